#pragma once
// The solver processes a run starts. Children get their own process group
// (a terminal's Ctrl-C reaches only the coupler, which then stops them in
// order) and die with the coupler even if it is killed outright
// (PR_SET_PDEATHSIG). Nothing is left behind: the destructor terminates and
// reaps every child still running.
#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

namespace cosim::coupler {

class ProcessGroup {
 public:
  ProcessGroup() = default;
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;
  ~ProcessGroup();

  /// Starts binary with args and extra environment entries ("KEY=value");
  /// throws std::runtime_error when it cannot.
  pid_t spawn(const std::string& name, const std::string& binary, const std::vector<std::string>& args,
              const std::vector<std::string>& extraEnvironment = {});

  struct Exit {
    std::string name;
    pid_t pid = 0;
    std::string how;  // "exited with code 3", "was killed by signal 9 (Killed)"
  };
  /// A child that ended since the last call (without blocking), if any.
  std::optional<Exit> reapOne();
  /// Waits up to politeS for children to leave on their own, then SIGTERM,
  /// SIGKILL after graceS more, and reaps them all.
  void terminateAll(double politeS, double graceS);
  std::vector<pid_t> livePids() const;
  /// SIGKILL to a child known to be broken (hung or misbehaving); reaps it.
  void kill(const std::string& name);

 private:
  struct Child {
    std::string name;
    pid_t pid = 0;
    bool running = true;
  };
  bool reapFinished();  // true while any child still runs
  void waitWhileRunning(double seconds);
  std::vector<Child> children_;
};

/// SIGINT/SIGTERM set a flag instead of killing the coupler, so a run can stop cleanly.
void installStopSignalHandlers();
/// The signal that asked to stop, or 0.
int stopSignal();

}  // namespace cosim::coupler
