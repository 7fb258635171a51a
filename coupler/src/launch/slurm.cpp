#include "cosim/coupler/launch/slurm.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "cosim/coupler/config/scene.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {

std::string environment(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

/// srun --mem's size in MB (its default unit): 512, 512M, 4G, 1T, 100K.
long megabytes(const std::string& size) {
  if (size.empty()) return 0;
  const char unit = size.back();
  const bool suffixed = unit == 'K' || unit == 'M' || unit == 'G' || unit == 'T';
  const long value = std::stol(suffixed ? size.substr(0, size.size() - 1) : size);
  switch (unit) {
    case 'K': return std::max(1L, value / 1024);
    case 'G': return value * 1024;
    case 'T': return value * 1024 * 1024;
    default: return value;
  }
}

/// The shell's quoting of one word.
std::string quoted(const std::string& word) {
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::optional<SlurmAllocation> currentSlurmAllocation() {
  SlurmAllocation a;
  a.jobId = environment("SLURM_JOB_ID");
  if (a.jobId.empty()) return std::nullopt;
  const std::string nodes = environment("SLURM_JOB_NUM_NODES");
  a.nodes = nodes.empty() ? 1 : std::max(1, std::atoi(nodes.c_str()));
  a.nodeList = environment("SLURM_JOB_NODELIST");
  const std::string het = environment("SLURM_HET_SIZE");
  a.components = het.empty() ? 0 : std::max(0, std::atoi(het.c_str()));
  return a;
}

int slurmNodesOf(const SlurmAllocation& allocation, int hetGroup) {
  if (hetGroup >= 0) {
    const std::string n = environment(("SLURM_JOB_NUM_NODES_HET_GROUP_" + std::to_string(hetGroup)).c_str());
    if (!n.empty()) return std::max(1, std::atoi(n.c_str()));
  }
  return allocation.nodes;
}

std::vector<std::string> srunArguments(const SolverSpec& solver, const std::vector<std::string>& solverArgs,
                                       int hetGroup) {
  const auto& r = solver.resources;
  std::vector<std::string> args{"--job-name=" + solver.name};
  if (hetGroup >= 0) args.push_back("--het-group=" + std::to_string(hetGroup));
  for (std::string a : {"--nodes=1", "--ntasks=1"}) args.push_back(a);
  // A pool's workers_per_node: worker k on the (k / M)-th node of its component.
  if (solver.poolSize > 0 && solver.workersPerNode > 0)
    args.push_back("--relative=" + std::to_string(solver.poolIndex / solver.workersPerNode));
  args.push_back("--cpus-per-task=" + std::to_string(r.cpusPerTask));
  // The solver's OpenMP threads use the cores its step holds.
  args.push_back("--export=ALL,OMP_NUM_THREADS=" + std::to_string(r.cpusPerTask));
  // Steps get only what they ask for, so the others start beside them;
  // overlap lets them share cores (a small allocation, a test).
  args.push_back(r.overlap ? "--overlap" : "--exact");
  args.push_back("--quiet");
  if (!r.memory.empty()) args.push_back("--mem=" + r.memory);
  args.push_back("--");
  args.push_back(solver.binary);
  args.insert(args.end(), solverArgs.begin(), solverArgs.end());
  return args;
}

int nodesOfPool(const SolverSpec& worker) {
  return worker.workersPerNode > 0 ? (worker.poolSize + worker.workersPerNode - 1) / worker.workersPerNode : 0;
}

long JobComponent::memoryPerCpuMb() const { return memory.empty() ? 0 : (megabytes(memory) + cpusPerTask - 1) / cpusPerTask; }

int ResourcePlan::cores() const {
  int n = 0;
  for (const auto& c : components) n += c.tasks * c.cpusPerTask;
  return n;
}

int ResourcePlan::componentOf(const std::string& solver) const {
  for (std::size_t k = 1; k < components.size(); ++k)
    if (std::find(components[k].solvers.begin(), components[k].solvers.end(), solver) != components[k].solvers.end())
      return static_cast<int>(k);
  return -1;
}

ResourcePlan planResources(const Scene& scene) {
  ResourcePlan p;
  p.components.push_back({});
  for (const auto& s : scene.solvers) {
    if (s.launch == SolverSpec::Launch::spawn) ++p.localProcesses;
    if (s.launch == SolverSpec::Launch::attach) ++p.attached;
    if (s.launch != SolverSpec::Launch::srun) continue;
    ++p.steps;
    auto alike = std::find_if(p.components.begin() + 1, p.components.end(), [&](const JobComponent& c) {
      return c.cpusPerTask == s.resources.cpusPerTask && c.memory == s.resources.memory;
    });
    if (alike == p.components.end()) {
      p.components.push_back({0, s.resources.cpusPerTask, s.resources.memory, {}});
      alike = p.components.end() - 1;
    }
    ++alike->tasks;
    alike->solvers.push_back(s.name);
    if (s.poolSize > 0 && s.workersPerNode > 0)
      alike->nodes = std::max(alike->nodes, nodesOfPool(s));
  }
  p.components[0].cpusPerTask = p.localProcesses;
  return p;
}

void describeResources(const Scene& scene, std::ostream& out) {
  if (!scene.usesSlurm()) return;
  const auto p = planResources(scene);
  out << "slurm: " << p.steps << " solver(s) as job steps, " << p.localProcesses
      << " process(es) in the coupler's task (the coupler and the solvers it spawns)";
  if (p.attached) out << ", " << p.attached << " attached";
  out << "\n  job: " << p.components.size() << " component(s), " << p.cores() << " cores\n";
  for (std::size_t k = 0; k < p.components.size(); ++k) {
    const auto& c = p.components[k];
    out << "  component " << k << ": " << c.tasks << " task(s) x " << c.cpusPerTask << " core(s)"
        << (c.memory.empty() ? std::string() : ", " + c.memory + " each") << ": ";
    if (c.nodes > 0) out << "on " << c.nodes << " node(s): ";
    if (k == 0) out << "the coupler";
    for (std::size_t i = 0; i < c.solvers.size(); ++i) out << (i ? ", " : "") << c.solvers[i];
    out << "\n";
  }
  for (const auto& s : scene.solvers)
    if (s.poolSize > 0 && s.poolIndex == 0)
      out << "  pool " << s.poolEntry << ": " << s.poolSize << " workers (" << s.name << " .. " << s.poolEntry << "-"
          << s.poolSize - 1 << ")"
          << (s.workersPerNode > 0 ? ", " + std::to_string(s.workersPerNode) + " per node on " +
                                         std::to_string(nodesOfPool(s)) + " node(s)"
                                   : std::string(", where Slurm places them"))
          << "\n";
}

namespace {
std::string taskRequest(int tasks, int cpus, long memoryPerCpuMb, int nodes, const SbatchOptions& options) {
  std::ostringstream s;
  if (nodes > 0) s << "--nodes=" << nodes << " --ntasks-per-node=" << (tasks + nodes - 1) / nodes << " ";
  s << "--ntasks=" << tasks << " --cpus-per-task=" << cpus;
  if (memoryPerCpuMb > 0) s << " --mem-per-cpu=" << memoryPerCpuMb << "M";
  if (!options.partition.empty()) s << " --partition=" << options.partition;
  if (!options.time.empty()) s << " --time=" << options.time;
  return s.str();
}
}  // namespace

std::string sbatchScript(const Scene& scene, const std::string& couplerBinary, const SbatchOptions& options) {
  const auto p = planResources(scene);
  const std::string out = fs::absolute(options.outDir.empty() ? scene.output.dir : options.outDir).string();
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "#SBATCH --job-name=" << scene.name << "\n"
    << "#SBATCH --output=" << out << "/slurm-%j.out\n";
  if (options.heterogeneous) {
    // One component per kind of task: the coupler's, then the job steps'
    // (the coupler starts each step in its component with srun --het-group).
    for (std::size_t k = 0; k < p.components.size(); ++k) {
      if (k > 0) s << "#SBATCH hetjob\n";
      const auto& c = p.components[k];
      s << "#SBATCH " << taskRequest(c.tasks, c.cpusPerTask, c.memoryPerCpuMb(), c.nodes, options) << "\n";
    }
  } else {
    // Every task sized for the largest: what any Slurm schedules.
    int tasks = 0, cpus = 1, nodes = 0;
    long memory = 0;
    bool allMemory = true;
    for (std::size_t k = 0; k < p.components.size(); ++k) {
      const auto& c = p.components[k];
      tasks += c.tasks;
      nodes = std::max(nodes, c.nodes);
      cpus = std::max(cpus, c.cpusPerTask);
      if (k > 0 && c.memory.empty()) allMemory = false;
      memory = std::max(memory, c.memoryPerCpuMb());
    }
    s << "#SBATCH " << taskRequest(tasks, cpus, allMemory ? memory : 0, nodes, options) << "\n";
    if (tasks * cpus > p.cores())
      s << "# (" << tasks * cpus - p.cores() << " of its " << tasks * cpus
        << " cores go unused: coupler sbatch --heterogeneous asks for each kind of task apart)\n";
  }
  s << "# Written by `coupler sbatch` for " << fs::absolute(scene.file).string() << ":\n"
    << "# the coupler runs in the batch step and starts the " << p.steps
    << " solver(s) with launch: srun as job steps of this allocation";
  if (p.localProcesses > 1) s << ", and " << p.localProcesses - 1 << " solver(s) beside it";
  s << ".\n"
    << "set -euo pipefail\n"
    << "mkdir -p " << quoted(out) << "\n"
    << "cd " << quoted(fs::current_path().string()) << "\n"
    << "exec " << quoted(couplerBinary) << " run " << quoted(fs::absolute(scene.file).string()) << " --out "
    << quoted(out) << " --no-progress\n";
  return s.str();
}

}  // namespace cosim::coupler
