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
  return a;
}

std::vector<std::string> srunArguments(const SolverSpec& solver, const std::vector<std::string>& solverArgs) {
  const auto& r = solver.resources;
  std::vector<std::string> args{"--job-name=" + solver.name, "--nodes=1", "--ntasks=1",
                                "--cpus-per-task=" + std::to_string(r.cpusPerTask),
                                // The solver's OpenMP threads use the cores its step holds.
                                "--export=ALL,OMP_NUM_THREADS=" + std::to_string(r.cpusPerTask),
                                // Steps get only what they ask for, so the others start beside them;
                                // overlap lets them share cores (a small allocation, a test).
                                r.overlap ? "--overlap" : "--exact", "--quiet"};
  if (!r.memory.empty()) args.push_back("--mem=" + r.memory);
  args.push_back("--");
  args.push_back(solver.binary);
  args.insert(args.end(), solverArgs.begin(), solverArgs.end());
  return args;
}

ResourcePlan planResources(const Scene& scene) {
  ResourcePlan p;
  bool allMemory = true;
  for (const auto& s : scene.solvers) {
    if (s.launch == SolverSpec::Launch::spawn) ++p.localProcesses;
    if (s.launch == SolverSpec::Launch::attach) ++p.attached;
    if (s.launch != SolverSpec::Launch::srun) continue;
    ++p.steps;
    p.cpusPerTask = std::max(p.cpusPerTask, s.resources.cpusPerTask);
    p.coresUsed += s.resources.cpusPerTask;
    if (s.resources.memory.empty()) allMemory = false;
    else p.memoryPerCpuMb = std::max(p.memoryPerCpuMb, (megabytes(s.resources.memory) + s.resources.cpusPerTask - 1) /
                                                            s.resources.cpusPerTask);
  }
  // The coupler's task holds a core for it and one per solver it spawns.
  p.cpusPerTask = std::max(p.cpusPerTask, p.localProcesses);
  p.coresUsed += p.localProcesses - 1;
  p.tasks = 1 + p.steps;
  if (!allMemory || p.steps == 0) p.memoryPerCpuMb = 0;
  return p;
}

void describeResources(const Scene& scene, std::ostream& out) {
  if (!scene.usesSlurm()) return;
  const auto p = planResources(scene);
  out << "slurm: " << p.steps << " solver(s) as job steps, " << p.localProcesses
      << " process(es) in the coupler's task (the coupler and the solvers it spawns)";
  if (p.attached) out << ", " << p.attached << " attached";
  out << "\n  allocation: " << p.tasks << " task(s) x " << p.cpusPerTask << " core(s) = " << p.tasks * p.cpusPerTask
      << " cores (" << p.coresUsed << " used";
  if (p.tasks * p.cpusPerTask > p.coresUsed) out << "; the tasks are sized for the largest one";
  out << ")";
  if (p.memoryPerCpuMb > 0) out << ", " << p.memoryPerCpuMb << " MB per core";
  else out << ", memory: the partition's default (give every srun solver resources.memory to size it)";
  out << "\n";
  for (const auto& s : scene.solvers)
    if (s.launch == SolverSpec::Launch::srun)
      out << "  " << s.name << ": 1 task, " << s.resources.cpusPerTask << " core(s)"
          << (s.resources.memory.empty() ? std::string() : ", " + s.resources.memory) << (s.resources.overlap ? ", overlap" : "")
          << "\n";
}

std::string sbatchScript(const Scene& scene, const std::string& couplerBinary, const SbatchOptions& options) {
  const auto p = planResources(scene);
  const std::string out = fs::absolute(options.outDir.empty() ? scene.output.dir : options.outDir).string();
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "#SBATCH --job-name=" << scene.name << "\n"
    << "#SBATCH --ntasks=" << p.tasks << "\n"
    << "#SBATCH --cpus-per-task=" << p.cpusPerTask << "\n";
  if (p.memoryPerCpuMb > 0) s << "#SBATCH --mem-per-cpu=" << p.memoryPerCpuMb << "M\n";
  if (!options.partition.empty()) s << "#SBATCH --partition=" << options.partition << "\n";
  if (!options.time.empty()) s << "#SBATCH --time=" << options.time << "\n";
  s << "#SBATCH --output=" << out << "/slurm-%j.out\n"
    << "# Written by `coupler sbatch` for " << fs::absolute(scene.file).string() << ":\n"
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
