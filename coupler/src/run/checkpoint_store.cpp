#include "cosim/coupler/run/checkpoint_store.hpp"

#include <algorithm>
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
}  // namespace

CheckpointStore::CheckpointStore(fs::path runDir, int keep) : root_(std::move(runDir) / "checkpoints"), keep_(keep) {}

fs::path CheckpointStore::begin(std::uint64_t exchange) {
  const auto dir = root_ / (name(exchange) + ".partial");
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

CheckpointStore::Point CheckpointStore::commit(std::uint64_t exchange, double time, const std::string& sceneText) {
  const auto partial = root_ / (name(exchange) + ".partial");
  {
    std::ofstream scene(partial / kScene);
    scene << sceneText;
    nlohmann::json state{{"exchange", exchange}, {"time_hex", ""}, {"time", time}};
    // The time as exact hex so that a resumed run continues bit for bit.
    char hex[64];
    std::snprintf(hex, sizeof(hex), "%a", time);
    state["time_hex"] = hex;
    std::ofstream out(partial / kState);
    out << state.dump(2) << "\n";
    if (!out) throw std::runtime_error((partial / kState).string() + ": cannot write the checkpoint state");
  }
  const auto final = root_ / name(exchange);
  fs::remove_all(final);
  fs::rename(partial, final);
  std::vector<std::pair<std::uint64_t, fs::path>> all;
  for (const auto& e : fs::directory_iterator(root_)) {
    const auto n = e.path().filename().string();
    if (n.rfind(kPrefix, 0) == 0 && n.find(".partial") == std::string::npos)
      all.emplace_back(std::stoull(n.substr(std::string(kPrefix).size())), e.path());
  }
  std::sort(all.begin(), all.end());
  for (std::size_t i = 0; i + static_cast<std::size_t>(keep_) < all.size(); ++i) fs::remove_all(all[i].second);
  return Point{exchange, time, final};
}

std::optional<CheckpointStore::Point> CheckpointStore::latest() const {
  std::optional<Point> best;
  if (!fs::exists(root_)) return best;
  for (const auto& e : fs::directory_iterator(root_)) {
    const auto statePath = e.path() / kState;
    if (!fs::exists(statePath)) continue;
    std::ifstream in(statePath);
    nlohmann::json state;
    try {
      in >> state;
    } catch (const nlohmann::json::exception&) {
      continue;  // not complete: skip it
    }
    Point p{state.at("exchange").get<std::uint64_t>(),
            std::strtod(state.at("time_hex").get<std::string>().c_str(), nullptr), e.path()};
    if (!best || p.exchange > best->exchange) best = p;
  }
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

}  // namespace cosim::coupler
