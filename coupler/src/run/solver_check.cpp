#include "cosim/coupler/run/solver_check.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "cosim/wire/message.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

void fillSetup(proto::Setup::Builder setup, const Scene& scene, const SolverSpec& s, InputAssembler& inputs,
               const fs::path& runDir, bool resuming) {
  setup.setSceneFile(scene.file);
  setup.setSceneYaml(scene.text);
  setup.setInstance(s.name);
  setup.setRunDir(fs::absolute(runDir).string());
  setup.setResuming(resuming);
  setup.setSceneDir(fs::absolute(scene.sceneDir).string());
  if (s.poolSize > 0) {
    auto pool = setup.initPool();
    pool.setEntry(s.poolEntry);
    pool.setIndex(static_cast<std::uint32_t>(s.poolIndex));
    pool.setSize(static_cast<std::uint32_t>(s.poolSize));
  }
  inputs.build(setup.initInputs());
}

namespace {

// A setup is a solver's own work: a large mesh or pack takes seconds, never this long.
constexpr double kCheckTimeoutS = 600.0;

struct Check {
  std::string solver;
  pid_t pid = -1;
  fs::path log;
};

pid_t startCheck(const SolverSpec& s, const fs::path& setupFile, const fs::path& log) {
  std::vector<std::string> args{s.binary, "--check", setupFile.string()};
  args.insert(args.end(), s.args.begin(), s.args.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("cannot start the check of solver '" + s.name + "': fork failed");
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    ::execv(s.binary.c_str(), argv.data());
    const char msg[] = "exec of the solver binary failed\n";
    (void)!::write(STDERR_FILENO, msg, sizeof msg - 1);
    ::_exit(127);
  }
  return pid;
}

// The solver's own words: its last non-empty lines, without the log prefix.
std::string message(const fs::path& log) {
  std::ifstream in(log);
  std::string line, text;
  while (std::getline(in, line))
    if (!line.empty()) text += (text.empty() ? "" : "\n    ") + line;
  return text.empty() ? "(no message)" : text;
}

/// What a check's exit says: nothing (accepted), a refusal of the scene
/// (exit 2, the contract of --check), or a failure of the binary (any other
/// exit, a signal, no end in time), which is no fault of the scene.
struct CheckOutcome {
  std::string problem;
  bool failed = false;
};

CheckOutcome outcome(const Check& c, long& peakKb) {
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  struct rusage usage {};
  while (::wait4(c.pid, &status, WNOHANG, &usage) == 0) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > kCheckTimeoutS) {
      ::kill(c.pid, SIGKILL);
      ::waitpid(c.pid, &status, 0);
      return {"solver '" + c.solver + "' did not finish checking its params in " +
                  std::to_string(static_cast<int>(kCheckTimeoutS)) + " s", true};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  peakKb = usage.ru_maxrss;  // kB on Linux
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return {};
  if (WIFEXITED(status) && WEXITSTATUS(status) == 2)
    return {"solver '" + c.solver + "' refuses its params (exit 2): " + message(c.log), false};
  const std::string how = WIFEXITED(status) ? "exited with code " + std::to_string(WEXITSTATUS(status))
                                            : "was killed by signal " + std::to_string(WTERMSIG(status));
  return {"solver '" + c.solver + "' " + how + " while checking its params: " + message(c.log), true};
}

}  // namespace

SolverCheckResult checkSolverParams(const Scene& scene, const fs::path& scratch) {
  fs::create_directories(scratch);
  std::map<std::string, InputAssembler> inputs;
  for (const auto& c : scene.couplings) c->stageSetup(inputs);
  std::vector<Check> checks;
  SolverCheckResult result;
  for (const auto& s : scene.solvers) {
    if (s.launch == SolverSpec::Launch::attach) continue;  // a job step's binary is checked here, on the coupler's host
    const fs::path dir = scratch / s.name;
    fs::create_directories(dir / "run");
    auto& staged = inputs[s.name];
    wire::OutMessage m(scene.text.size() / 8 + 256 + staged.words());
    fillSetup(m.envelope().getBody().initSetup(), scene, s, staged, dir / "run", false);
    const fs::path file = dir / "setup.bin";
    wire::InMessage::decode(m.frames()).save(file.string());
    checks.push_back({s.name, startCheck(s, file, dir / "check.log"), dir / "check.log"});
  }
  for (const auto& c : checks) {
    long peakKb = 0;
    auto o = outcome(c, peakKb);
    if (o.problem.empty()) result.peakResidentKb[c.solver] = peakKb;
    else (o.failed ? result.failures : result.problems).push_back(std::move(o.problem));
  }
  std::error_code ignored;
  fs::remove_all(scratch, ignored);
  return result;
}

void describeSetupMemory(const Scene& scene, const SolverCheckResult& checked, std::ostream& out) {
  if (checked.peakResidentKb.empty()) return;
  const auto mb = [](long kb) { return std::to_string((kb + 512) / 1024) + " MB"; };
  std::vector<std::string> entries;
  struct Pool {
    int workers = 0;
    long sumKb = 0, largestKb = 0;
  };
  std::map<std::string, Pool> pools;
  for (const auto& s : scene.solvers) {
    const auto it = checked.peakResidentKb.find(s.name);
    if (it == checked.peakResidentKb.end()) continue;
    if (s.poolSize == 0) {
      entries.push_back(s.name + " " + mb(it->second));
      continue;
    }
    auto& pool = pools[s.poolEntry];
    ++pool.workers;
    pool.sumKb += it->second;
    pool.largestKb = std::max(pool.largestKb, it->second);
  }
  for (const auto& [entry, pool] : pools)
    entries.push_back("pool " + entry + " " + std::to_string(pool.workers) + " workers, " + mb(pool.sumKb) +
                      " (at most " + mb(pool.largestKb) + " each)");
  out << "setup memory (peak resident size of each solver's check):";
  for (std::size_t k = 0; k < entries.size(); ++k) out << (k ? "; " : " ") << entries[k];
  out << "\n";
}

}  // namespace cosim::coupler
