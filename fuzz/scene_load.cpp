// Fuzz target: `coupler check SCENE --set key=value...` up to the solvers'
// checks: the --set arguments parsed (parseOverride), applied to the scene
// text (applyOverrides), the run directory derived from the result
// (runDirectoryOf) and the effective text loaded and validated
// (loadSceneText: schedule, solvers, couplings, analysis, output, placement),
// then described as `coupler check` prints it. A bad scene or argument must
// end in config::ConfigError naming the scene file or OverrideError naming
// the --set argument, the two errors the coupler's command line reports;
// anything else is a finding.
//
// Input layout: scene YAML text; each line that starts with "--set " is not
// part of the scene but one --set argument (the rest of the line), applied
// in their order. The effective scene is not written to a file. The solver
// binaries a scene names by kind are found as empty executables in the
// scratch directory ($COSIM_BIN_DIR), so that a scene can load completely.
#include <sys/stat.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/config/scene_overrides.hpp"
#include "cosim/coupler/run/coupler_run.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

constexpr std::string_view kSetPrefix = "--set ";

void fakeSolverBinaries() {
  const auto dir = fuzz::scratchDir() / "bin";
  std::filesystem::create_directories(dir);
  for (const char* name : {"dem_solver", "fem_solver", "pd_solver", "mock_solver"}) {
    std::ofstream(dir / name).close();
    ::chmod((dir / name).c_str(), 0700);
  }
  ::setenv("COSIM_BIN_DIR", dir.c_str(), 1);
}

struct Input {
  std::string scene;
  std::vector<std::string> overrides;
};

Input split(std::string_view text) {
  Input in;
  while (!text.empty()) {
    const auto eol = text.find('\n');
    const std::string_view line = text.substr(0, eol == std::string_view::npos ? text.size() : eol + 1);
    text.remove_prefix(line.size());
    if (line.substr(0, kSetPrefix.size()) == kSetPrefix) {
      std::string_view arg = line.substr(kSetPrefix.size());
      if (!arg.empty() && arg.back() == '\n') arg.remove_suffix(1);
      in.overrides.emplace_back(arg);
    } else {
      in.scene.append(line);
    }
  }
  return in;
}

// As loadSceneWithOverrides, with the effective text kept in memory.
coupler::Scene load(const Input& in) {
  const std::string file = fuzz::kSceneFile;
  const std::string dir = fuzz::scratchDir().string();
  if (in.overrides.empty()) return coupler::loadSceneText(in.scene, file, dir);
  std::vector<coupler::SceneOverride> overrides;
  for (const auto& arg : in.overrides) overrides.push_back(coupler::parseOverride(arg));
  const std::string text = coupler::applyOverrides(in.scene, file, overrides);
  const auto effective = coupler::runDirectoryOf(text, file, "") / "scene.effective.yaml";
  return coupler::loadSceneText(text, effective.string(), dir);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool prepared = (fakeSolverBinaries(), true);
  (void)prepared;
  const auto text = fuzz::inputText(data, size);
  if (!text) return -1;
  try {
    const coupler::Scene scene = load(split(*text));
    std::ostringstream description;
    coupler::describeScene(scene, description);
  } catch (const config::ConfigError& e) {
    fuzz::userError(e, {fuzz::kSceneFile, "scene.effective.yaml"});
  } catch (const coupler::OverrideError& e) {
    fuzz::userError(e, {"--set"});
  }
  return 0;
}

namespace cosim::fuzz {

// Seeds: small shipped scenes of each kind of coupling and schedule, alone
// and with the --set arguments their comments and tests use.
std::vector<std::vector<std::uint8_t>> seeds() {
  const std::vector<std::pair<std::string, std::vector<std::string>>> scenes{
      {"configs/demo/two_mocks.yaml", {}},
      {"configs/demo/two_mocks.yaml", {"schedule.dt=1e-4", "solvers.left.params.length=10", "output.record=[left.digest]"}},
      {"configs/dem/hertz_collision.yaml", {"placement={processes: packed, cpus: [0]}"}},
      {"configs/fem/cantilever.yaml", {"solvers[0].params.mesh.box.divisions=[1, 3, 1]", "transport={kind: tcp, port: 5555}"}},
      {"configs/gmh/l2_shear.yaml", {"solvers.cells.params.unit_cells.file=/abs/cell.ckpt"}},
      {"configs/c2/wave_volume_1p.yaml", {}},
      {"configs/h1/pd_dem_hertz_lps.yaml", {}},
      {"configs/h4/pd_squeeze.yaml", {"schedule.ratio=2"}},
      {"configs/c1/cantilever_surface.yaml", {}},
  };
  std::vector<std::vector<std::uint8_t>> out;
  for (const auto& [config, sets] : scenes) {
    std::string text = sourceText(config);
    for (const auto& s : sets) text += std::string(kSetPrefix) + s + "\n";
    out.push_back(bytesOf(text));
  }
  return out;
}

}  // namespace cosim::fuzz
