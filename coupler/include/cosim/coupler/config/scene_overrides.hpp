#pragma once
// `--set key.path=value`: changes to the scene TEXT before it is validated,
// because every solver re-parses the scene text the coupler sends at setup.
// A key path addresses the scene YAML: map keys separated by dots, list items
// by index (`solvers[1]`) or by the value of their `name` field
// (`solvers.particles`). The value is parsed as YAML (`[0, 0, -9.81]` is a list).
#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/coupler/config/scene.hpp"

namespace cosim::coupler {

/// A --set argument that cannot be applied; what() names the argument and the missing part.
class OverrideError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// One step of a key path: a map key (or a list item's name), or a list index.
struct KeyStep {
  bool isIndex = false;
  std::string key;
  std::size_t index = 0;
};

struct SceneOverride {
  std::string argument;  // as given on the command line: "schedule.dt=1e-5"
  std::string path;      // "schedule.dt"
  std::string value;     // "1e-5", parsed as YAML when applied
};

/// Splits "key.path=value" at the first '='; throws OverrideError.
SceneOverride parseOverride(const std::string& argument);

/// "solvers[1].params.dt" -> solvers, [1], params, dt; throws OverrideError naming the argument.
std::vector<KeyStep> parseKeyPath(const std::string& path, const std::string& argument);

/// Applies the overrides in order to the scene text and emits the new text,
/// headed by a comment naming the original file and the overrides.
std::string applyOverrides(const std::string& sceneText, const std::string& sceneFile,
                           const std::vector<SceneOverride>& overrides);

/// Where a run of this (effective) scene text writes: outDir when given, else
/// its output.dir, else runs/<scene>, else runs/<file stem> (a dir with a
/// control character or an invalid scene name is passed over: the loader
/// reports it at its line).
std::filesystem::path runDirectoryOf(const std::string& sceneText, const std::string& sceneFile,
                                     const std::string& outDir);

/// The scene a run or check uses: the file itself without overrides; with
/// them, the effective text written to <run dir>/scene.effective.yaml, which
/// the scene (and so every later `file:line` message) names. Throws
/// OverrideError or config::ConfigError.
Scene loadSceneWithOverrides(const std::string& path, const std::vector<SceneOverride>& overrides,
                             const std::string& outDir);

}  // namespace cosim::coupler
