#pragma once
// Runs on a Slurm cluster (docs/cluster.md): solvers with `launch: srun` start
// as job steps of the allocation the coupler runs in; `coupler sbatch` writes
// the batch script that asks for that allocation; `coupler check` prints the
// plan both are sized from.
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace cosim::coupler {

struct Scene;
struct SolverSpec;

/// The allocation this process runs in (SLURM_JOB_ID, SLURM_JOB_NUM_NODES,
/// SLURM_JOB_NODELIST), if any.
struct SlurmAllocation {
  std::string jobId;
  int nodes = 1;
  std::string nodeList;
};
std::optional<SlurmAllocation> currentSlurmAllocation();

/// The arguments after `srun` that start `solver` as a one-task job step
/// running `binary` with `solverArgs`.
std::vector<std::string> srunArguments(const SolverSpec& solver, const std::vector<std::string>& solverArgs);

/// What a scene's processes ask for: the coupler and the solvers it spawns
/// share one task (one core each); each srun solver is a task of its own.
struct ResourcePlan {
  int localProcesses = 1;  // the coupler and its spawned solvers
  int steps = 0;           // srun solvers
  int attached = 0;        // started by the user
  int tasks = 1;           // the allocation: the coupler's task and one per step
  int cpusPerTask = 1;     // the largest task's cores (a homogeneous allocation)
  int coresUsed = 1;       // what the tasks need
  long memoryPerCpuMb = 0; // the largest step's memory per core; 0: some step names none
};
ResourcePlan planResources(const Scene& scene);
void describeResources(const Scene& scene, std::ostream& out);

struct SbatchOptions {
  std::string outDir;     // the run directory (--out); empty: the scene's output.dir
  std::string partition;  // #SBATCH --partition, if given
  std::string time;       // #SBATCH --time, if given
};
/// A batch script that asks for the plan's allocation and runs the scene in it.
std::string sbatchScript(const Scene& scene, const std::string& couplerBinary, const SbatchOptions& options);

}  // namespace cosim::coupler
