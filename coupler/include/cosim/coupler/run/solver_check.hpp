#pragma once
// Each solver's section of a scene checked by the solver itself, before a run
// starts it for real: the coupler writes the setup message the run would send
// and the solver's binary sets up from it (`BINARY --check FILE`) in a scratch
// run directory, then exits. So `coupler check` finds what only a solver can
// judge (its params, meshes, particle and cell files) and `coupler run` refuses
// such a scene before any process starts.
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"

namespace cosim::coupler {

/// The setup message of solver `s`: the scene, where it runs and writes, and
/// the inputs the couplings staged for it.
void fillSetup(proto::Setup::Builder setup, const Scene& scene, const SolverSpec& s, InputAssembler& inputs,
               const std::filesystem::path& runDir, bool resuming);

struct SolverCheckResult {
  /// One per solver that refused its section, naming the solver and carrying its own message.
  std::vector<std::string> problems;
  /// One per solver whose check failed without a verdict (crashed, killed,
  /// exited otherwise, or ran out of time): the binary's fault, not the scene's.
  std::vector<std::string> failures;
  /// The peak resident size of each solver's check [kB] (the kernel's count
  /// for the process): what its setup took, meshes, particles and cells loaded.
  std::map<std::string, long> peakResidentKb;
};

/// Checks every solver the coupler starts (not those attached by hand), all
/// at once, in run directories under `scratch` (removed afterwards).
SolverCheckResult checkSolverParams(const Scene& scene, const std::filesystem::path& scratch);

/// The checks' memory, one entry per solver and one per pool (its workers' sum), as `coupler check` prints it.
void describeSetupMemory(const Scene& scene, const SolverCheckResult& checked, std::ostream& out);

}  // namespace cosim::coupler
