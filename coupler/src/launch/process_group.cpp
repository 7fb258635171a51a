#include "cosim/coupler/launch/process_group.hpp"

#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "cosim/wire/clock.hpp"

namespace cosim::coupler {
namespace {

std::atomic<int> g_stopSignal{0};

extern "C" void onStopSignal(int sig) { g_stopSignal = sig; }

std::string describeStatus(int status) {
  if (WIFEXITED(status)) return "exited with code " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" + strsignal(WTERMSIG(status)) + ")";
  return "ended (status " + std::to_string(status) + ")";
}

}  // namespace

void installStopSignalHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::signal(SIGPIPE, SIG_IGN);
}

int stopSignal() { return g_stopSignal.load(); }

ProcessGroup::~ProcessGroup() { terminateAll(0.0, 2.0); }

pid_t ProcessGroup::spawn(const std::string& name, const std::string& binary, const std::vector<std::string>& args,
                          const std::vector<std::string>& extraEnvironment) {
  std::vector<std::string> argvStore{binary};
  argvStore.insert(argvStore.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argvStore) argv.push_back(a.data());
  argv.push_back(nullptr);
  // The environment is assembled before fork: after it, only async-signal-safe calls.
  std::vector<std::string> envStore(extraEnvironment);
  for (char** e = environ; *e; ++e) envStore.emplace_back(*e);
  std::vector<char*> envp;
  for (auto& e : envStore) envp.push_back(e.data());
  envp.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("cannot start '" + name + "' (" + binary + "): fork failed: " + std::strerror(errno));
  if (pid == 0) {
    // Child: only async-signal-safe calls until exec.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);  // the coupler died before prctl took effect
    ::setpgid(0, 0);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::execve(binary.c_str(), argv.data(), envp.data());
    const char msg[] = "coupler: exec of a solver binary failed\n";
    [[maybe_unused]] auto ignored = ::write(2, msg, sizeof(msg) - 1);
    ::_exit(127);
  }
  ::setpgid(pid, pid);  // as the child does: its group exists before any signal is sent to it
  children_.push_back({name, pid, true});
  return pid;
}

namespace {
// A solver's own children (a wrapper's job step, a helper it started) share its
// process group: signals go to the whole group, so none of them outlives the run.
// Called only while the solver's pid is ours (running, or just reaped), so the
// group is the one it made.
void signalGroup(pid_t pid, int sig) {
  if (::kill(-pid, sig) != 0) ::kill(pid, sig);
}
}  // namespace

std::optional<ProcessGroup::Exit> ProcessGroup::reapOne() {
  for (auto& c : children_) {
    if (!c.running) continue;
    int status = 0;
    const pid_t r = ::waitpid(c.pid, &status, WNOHANG);
    if (r == c.pid) {
      c.running = false;
      ::kill(-c.pid, SIGKILL);  // what it left behind in its group
      return Exit{c.name, c.pid, describeStatus(status)};
    }
  }
  return std::nullopt;
}

std::vector<pid_t> ProcessGroup::livePids() const {
  std::vector<pid_t> pids;
  for (const auto& c : children_)
    if (c.running) pids.push_back(c.pid);
  return pids;
}

void ProcessGroup::kill(const std::string& name) {
  for (auto& c : children_)
    if (c.name == name && c.running) {
      signalGroup(c.pid, SIGKILL);
      int status = 0;
      ::waitpid(c.pid, &status, 0);
      c.running = false;
    }
}

bool ProcessGroup::reapFinished() {
  bool anyRunning = false;
  for (auto& c : children_) {
    if (!c.running) continue;
    int status = 0;
    if (::waitpid(c.pid, &status, WNOHANG) == c.pid) {
      c.running = false;
      ::kill(-c.pid, SIGKILL);  // what it left behind in its group
    } else {
      anyRunning = true;
    }
  }
  return anyRunning;
}

void ProcessGroup::waitWhileRunning(double seconds) {
  const double end = monotonicSeconds() + seconds;
  while (reapFinished() && monotonicSeconds() < end) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

void ProcessGroup::terminateAll(double politeS, double graceS) {
  waitWhileRunning(politeS);  // children asked to shut down leave by themselves
  for (auto& c : children_)
    if (c.running) signalGroup(c.pid, SIGTERM);
  waitWhileRunning(graceS);
  for (auto& c : children_)
    if (c.running) {
      signalGroup(c.pid, SIGKILL);  // also ends a stopped (SIGSTOP) child
      int status = 0;
      ::waitpid(c.pid, &status, 0);
      c.running = false;
    }
}

}  // namespace cosim::coupler
