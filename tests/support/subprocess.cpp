#include "subprocess.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace cosim::testing {
namespace {
double now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}
}  // namespace

Subprocess::Subprocess(const std::vector<std::string>& argv) {
  int out[2], err[2];
  if (::pipe(out) != 0 || ::pipe(err) != 0) throw std::runtime_error("pipe failed");
  std::vector<std::string> store = argv;
  std::vector<char*> args;
  for (auto& a : store) args.push_back(a.data());
  args.push_back(nullptr);
  pid_ = ::fork();
  if (pid_ < 0) throw std::runtime_error("fork failed");
  if (pid_ == 0) {
    ::dup2(out[1], 1);
    ::dup2(err[1], 2);
    ::close(out[0]);
    ::close(err[0]);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(out[1]);
  ::close(err[1]);
  outFd_ = out[0];
  errFd_ = err[0];
}

Subprocess::~Subprocess() {
  if (!done_) {
    ::kill(pid_, SIGKILL);
    wait(5.0);
  }
  if (outFd_ >= 0) ::close(outFd_);
  if (errFd_ >= 0) ::close(errFd_);
}

void Subprocess::signal(int sig) const { ::kill(pid_, sig); }

void Subprocess::drain(double timeoutS) {
  pollfd fds[2] = {{outFd_, POLLIN, 0}, {errFd_, POLLIN, 0}};
  if (::poll(fds, 2, static_cast<int>(timeoutS * 1000)) <= 0) return;
  char buf[65536];
  for (int i = 0; i < 2; ++i)
    if (fds[i].revents & (POLLIN | POLLHUP)) {
      const auto n = ::read(fds[i].fd, buf, sizeof(buf));
      if (n > 0) (i == 0 ? out_ : err_).append(buf, static_cast<std::size_t>(n));
    }
}

int Subprocess::wait(double timeoutS) {
  if (done_) return code_;
  const double end = now() + timeoutS;
  int status = 0;
  while (true) {
    drain(0.02);
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_) break;
    if (now() > end) {
      timedOut_ = true;
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
      break;
    }
  }
  for (int i = 0; i < 50; ++i) drain(0.0);  // what is left in the pipes
  done_ = true;
  code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return code_;
}

Finished run(const std::vector<std::string>& argv, double timeoutS) {
  const double start = now();
  Subprocess p(argv);
  Finished f;
  f.code = p.wait(timeoutS);
  f.timedOut = p.timedOut();
  f.out = p.out();
  f.err = p.err();
  f.wallS = now() - start;
  return f;
}

std::vector<pid_t> processesMentioning(const std::string& needle) {
  std::vector<pid_t> pids;
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    const auto name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream status(entry.path() / "stat");
    std::string pidText, comm, state;
    if (!(status >> pidText >> comm >> state) || state == "Z") continue;
    // A process may exit between the two reads (another test's, under
    // ctest -j): libstdc++ then throws "No such process" from the read.
    std::string line;
    try {
      std::ifstream cmd(entry.path() / "cmdline");
      line.assign(std::istreambuf_iterator<char>(cmd), std::istreambuf_iterator<char>());
    } catch (const std::ios_base::failure&) {
      continue;
    }
    for (auto& c : line)
      if (c == '\0') c = ' ';
    if (line.find(needle) != std::string::npos) pids.push_back(std::stoi(name));
  }
  return pids;
}

namespace {

// The directories freshDirectory() made during the running test: removed when
// the test passes, kept (and named) when it fails. Made outside a test (a
// suite's shared set-up), they are the caller's to remove. Without this,
// every test run left its runs in /tmp (over 400 MB after some thirty sessions).
class ScratchCleaner : public ::testing::EmptyTestEventListener {
 public:
  static ScratchCleaner& instance() {
    // Owned by gtest's listener list once appended.
    static ScratchCleaner* cleaner = [] {
      auto* c = new ScratchCleaner;
      ::testing::UnitTest::GetInstance()->listeners().Append(c);
      return c;
    }();
    return *cleaner;
  }
  void made(const std::filesystem::path& dir) {
    if (inTest_) dirs_.push_back(dir);
  }
  void OnTestStart(const ::testing::TestInfo&) override { inTest_ = true; }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    inTest_ = false;
    for (const auto& dir : dirs_) {
      std::error_code ec;
      if (info.result()->Passed()) std::filesystem::remove_all(dir, ec);
      else if (std::filesystem::exists(dir, ec)) std::printf("kept for inspection: %s\n", dir.c_str());
    }
    dirs_.clear();
  }

 private:
  bool inTest_ = false;
  std::vector<std::filesystem::path> dirs_;
};

// Listening from the start, so that a directory made in the first test is seen.
const bool cleanerListening = (ScratchCleaner::instance(), true);

}  // namespace

std::filesystem::path freshDirectory(const std::string& prefix) {
  std::string templ = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
  if (::mkdtemp(templ.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  ScratchCleaner::instance().made(templ);
  return templ;
}

std::filesystem::path cutBackToEarlierCheckpoint(const std::filesystem::path& runDir,
                                                 const std::filesystem::path& cut) {
  namespace fs = std::filesystem;
  fs::copy(runDir, cut, fs::copy_options::recursive);
  std::vector<std::pair<unsigned long, fs::path>> kept;  // by exchange number, not by name
  for (const auto& e : fs::directory_iterator(cut / "checkpoints"))
    kept.emplace_back(std::stoul(e.path().filename().string().substr(9)), e.path());
  if (kept.size() != 2)
    throw std::runtime_error(cut.string() + ": the run kept " + std::to_string(kept.size()) + " checkpoints, not 2");
  std::sort(kept.begin(), kept.end());
  fs::remove_all(kept[1].second);
  return kept[0].second;
}

std::string binary(const std::string& name) {
  const char* dir = std::getenv("COSIM_BIN_DIR");
  return std::string(dir ? dir : COSIM_DEFAULT_BIN_DIR) + "/" + name;
}

std::string sourcePath(const std::string& relative) {
  const char* dir = std::getenv("COSIM_SOURCE_DIR");
  return std::string(dir ? dir : COSIM_DEFAULT_SOURCE_DIR) + "/" + relative;
}

}  // namespace cosim::testing
