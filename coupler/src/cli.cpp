#include "cosim/coupler/cli.hpp"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene_overrides.hpp"
#include "cosim/coupler/launch/slurm.hpp"
#include "cosim/coupler/run/coupler_run.hpp"
#include "cosim/coupler/run/solver_check.hpp"
#include "cosim/coupler/sweep/sweep.hpp"
#include "cosim/wire/log.hpp"
#include "cosim/wire/message.hpp"

namespace cosim::coupler {
namespace {

constexpr const char* kUsage =
    "usage: coupler run SCENE.yaml [--set KEY=VALUE ...] [--out DIR] [--resume] [--force] [--no-progress]\n"
    "                              [--exchanges N]\n"
    "                  [--log-level LEVEL]\n"
    "       coupler check SCENE.yaml [--set KEY=VALUE ...] [--out DIR]\n"
    "       coupler sbatch SCENE.yaml [--set KEY=VALUE ...] [--out DIR] [--partition P] [--time T]\n"
    "                              [--heterogeneous]\n"
    "       coupler sweep SCENE.yaml --set KEY=V1,V2,... [--set KEY2=A,B ...] [--out DIR] [--jobs N] [--force]\n"
    "\n"
    "  run    validate the scene, start the solvers it names, run it, write DIR/coupler.h5\n"
    "         and DIR/run_report.json (DIR defaults to the scene's output.dir)\n"
    "  check  validate the scene, print the coupling graph and the processes it would\n"
    "         start, and have each solver check its section (BINARY --check: it sets up\n"
    "         in a scratch directory and exits); runs nothing\n"
    "  sbatch write DIR/<scene>.sbatch, a Slurm batch script that asks for the allocation the\n"
    "         scene's solvers need (launch: srun, resources:) and runs it there; prints how to\n"
    "         submit it; --heterogeneous: one job component per kind of task (docs/cluster.md)\n"
    "  sweep  run the scene once per combination of the --set values (cartesian product),\n"
    "         each as a `coupler run` into DIR/<index>_<key=value...>/ (output in its\n"
    "         coupler.log); write DIR/sweep.csv and plots of error against wall time\n"
    "         (scripts/plot_sweep.py; DIR defaults to runs/<scene file stem>-sweep)\n"
    "\n"
    "  --set KEY=VALUE  change the scene before validation; KEY is a path of map keys\n"
    "                 separated by '.', list items as [N] or by their name\n"
    "                 (schedule.dt=1e-5, solvers.left.params.seed=3,\n"
    "                 solvers[1].params.gravity=[0,0,-9.81]); VALUE is YAML. The changed\n"
    "                 scene is written to DIR/scene.effective.yaml, which messages name.\n"
    "                 In a sweep, commas separate values except inside [] {} or quotes\n"
    "  --resume       continue the run in DIR from its last complete checkpoint\n"
    "                 (output.checkpoint_interval); the scene must be unchanged\n"
    "  --force        run even if dt exceeds a solver's critical time step\n"
    "  --no-progress  no progress line on stderr\n"
    "  --exchanges N  stop after N exchanges (0: start and set up every solver, then stop)\n"
    "  --log-level    debug, info, warn, error or quiet\n"
    "  --jobs N       sweep: runs at once (default 1)\n"
    "\n"
    "exit codes: 0 done, 1 coupler failure, 2 invalid scene or usage, 3 refused before time\n"
    "zero (handshake, capabilities, setup, stability), 4 a peer failed during the run,\n"
    "130 interrupted; sweep: 0 every run completed, 1 some did not, 2 usage, 130 interrupted\n";

std::uint64_t parseExchangeCount(const std::string& text) {
  const bool digits = !text.empty() && text.size() < 16 &&
                      std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
  if (!digits) throw std::invalid_argument("--exchanges: expected a whole number of exchanges (0 or more), got '" + text + "'");
  return std::stoull(text);
}

/// `coupler sbatch`: the batch script, in the run directory (which Slurm needs
/// to exist for the job's output file).
int writeSbatch(const Scene& scene, const SbatchOptions& options) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::absolute(options.outDir.empty() ? scene.output.dir : options.outDir);
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  const fs::path file = dir / (scene.name + ".sbatch");
  fs::create_directories(dir, ec);
  std::ofstream out(file);
  out << sbatchScript(scene, ec ? std::string("coupler") : self.string(), options);
  if (!out) {
    std::cerr << "coupler: cannot write " << file.string() << "\n";
    return kExitFailure;
  }
  out.close();
  fs::permissions(file, fs::perms::owner_exec, fs::perm_options::add, ec);
  describeResources(scene, std::cout);
  std::cout << "wrote " << file.string() << "\nsubmit it with: sbatch " << file.string() << "\n";
  return kExitOk;
}

int usageError(const std::string& message) {
  std::cerr << "coupler: " << message << "\n" << kUsage;
  return kExitBadConfig;
}

}  // namespace

int couplerMain(int argc, char** argv) {
  wire::keepLargeBuffersOnHeap();
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) return usageError("no command given");
  if (args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    std::cout << kUsage;
    return kExitOk;
  }
  const std::string command = args[0];
  if (command == "sweep") {
    try {
      return sweepMain(parseSweepArguments({args.begin() + 1, args.end()}));
    } catch (const std::invalid_argument& e) {
      return usageError(e.what());
    }
  }
  if (command != "run" && command != "check" && command != "sbatch")
    return usageError("unknown command '" + command + "'");
  std::string scenePath;
  RunOptions options;
  std::vector<SceneOverride> overrides;
  SbatchOptions batch;
  for (std::size_t i = 1; i < args.size(); ++i) {
    const auto& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
      return args[++i];
    };
    try {
      if (a == "--out") options.outDir = value();
      else if (a == "--set") overrides.push_back(parseOverride(value()));
      else if (a == "--force") options.force = true;
      else if (a == "--resume") options.resume = true;
      else if (a == "--no-progress") options.progress = false;
      else if (a == "--exchanges") options.stopAfter = parseExchangeCount(value());
      else if (a == "--log-level") log::setLevel(log::parseLevel(value()));
      else if (command == "sbatch" && a == "--partition") batch.partition = value();
      else if (command == "sbatch" && a == "--time") batch.time = value();
      else if (command == "sbatch" && a == "--heterogeneous") batch.heterogeneous = true;
      else if (!a.empty() && a[0] == '-') return usageError("unknown option '" + a + "'");
      else if (scenePath.empty()) scenePath = a;
      else return usageError("more than one scene given ('" + scenePath + "', '" + a + "')");
    } catch (const std::exception& e) {
      return usageError(e.what());
    }
  }
  if (scenePath.empty()) return usageError("no scene file given");
  log::setPrefix("coupler");
  try {
    const Scene scene = loadSceneWithOverrides(scenePath, overrides, options.outDir);
    if (!overrides.empty()) std::cout << "effective scene: " << scene.file << "\n";
    if (command == "check") {
      describeScene(scene, std::cout);
      const auto checked = checkSolverParams(scene, solverCheckDirectory());
      const auto& problems = checked.problems;
      for (const auto& p : problems) std::cerr << scene.file << ": " << p << "\n";
      for (const auto& f : checked.failures) std::cerr << "coupler: " << f << "\n";
      describeSetupMemory(scene, checked, std::cout);
      std::cout << "solver params: "
                << (!problems.empty()          ? std::to_string(problems.size()) + " solver(s) refuse theirs"
                    : !checked.failures.empty() ? std::to_string(checked.failures.size()) + " solver(s) failed to check theirs"
                                                : std::string("every solver the run starts accepts its section"))
                << "\n";
      if (!problems.empty()) return kExitBadConfig;
      return checked.failures.empty() ? kExitOk : kExitRefused;
    }
    if (command == "sbatch") {
      batch.outDir = options.outDir;
      return writeSbatch(scene, batch);
    }
    return runScene(scene, options);
  } catch (const config::ConfigError& e) {
    std::cerr << e.what() << "\n";
    return kExitBadConfig;
  } catch (const OverrideError& e) {
    std::cerr << "coupler: " << e.what() << "\n";
    return kExitBadConfig;
  }
}

}  // namespace cosim::coupler
