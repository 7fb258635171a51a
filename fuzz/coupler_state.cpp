// Fuzz target: the coupler's state file of a checkpoint (coupler_state.json:
// exchange, time as exact hex, series row counts), read when `coupler run
// --resume` looks for the newest checkpoint (CheckpointStore::latest), and
// the scene text kept beside it. A bad file must end in a std::runtime_error
// whose message names the file; anything else is a finding.
//
// Input layout: the JSON text, written as the state file of the committed
// checkpoint checkpoints/exchange-7/ of a run directory in the scratch directory.
#include <fstream>
#include <map>

#include "cosim/coupler/run/checkpoint_store.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;
namespace fs = std::filesystem;

constexpr std::uint64_t kExchange = 7;

const fs::path& runDir() {
  static const fs::path dir = [] {
    const fs::path d = fuzz::scratchDir() / "state-run";
    fs::create_directories(d / "checkpoints" / ("exchange-" + std::to_string(kExchange)));
    std::ofstream(d / "checkpoints" / ("exchange-" + std::to_string(kExchange)) / "scene.yaml") << "scene: fuzz\n";
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > fuzz::kMaxInputBytes) return -1;
  const coupler::CheckpointStore store(runDir());
  const std::string name = "state-run/checkpoints/exchange-" + std::to_string(kExchange) + "/coupler_state.json";
  fuzz::writeScratch(name, data, size);
  try {
    if (const auto point = store.latest()) (void)coupler::CheckpointStore::sceneText(*point);
  } catch (const std::runtime_error& e) {
    fuzz::userError(e, {"coupler_state.json"});
  }
  return 0;
}

namespace cosim::fuzz {

// Seeds: state files the coupler writes (CheckpointStore::commit) at
// exchange 7, with and without series rows, and an older one without them.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  const fs::path dir = scratchDir() / "seed-run";
  coupler::CheckpointStore store(dir, 1);
  const std::vector<std::pair<double, std::map<std::string, std::size_t>>> states{
      {0.0, {}}, {0.125, {{"coupler/time", 8}, {"particles/energies", 2}}}, {1.0e-300, {{"x", 0}}}};
  for (const auto& [time, rows] : states) {
    store.begin(kExchange);
    const auto point = store.commit(kExchange, time, "scene: fuzz\n", rows);
    out.push_back(readBytes(point.dir / "coupler_state.json"));
  }
  out.push_back(bytesOf(R"({"exchange": 7, "time_hex": "0x1.8p-3"})"));
  return out;
}

}  // namespace cosim::fuzz
