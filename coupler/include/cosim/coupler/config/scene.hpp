#pragma once
// The scene: one YAML file describing a run. Loading validates everything
// that can be checked without starting a process.
#include <memory>
#include <string>
#include <vector>

#include "cosim/coupler/analysis/reference.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/coupler/schedule/schedule.hpp"
#include "cosim/wire/endpoint.hpp"
#include "cosim/wire/peer_session.hpp"

namespace cosim::coupler {

/// What a solver started as a Slurm job step asks for (`resources:` with
/// `launch: srun`; docs/cluster.md). A solver instance is one process (one
/// task on one node) with cpusPerTask cores for its OpenMP threads.
struct SlurmResources {
  int cpusPerTask = 1;
  std::string memory;    // srun --mem (e.g. 4G); empty: the allocation's default
  bool overlap = false;  // share CPUs with the run's other steps (srun --overlap)
};

struct SolverSpec {
  std::string name;
  std::string kind;
  std::string binary;  // resolved path of the executable (spawn, srun), as written otherwise
  /// spawn: a child process here; attach: started by the user, it connects;
  /// srun: a job step of the Slurm allocation the coupler runs in.
  enum class Launch { spawn, attach, srun } launch = Launch::spawn;
  SlurmResources resources;  // launch: srun
  std::vector<std::string> args;
  std::vector<std::string> extraCapabilities;  // `requires:` in the scene
  int line = 0;
  /// A worker of a pool entry (`pool: {workers: N, workers_per_node: M}`):
  /// the entry's name, whose params it reads, this worker's index and N
  /// (poolSize 0: not in a pool). Worker k is named `<entry>-<k>`.
  std::string poolEntry;
  int poolIndex = 0, poolSize = 0;
  int workersPerNode = 0;  // launch: srun: worker k runs on node k / M of its job component; 0: where Slurm puts it
};

/// The solvers a name in a scene's list of solvers stands for: a pool entry's
/// workers, else the solver of that name; empty when neither is declared.
std::vector<std::string> solversNamed(const std::string& name, const std::vector<SolverSpec>& solvers);
/// The declared names for a message: each solver, a pool once by its entry's name.
std::string declaredSolverNames(const std::vector<SolverSpec>& solvers);

struct RecordSpec {
  std::string solver;
  std::string array;
};

struct OutputSpec {
  std::string dir;            // run directory (relative to the working directory)
  long flushInterval = 100;   // exchanges between flushes of coupler.h5
  long seriesEvery = 1;       // exchanges between rows of /series (analyses still see every exchange)
  long checkpointInterval = 0;  // exchanges between checkpoints of every solver (0 = none)
  std::vector<RecordSpec> record;  // solver arrays stored in /series every exchange
};

/// Where the run's processes may run (`placement:`). spread: where the OS puts
/// them. packed: the coupler and every solver it starts share `cpus`, by default
/// the one CPU the coupler starts on; for lockstep runs whose exchanges are
/// short this replaces cross-CPU wake-ups by local switches (docs/protocol.md).
/// Solvers started elsewhere (`launch: attach`) are not moved.
struct PlacementSpec {
  enum class Kind { spread, packed } kind = Kind::spread;
  std::vector<int> cpus;  // packed: empty = the coupler's CPU at start
};

struct Scene {
  std::string file;
  std::string sceneDir;  // relative paths in the scene resolve here (the user's file's directory)
  std::string text;
  std::string name;
  std::string description;
  wire::TransportOptions transport;
  // Which transport keys the scene wrote (launch: srun changes the defaults).
  bool transportKindGiven = false, transportInterfaceGiven = false, transportCurveGiven = false;
  wire::LinkOptions link;
  double connectTimeoutS = 30.0;
  std::vector<SolverSpec> solvers;
  std::vector<std::unique_ptr<Coupling>> couplings;
  std::unique_ptr<Schedule> schedule;
  std::unique_ptr<Reference> reference;  // `analysis:`; null when the scene names none
  OutputSpec output;
  PlacementSpec placement;

  const SolverSpec* solver(const std::string& name) const;
  /// Whether a solver is started by srun (and so may run on another host).
  bool usesSlurm() const;
  /// Capabilities the run needs from one solver (schedule, couplings, output, requires).
  std::vector<std::string> requiredCapabilities(const std::string& solver) const;
};

/// Loads and validates; throws config::ConfigError (all problems, each `file:line: message`).
Scene loadScene(const std::string& path);
/// The same from scene text: messages name displayName; binaries given as paths
/// resolve against sceneDir (the directory of the scene file the text came from).
Scene loadSceneText(const std::string& text, const std::string& displayName, const std::string& sceneDir);

/// Where a solver binary named without a directory is looked for: $COSIM_BIN_DIR,
/// the coupler's own directory, then $PATH. Empty when not found.
std::string findExecutable(const std::string& name, const std::string& sceneDir);

}  // namespace cosim::coupler
