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
/// SLURM_JOB_NODELIST, SLURM_HET_SIZE), if any.
struct SlurmAllocation {
  std::string jobId;
  int nodes = 1;
  std::string nodeList;
  int components = 0;  // of a heterogeneous job; 0: a homogeneous one
};
std::optional<SlurmAllocation> currentSlurmAllocation();
/// The nodes of component hetGroup of the allocation (SLURM_JOB_NUM_NODES_HET_GROUP_k), or of all of it (-1).
int slurmNodesOf(const SlurmAllocation& allocation, int hetGroup);

/// The arguments after `srun` that start `solver` as a one-task job step
/// running `binary` with `solverArgs`, in component `hetGroup` of a
/// heterogeneous job (-1: a homogeneous one).
std::vector<std::string> srunArguments(const SolverSpec& solver, const std::vector<std::string>& solverArgs,
                                       int hetGroup = -1);

/// The nodes a pool worker's workers_per_node spreads its pool over (0 without it).
int nodesOfPool(const SolverSpec& worker);

/// One component of the (heterogeneous) job a scene asks for: tasks alike in
/// cores and memory.
struct JobComponent {
  int tasks = 1;
  int cpusPerTask = 1;
  std::string memory;                 // per task (srun --mem); empty: the partition's default
  std::vector<std::string> solvers;   // the srun solvers it holds; none in component 0
  int nodes = 0;                      // the nodes its pools' workers_per_node place them on; 0: any
  long memoryPerCpuMb() const;        // for #SBATCH --mem-per-cpu; 0 without memory
};

/// What a scene's processes ask for: component 0 is the coupler's task, with
/// one core for it and one per solver it spawns; each further component holds
/// the srun solvers of one (cores, memory), in the order the scene names them.
struct ResourcePlan {
  int localProcesses = 1;  // the coupler and its spawned solvers
  int steps = 0;           // srun solvers
  int attached = 0;        // started by the user
  std::vector<JobComponent> components;
  int cores() const;
  /// The component (srun --het-group) of an srun solver; -1 for any other.
  int componentOf(const std::string& solver) const;
};
ResourcePlan planResources(const Scene& scene);
void describeResources(const Scene& scene, std::ostream& out);

struct SbatchOptions {
  std::string outDir;     // the run directory (--out); empty: the scene's output.dir
  std::string partition;  // #SBATCH --partition, if given
  std::string time;       // #SBATCH --time, if given
  bool heterogeneous = false;  // one job component per kind of task (#SBATCH hetjob), else every task alike
};
/// A batch script that asks for the plan's allocation and runs the scene in
/// it: every task sized for the largest one, or with `heterogeneous` a
/// heterogeneous job of the plan's components.
std::string sbatchScript(const Scene& scene, const std::string& couplerBinary, const SbatchOptions& options);

}  // namespace cosim::coupler
