#include "cosim/coupler/run/checkpoint_store.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {
constexpr const char* kPrefix = "exchange-";
constexpr const char* kState = "coupler_state.json";
constexpr const char* kScene = "scene.yaml";

std::string name(std::uint64_t exchange) {
  std::ostringstream s;
  s << kPrefix << exchange;
  return s.str();
}

/// The exchange in a committed checkpoint's directory name ("exchange-N"), if it is one.
std::optional<std::uint64_t> committedExchange(const fs::path& dir) {
  const std::string n = dir.filename().string(), digits = n.substr(std::min(n.size(), std::string(kPrefix).size()));
  if (n.rfind(kPrefix, 0) != 0 || digits.empty() || digits.size() > 18 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  return std::stoull(digits);
}

/// The state file of a committed checkpoint, checked against its directory:
/// a corrupt one stops the resume with its path rather than resuming at a
/// wrong exchange or time.
CheckpointStore::Point readState(const fs::path& dir, std::uint64_t exchange) {
  const fs::path statePath = dir / kState;
  const auto fail = [&](const std::string& what) -> CheckpointStore::Point {
    throw std::runtime_error(statePath.string() + ": corrupt checkpoint state: " + what + " (remove " + dir.string() +
                             " to resume from an earlier checkpoint)");
  };
  std::ifstream in(statePath);
  nlohmann::json state;
  try {
    in >> state;
  } catch (const nlohmann::json::exception& e) {
    return fail(e.what());
  }
  const auto ex = state.find("exchange");
  const auto hex = state.find("time_hex");
  if (!state.is_object() || ex == state.end() || !ex->is_number_unsigned() || hex == state.end() || !hex->is_string())
    return fail("needs an unsigned 'exchange' and a string 'time_hex'");
  if (ex->get<std::uint64_t>() != exchange)
    return fail("'exchange' is " + ex->dump() + " in the directory of exchange " + std::to_string(exchange));
  const std::string text = hex->get<std::string>();
  char* end = nullptr;
  const double time = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(time) || time < 0.0)
    return fail("'time_hex' is '" + text + "', not a finite time >= 0");
  CheckpointStore::Point point{exchange, time, dir, std::nullopt};
  if (const auto rows = state.find("series_rows"); rows != state.end()) {
    if (!rows->is_object()) return fail("'series_rows' is not an object");
    point.seriesRows.emplace();
    for (const auto& [name, n] : rows->items()) {
      if (!n.is_number_unsigned()) return fail("'series_rows." + name + "' is not a row count");
      (*point.seriesRows)[name] = n.get<std::size_t>();
    }
  }
  return point;
}
}  // namespace

CheckpointStore::CheckpointStore(fs::path runDir, int keep) : root_(std::move(runDir) / "checkpoints"), keep_(keep) {}

fs::path CheckpointStore::begin(std::uint64_t exchange) {
  const auto dir = root_ / (name(exchange) + ".partial");
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

CheckpointStore::Point CheckpointStore::commit(std::uint64_t exchange, double time, const std::string& sceneText,
                                               const std::map<std::string, std::size_t>& seriesRows) {
  const auto partial = root_ / (name(exchange) + ".partial");
  {
    std::ofstream scene(partial / kScene);
    scene << sceneText;
    nlohmann::json state{{"exchange", exchange}, {"time_hex", ""}, {"time", time}};
    // The time as exact hex so that a resumed run continues bit for bit.
    char hex[64];
    std::snprintf(hex, sizeof(hex), "%a", time);
    state["time_hex"] = hex;
    state["series_rows"] = seriesRows;
    std::ofstream out(partial / kState);
    out << state.dump(2) << "\n";
    if (!out) throw std::runtime_error((partial / kState).string() + ": cannot write the checkpoint state");
  }
  const auto final = root_ / name(exchange);
  fs::remove_all(final);
  fs::rename(partial, final);
  std::vector<std::pair<std::uint64_t, fs::path>> all;
  for (const auto& e : fs::directory_iterator(root_))
    if (const auto committed = committedExchange(e.path())) all.emplace_back(*committed, e.path());
  std::sort(all.begin(), all.end());
  for (std::size_t i = 0; i + static_cast<std::size_t>(keep_) < all.size(); ++i) fs::remove_all(all[i].second);
  return Point{exchange, time, final, seriesRows};
}

std::optional<CheckpointStore::Point> CheckpointStore::latest() const {
  std::optional<Point> best;
  if (!fs::exists(root_)) return best;
  // Only committed directories count: a ".partial" one was cut off while written.
  std::optional<std::pair<std::uint64_t, fs::path>> newest;
  for (const auto& e : fs::directory_iterator(root_)) {
    const auto exchange = committedExchange(e.path());
    if (!exchange || !fs::exists(e.path() / kState)) continue;
    if (!newest || *exchange > newest->first) newest = {*exchange, e.path()};
  }
  if (newest) best = readState(newest->second, newest->first);
  return best;
}

std::string CheckpointStore::sceneText(const Point& point) {
  std::ifstream in(point.dir / kScene);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path CheckpointStore::solverCheckpoint(const fs::path& dir, const std::string& solver) {
  return dir / (solver + ".chk");
}
fs::path CheckpointStore::solverLastReply(const fs::path& dir, const std::string& solver) {
  return dir / (solver + ".last.bin");
}

fs::path CheckpointStore::analysisState(const fs::path& dir) { return dir / "analysis.bin"; }
fs::path CheckpointStore::couplingState(const fs::path& dir) { return dir / "couplings.bin"; }

namespace {
fs::path lostFile(const fs::path& dir) { return dir / "lost_solvers.txt"; }
}  // namespace

void CheckpointStore::saveLostSolvers(const fs::path& dir, const std::set<std::string>& lost) {
  if (lost.empty()) return;
  std::ofstream out(lostFile(dir));
  for (const auto& name : lost) out << name << "\n";
  if (!out) throw std::runtime_error(lostFile(dir).string() + ": cannot write the lost solvers");
}

std::set<std::string> CheckpointStore::lostSolvers(const fs::path& dir) {
  std::set<std::string> lost;
  std::ifstream in(lostFile(dir));
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lost.insert(line);
  return lost;
}

}  // namespace cosim::coupler
