#pragma once
// Test support: run a real process with captured stdout/stderr, signal it,
// wait with a timeout; find processes by their command line (orphan checks).
#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace cosim::testing {

class Subprocess {
 public:
  explicit Subprocess(const std::vector<std::string>& argv);
  ~Subprocess();
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  pid_t pid() const { return pid_; }
  void signal(int sig) const;
  /// Waits up to timeoutS; kills the process (SIGKILL) when it runs longer.
  /// Returns the exit code, or 128 + signal when a signal ended it.
  int wait(double timeoutS);
  bool timedOut() const { return timedOut_; }
  const std::string& out() const { return out_; }
  const std::string& err() const { return err_; }

 private:
  void drain(double timeoutS);
  pid_t pid_ = -1;
  int outFd_ = -1;
  int errFd_ = -1;
  bool done_ = false;
  bool timedOut_ = false;
  int code_ = -1;
  std::string out_;
  std::string err_;
};

/// Runs to completion (or timeout) and returns the finished process.
struct Finished {
  int code = -1;
  bool timedOut = false;
  std::string out;
  std::string err;
  double wallS = 0.0;
};
Finished run(const std::vector<std::string>& argv, double timeoutS);

/// Pids of live processes whose command line contains needle (zombies excluded).
std::vector<pid_t> processesMentioning(const std::string& needle);

/// A fresh, short temporary directory. Made during a test, it is removed when
/// the test passes and kept (its path printed) when it fails; made outside one
/// (a suite's set-up), it is the caller's to remove.
std::filesystem::path freshDirectory(const std::string& prefix);

/// Copies a finished run's directory to `cut` and removes the newer of the
/// two checkpoints the run kept, so that `--resume` on `cut` continues from
/// the earlier one; returns that checkpoint's directory (exchange-<k>).
/// Throws unless the run kept exactly two.
std::filesystem::path cutBackToEarlierCheckpoint(const std::filesystem::path& runDir,
                                                 const std::filesystem::path& cut);

/// A binary built next to the tests ($COSIM_BIN_DIR/name).
std::string binary(const std::string& name);
/// A file in the source tree ($COSIM_SOURCE_DIR/relative).
std::string sourcePath(const std::string& relative);

}  // namespace cosim::testing
