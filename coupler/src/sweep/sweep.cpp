#include "cosim/coupler/sweep/sweep.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene_overrides.hpp"
#include "cosim/coupler/launch/process_group.hpp"
#include "cosim/util/cpu_affinity.hpp"
#include "cosim/wire/clock.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxRuns = 10000;
constexpr const char* kPython = "/usr/bin/python3";

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

int parseJobs(const std::string& text) {
  const bool digits = !text.empty() && text.size() < 6 &&
                      std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
  const int jobs = digits ? std::stoi(text) : 0;
  if (jobs < 1 || jobs > 256) throw std::invalid_argument("--jobs: expected a whole number from 1 to 256, got '" + text + "'");
  return jobs;
}

std::vector<SceneOverride> overridesOf(const SweepPoint& point) {
  std::vector<SceneOverride> overrides;
  for (const auto& [key, value] : point) overrides.push_back(parseOverride(key + "=" + value));
  return overrides;
}

std::string readSceneText(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open the scene file");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// Every combination must apply to the scene before any run starts, so a
/// mistyped key is a usage error, not a table of failed runs.
void checkCombinations(const SweepOptions& options, const std::vector<SweepPoint>& points) {
  const std::string text = readSceneText(options.scenePath);
  try {
    for (const auto& point : points) applyOverrides(text, options.scenePath, overridesOf(point));
  } catch (const config::ConfigError& e) {
    throw std::invalid_argument(e.what());
  }
}

std::string describePoint(const SweepPoint& point) {
  std::string out;
  for (const auto& [key, value] : point) out += (out.empty() ? "" : " ") + key + "=" + value;
  return out;
}

int exitCodeOf(int waitStatus) {
  if (WIFEXITED(waitStatus)) return WEXITSTATUS(waitStatus);
  if (WIFSIGNALED(waitStatus)) return 128 + WTERMSIG(waitStatus);
  return 1;
}

std::vector<char*> argvOf(std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return argv;
}

/// Starts a child with stdin from /dev/null and stdout, stderr to the given
/// descriptors (closed here). Like the solvers a run starts, it gets its own
/// process group (Ctrl-C reaches only the sweep, which passes it on) and dies
/// with the sweep.
pid_t startChild(std::vector<std::string> args, int outFd, int errFd) {
  auto argv = argvOf(args);
  const int devNull = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) {
    // Child: only async-signal-safe calls until exec.
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) ::_exit(126);
    ::setpgid(0, 0);
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    ::signal(SIGPIPE, SIG_DFL);
    if (devNull >= 0) ::dup2(devNull, 0);
    ::dup2(outFd, 1);
    ::dup2(errFd, 2);
    ::execv(argv[0], argv.data());
    const char msg[] = "coupler sweep: exec failed\n";
    [[maybe_unused]] auto ignored = ::write(2, msg, sizeof(msg) - 1);
    ::_exit(127);
  }
  const int forkErrno = errno;
  if (devNull >= 0) ::close(devNull);
  ::close(outFd);
  if (errFd != outFd) ::close(errFd);
  if (pid < 0) throw std::runtime_error(std::string("cannot start ") + args[0] + ": fork failed: " + std::strerror(forkErrno));
  return pid;
}

int openForWriting(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error(path.string() + ": cannot open for writing: " + std::strerror(errno));
  return fd;
}

fs::path ownExecutable() {
  std::error_code ec;
  const auto exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find the coupler's own executable (/proc/self/exe): " + ec.message());
  return exe;
}

fs::path plotScript() {
  if (const char* src = std::getenv("COSIM_SOURCE_DIR"); src && *src) {
    const fs::path p = fs::path(src) / "scripts" / "plot_sweep.py";
    if (fs::exists(p)) return p;
  }
#ifdef COSIM_SCRIPTS_DIR
  const fs::path built = fs::path(COSIM_SCRIPTS_DIR) / "plot_sweep.py";
  if (fs::exists(built)) return built;
#endif
  return {};
}

std::string lastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string last;
  for (std::string line; std::getline(in, line);)
    if (!trimmed(line).empty()) last = line;
  return last;
}

/// Runs the plot script; returns the PNGs it wrote (one path per stdout line).
std::vector<std::string> runPlotScript(const fs::path& script, const fs::path& csv, const fs::path& log) {
  int pipeFds[2];
  if (::pipe2(pipeFds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
  const pid_t pid = startChild({kPython, script.string(), csv.string()}, pipeFds[1], openForWriting(log));
  std::string out;
  char buf[4096];
  for (ssize_t n; (n = ::read(pipeFds[0], buf, sizeof buf)) != 0;)
    if (n > 0) out.append(buf, static_cast<std::size_t>(n));
    else if (errno != EINTR) break;
  ::close(pipeFds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (exitCodeOf(status) != 0)
    throw std::runtime_error(lastLine(log).empty() ? "the plot script failed" : lastLine(log));
  std::vector<std::string> pngs;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);)
    if (!trimmed(line).empty()) pngs.push_back(trimmed(line));
  return pngs;
}

class Sweep {
 public:
  explicit Sweep(const SweepOptions& options)
      : options_(options), points_(sweepPoints(options.axes)), exe_(ownExecutable()),
        outDir_(options.outDir.empty() ? fs::path("runs") / (fs::path(options.scenePath).stem().string() + "-sweep")
                                       : fs::path(options.outDir)) {}

  int run() {
    checkCombinations(options_, points_);
    slotCpus_ = packingCpusPerSlot();
    fs::create_directories(outDir_);
    installStopSignalHandlers();
    std::cout << "sweep: " << points_.size() << " run(s) of " << options_.scenePath << " into " << outDir_.string()
              << ", " << options_.jobs << " at once\n" << std::flush;
    runAll();
    printTable();
    std::cout << "table: " << csvPath().string() << "\n";
    writePlots();
    if (stopSignal()) return 130;
    const bool allCompleted = rows_.size() == points_.size() &&
                              std::all_of(rows_.begin(), rows_.end(), [](const SweepRow& r) { return r.status == "completed"; });
    return allCompleted ? 0 : 1;
  }

 private:
  struct Running {
    pid_t pid = 0;
    std::size_t index = 0;
    double startedAt = 0.0;
    std::size_t slot = 0;  // which of the `jobs` places it occupies
  };

  /// A scene packed on "the CPU the coupler starts on" would let runs started
  /// together land on one CPU: with more than one job, slot k packs on the
  /// k-th allowed CPU instead (round robin). Empty: runs are left alone.
  std::vector<int> packingCpusPerSlot() const {
    if (options_.jobs < 2) return {};
    const auto scene = loadSceneText(readSceneText(options_.scenePath), options_.scenePath,
                                     fs::absolute(options_.scenePath).parent_path().string());
    if (scene.placement.kind != PlacementSpec::Kind::packed || !scene.placement.cpus.empty()) return {};
    const auto allowed = util::allowedCpus();
    std::vector<int> cpus;
    for (int k = 0; k < options_.jobs; ++k) cpus.push_back(allowed[static_cast<std::size_t>(k) % allowed.size()]);
    return cpus;
  }

  std::size_t freeSlot() const {
    for (std::size_t k = 0;; ++k)
      if (std::none_of(running_.begin(), running_.end(), [k](const Running& r) { return r.slot == k; })) return k;
  }

  fs::path csvPath() const { return outDir_ / "sweep.csv"; }
  fs::path runDir(std::size_t index) const { return outDir_ / runDirectoryName(index, points_.size(), points_[index]); }

  void runAll() {
    std::size_t next = 0;
    bool passedOn = false;
    while ((next < points_.size() && !stopSignal()) || !running_.empty()) {
      while (running_.size() < static_cast<std::size_t>(options_.jobs) && next < points_.size() && !stopSignal())
        start(next++);
      if (stopSignal() && !passedOn) {
        for (const auto& r : running_) ::kill(r.pid, SIGINT);  // each run stops cleanly and writes its report
        passedOn = true;
      }
      if (!reapFinished()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  void start(std::size_t index) {
    const auto dir = runDir(index);
    fs::create_directories(dir);
    fs::remove(dir / "run_report.json");  // a report left by an earlier sweep must not stand for this run
    std::vector<std::string> args{exe_.string(), "run", options_.scenePath, "--out", dir.string(), "--no-progress"};
    for (const auto& [key, value] : points_[index]) args.insert(args.end(), {"--set", key + "=" + value});
    const auto slot = freeSlot();
    const bool pointPlaces = std::any_of(points_[index].begin(), points_[index].end(),
                                         [](const auto& kv) { return kv.first.rfind("placement", 0) == 0; });
    if (!slotCpus_.empty() && !pointPlaces) args.insert(args.end(), {"--set", "placement.cpus=[" + std::to_string(slotCpus_[slot]) + "]"});
    if (options_.force) args.push_back("--force");
    const int log = openForWriting(dir / "coupler.log");
    running_.push_back({startChild(args, log, log), index, monotonicSeconds(), slot});
  }

  bool reapFinished() {
    bool any = false;
    for (auto it = running_.begin(); it != running_.end();) {
      int status = 0;
      if (::waitpid(it->pid, &status, WNOHANG) != it->pid) {
        ++it;
        continue;
      }
      record(it->index, exitCodeOf(status), monotonicSeconds() - it->startedAt);
      it = running_.erase(it);
      any = true;
    }
    return any;
  }

  void record(std::size_t index, int exitCode, double elapsedS) {
    rows_.push_back(readSweepRow(index, points_[index], runDir(index), exitCode));
    std::sort(rows_.begin(), rows_.end(), [](const SweepRow& a, const SweepRow& b) { return a.index < b.index; });
    writeSweepCsv(csvPath(), options_.axes, rows_);
    const auto& row = *std::find_if(rows_.begin(), rows_.end(), [&](const SweepRow& r) { return r.index == index; });
    std::cout << "[" << rows_.size() << "/" << points_.size() << "] " << describePoint(row.point) << ": " << row.status
              << " (exit " << exitCode << ", " << std::fixed << std::setprecision(2) << elapsedS << " s)"
              << std::defaultfloat << (row.status == "completed" ? "" : ": " + row.message) << "\n"
              << std::flush;
  }

  void printTable() const;
  void writePlots() const;

  SweepOptions options_;
  std::vector<SweepPoint> points_;
  fs::path exe_;
  fs::path outDir_;
  std::vector<Running> running_;
  std::vector<int> slotCpus_;  // per job slot, for packed scenes (packingCpusPerSlot)
  std::vector<SweepRow> rows_;
};

std::string cell(const std::optional<double>& v) {
  if (!v) return "-";
  std::ostringstream s;
  s << std::setprecision(4) << *v;
  return s.str();
}

void Sweep::printTable() const {
  std::vector<std::vector<std::string>> table{{"#"}};
  for (const auto& axis : options_.axes) table[0].push_back(axis.key);
  table[0].insert(table[0].end(), {"status", "exit", "wall s", "overhead", "error"});
  for (const auto& r : rows_) {
    std::vector<std::string> line{std::to_string(r.index)};
    for (const auto& [key, value] : r.point) line.push_back(value);
    line.insert(line.end(), {r.status, std::to_string(r.exitCode), cell(r.wallS), cell(r.overheadShare),
                             r.errorValue ? r.errorName + " = " + cell(r.errorValue) : std::string("-")});
    table.push_back(line);
  }
  std::vector<std::size_t> width(table[0].size(), 0);
  for (const auto& line : table)
    for (std::size_t i = 0; i < line.size(); ++i) width[i] = std::max(width[i], line[i].size());
  for (const auto& line : table) {
    for (std::size_t i = 0; i < line.size(); ++i) std::cout << (i ? "  " : "") << std::left << std::setw(static_cast<int>(width[i])) << line[i];
    std::cout << std::right << "\n";
  }
}

void Sweep::writePlots() const {
  const auto script = plotScript();
  std::string problem;
  if (script.empty()) problem = "scripts/plot_sweep.py not found (set COSIM_SOURCE_DIR to the source tree)";
  else if (::access(kPython, X_OK) != 0) problem = std::string(kPython) + " not found";
  if (problem.empty()) {
    try {
      for (const auto& png : runPlotScript(script, csvPath(), outDir_ / "plot.log")) std::cout << "plot: " << png << "\n";
      return;
    } catch (const std::exception& e) {
      problem = e.what();
    }
  }
  std::cerr << "coupler sweep: warning: no plots (" << problem << "); the table is " << csvPath().string() << "\n";
}

}  // namespace

std::vector<std::string> splitSweepValues(const std::string& list, const std::string& argument) {
  std::vector<std::string> values;
  std::string current;
  int depth = 0;
  char quote = 0;
  for (char c : list) {
    if (quote) quote = c == quote ? 0 : quote;
    else if (c == '\'' || c == '"') quote = c;
    else if (c == '[' || c == '{') ++depth;
    else if ((c == ']' || c == '}') && --depth < 0) break;
    if (c == ',' && depth == 0 && !quote) {
      values.push_back(trimmed(current));
      current.clear();
    } else {
      current += c;
    }
  }
  if (depth != 0 || quote) throw std::invalid_argument("--set '" + argument + "': unbalanced brackets or quotes in the values");
  values.push_back(trimmed(current));
  for (const auto& v : values)
    if (v.empty()) throw std::invalid_argument("--set '" + argument + "': an empty value in the list (values are separated by ',')");
  return values;
}

SweepAxis parseSweepAxis(const std::string& argument) {
  const auto o = parseOverride(argument);  // checks the key path
  SweepAxis axis{o.path, splitSweepValues(o.value, argument)};
  const std::set<std::string> distinct(axis.values.begin(), axis.values.end());
  if (distinct.size() != axis.values.size()) throw std::invalid_argument("--set '" + argument + "': a value is given twice");
  return axis;
}

SweepOptions parseSweepArguments(const std::vector<std::string>& args) {
  SweepOptions options;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const auto& a = args[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= args.size()) throw std::invalid_argument(a + " needs a value");
      return args[++i];
    };
    if (a == "--set") options.axes.push_back(parseSweepAxis(value()));
    else if (a == "--out") options.outDir = value();
    else if (a == "--jobs") options.jobs = parseJobs(value());
    else if (a == "--force") options.force = true;
    else if (!a.empty() && a[0] == '-') throw std::invalid_argument("sweep: unknown option '" + a + "'");
    else if (options.scenePath.empty()) options.scenePath = a;
    else throw std::invalid_argument("sweep: more than one scene given ('" + options.scenePath + "', '" + a + "')");
  }
  if (options.scenePath.empty()) throw std::invalid_argument("sweep: no scene file given");
  if (options.axes.empty()) throw std::invalid_argument("sweep: give at least one --set KEY=V1,V2,...");
  std::set<std::string> keys;
  for (const auto& axis : options.axes)
    if (!keys.insert(axis.key).second) throw std::invalid_argument("sweep: --set " + axis.key + " is given twice");
  std::size_t runs = 1;
  for (const auto& axis : options.axes) runs = std::min(runs * axis.values.size(), kMaxRuns + 1);
  if (runs > kMaxRuns) throw std::invalid_argument("sweep: more than " + std::to_string(kMaxRuns) + " runs; split the sweep");
  return options;
}

std::vector<SweepPoint> sweepPoints(const std::vector<SweepAxis>& axes) {
  std::vector<SweepPoint> points{SweepPoint{}};
  for (const auto& axis : axes) {
    std::vector<SweepPoint> extended;
    for (const auto& point : points)
      for (const auto& value : axis.values) {
        auto p = point;
        p.emplace_back(axis.key, value);
        extended.push_back(std::move(p));
      }
    points = std::move(extended);
  }
  return points;
}

std::string runDirectoryName(std::size_t index, std::size_t count, const SweepPoint& point) {
  const auto width = std::to_string(count > 0 ? count - 1 : 0).size();
  std::string number = std::to_string(index);
  number.insert(0, width > number.size() ? width - number.size() : 0, '0');
  std::string name = number;
  for (const auto& [key, value] : point) name += "_" + key + "=" + value;
  for (auto& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && !std::strchr("._=+-", c)) c = '_';
  return name.substr(0, 120);
}

int sweepMain(const SweepOptions& options) {
  try {
    return Sweep(options).run();
  } catch (const std::invalid_argument& e) {
    std::cerr << "coupler sweep: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "coupler sweep: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace cosim::coupler
