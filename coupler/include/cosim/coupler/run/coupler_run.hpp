#pragma once
// One coupled run from a validated scene: launch or attach the solvers,
// check their hellos, set them up, let the schedule drive the exchanges, and
// always end with peers shut down, no child left, output flushed, and a report.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>

#include "cosim/coupler/config/scene.hpp"

namespace cosim::coupler {

/// Exit codes of `coupler run`.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,      // the coupler itself failed (output dir, HDF5 ...)
  kExitBadConfig = 2,    // the scene did not validate
  kExitRefused = 3,      // refused before time zero: handshake, capabilities, setup, stability
  kExitPeerFault = 4,    // a peer died, hung, or reported an error during the run
  kExitInterrupted = 130 // SIGINT/SIGTERM
};

struct RunOptions {
  std::string outDir;     // empty: the scene's output.dir
  bool force = false;     // run even when dt exceeds the critical step
  bool progress = true;
  bool resume = false;    // continue the run in the output dir from its last complete checkpoint
  /// --exchanges N: stop after N exchanges (0: start and set up every solver, then stop)
  std::optional<std::uint64_t> stopAfter;
};

int runScene(const Scene& scene, const RunOptions& options);

/// What `coupler check` prints: the coupling graph and the processes a run would start.
void describeScene(const Scene& scene, std::ostream& out);

/// Where the solvers check their params before a run or in `coupler check` (removed afterwards).
std::filesystem::path solverCheckDirectory();

}  // namespace cosim::coupler
