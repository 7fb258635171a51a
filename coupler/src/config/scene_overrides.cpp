#include "cosim/coupler/config/scene_overrides.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <regex>
#include <sstream>

#include "cosim/config/config_reader.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const std::string& argument, const std::string& message) {
  throw OverrideError("--set '" + argument + "': " + message);
}

std::string describePath(const std::vector<KeyStep>& steps, std::size_t count) {
  std::string out;
  for (std::size_t i = 0; i < count && i < steps.size(); ++i) {
    if (steps[i].isIndex) {
      out.append("[").append(std::to_string(steps[i].index)).append("]");
    } else {
      if (!out.empty()) out.append(".");
      out.append(steps[i].key);
    }
  }
  return out.empty() ? std::string("the scene") : out;
}

// Reads "[digits]" starting at text[pos] == '['; returns the position after ']'.
std::size_t readIndex(const std::string& text, std::size_t pos, const std::string& argument, KeyStep& step) {
  const auto close = text.find(']', pos);
  const std::string digits = close == std::string::npos ? std::string() : text.substr(pos + 1, close - pos - 1);
  if (digits.empty() || digits.size() > 9 || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    fail(argument, "'" + text + "': a list index is written [N] with a whole number N");
  step.isIndex = true;
  step.index = std::stoul(digits);
  return close + 1;
}

std::string nameOf(const YAML::Node& item) {
  if (!item.IsMap()) return {};
  const YAML::Node name = item["name"];
  return name && name.IsScalar() ? name.Scalar() : std::string();
}

std::string namesIn(const YAML::Node& list) {
  std::string names;
  for (const auto& item : list)
    if (const auto n = nameOf(item); !n.empty()) names += (names.empty() ? "" : ", ") + n;
  return names.empty() ? std::string("its items have no names; address them as [N]") : "names: " + names;
}

/// The existing child a step addresses, or an undefined node when there is none.
YAML::Node findChild(const YAML::Node& node, const KeyStep& step) {
  if (step.isIndex) return node.IsSequence() && step.index < node.size() ? node[step.index] : YAML::Node(YAML::NodeType::Undefined);
  if (node.IsMap()) {
    for (auto it = node.begin(); it != node.end(); ++it)
      if (it->first.IsScalar() && it->first.Scalar() == step.key) return it->second;
  } else if (node.IsSequence()) {
    for (const auto& item : node)
      if (nameOf(item) == step.key) return item;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

std::string whyMissing(const YAML::Node& parent, const std::vector<KeyStep>& steps, std::size_t i) {
  const auto& step = steps[i];
  const auto parentName = describePath(steps, i);
  const auto missing = describePath(steps, i + 1);
  if (step.isIndex && parent.IsSequence())
    return missing + " does not exist: " + parentName + " has " + std::to_string(parent.size()) + " item(s)";
  if (step.isIndex) return parentName + " is not a list, so " + missing + " does not exist";
  if (parent.IsSequence()) {
    const bool numeric = std::all_of(step.key.begin(), step.key.end(), [](unsigned char c) { return std::isdigit(c); });
    return parentName + " has no item named '" + step.key + "' (" + namesIn(parent) + ")" +
           (numeric ? "; for the item at index " + step.key + " write " + parentName + "[" + step.key + "]" : "");
  }
  if (parent.IsMap()) return parentName + " has no key '" + step.key + "', so " + missing + " does not exist";
  if (parent.IsNull()) return parentName + " is empty (null), not a map, so " + missing + " does not exist";
  return parentName + " is a single value, not a map, so " + missing + " does not exist";
}

/// A missing map key on the way is not created (a typo would pass silently
/// into a new section): say how to add the whole map instead, e.g.
/// "placement.processes=packed" -> --set 'placement={processes: packed}'.
std::string asWholeMap(const YAML::Node& parent, const std::vector<KeyStep>& steps, std::size_t i,
                       const std::string& value) {
  if (!parent.IsMap()) return {};
  for (std::size_t k = i; k < steps.size(); ++k)
    if (steps[k].isIndex) return {};
  std::string nested = value;
  for (std::size_t k = steps.size() - 1; k > i; --k) nested = "{" + steps[k].key + ": " + nested + "}";
  return "; to add it, give the whole map: --set '" + describePath(steps, i + 1) + "=" + nested + "'";
}

YAML::Node parseValue(const SceneOverride& o) {
  if (o.value.empty()) fail(o.argument, "no value after '=' (write '' for an empty string, ~ for null)");
  try {
    return YAML::Load(o.value);
  } catch (const YAML::Exception& e) {
    fail(o.argument, "the value '" + o.value + "' is not valid YAML: " + e.msg);
  }
}

void applyOne(YAML::Node& root, const SceneOverride& o) {
  const auto steps = parseKeyPath(o.path, o.argument);
  const YAML::Node value = parseValue(o);
  YAML::Node node = root;
  for (std::size_t i = 0; i + 1 < steps.size(); ++i) {
    YAML::Node child = findChild(node, steps[i]);
    if (!child.IsDefined()) fail(o.argument, whyMissing(node, steps, i) + asWholeMap(node, steps, i, o.value));
    node.reset(child);  // rebind, not assign: assignment would overwrite the tree
  }
  const auto& last = steps.back();
  YAML::Node target = findChild(node, last);
  if (target.IsDefined()) target = value;  // replaces the value in the tree
  else if (!last.isIndex && node.IsMap()) node[last.key] = value;  // a new key in an existing map
  else fail(o.argument, whyMissing(node, steps, steps.size() - 1));
}

void emitTag(YAML::Emitter& out, const YAML::Node& node) {
  const auto& tag = node.Tag();
  if (!tag.empty() && tag != "?" && tag != "!") out << YAML::VerbatimTag(tag);
}

// Like `out << node`, except that a scalar quoted in the input stays quoted:
// "yes" or "1.0" written as strings must not come back as a bool or a number.
void emitNode(YAML::Emitter& out, const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      emitTag(out, node);
      if (node.Tag() == "!") out << YAML::DoubleQuoted;
      out << node.Scalar();
      break;
    case YAML::NodeType::Sequence:
      emitTag(out, node);
      out << (node.Style() == YAML::EmitterStyle::Flow ? YAML::Flow : YAML::Block) << YAML::BeginSeq;
      for (const auto& item : node) emitNode(out, item);
      out << YAML::EndSeq;
      break;
    case YAML::NodeType::Map:
      emitTag(out, node);
      out << (node.Style() == YAML::EmitterStyle::Flow ? YAML::Flow : YAML::Block) << YAML::BeginMap;
      for (auto it = node.begin(); it != node.end(); ++it) {
        out << YAML::Key;
        emitNode(out, it->first);
        out << YAML::Value;
        emitNode(out, it->second);
      }
      out << YAML::EndMap;
      break;
    default:
      out << YAML::Null;
  }
}

std::string oneLine(std::string text) {
  for (auto& c : text)
    if (c == '\n' || c == '\r') c = ' ';
  return text;
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw config::ConfigError({path + ": cannot open the scene file"});
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void writeFile(const fs::path& path, const std::string& text) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) throw config::ConfigError({path.string() + ": cannot write the effective scene (check output.dir or --out)"});
}

}  // namespace

SceneOverride parseOverride(const std::string& argument) {
  const auto eq = argument.find('=');
  if (eq == std::string::npos) fail(argument, "expected key.path=value");
  SceneOverride o{argument, argument.substr(0, eq), argument.substr(eq + 1)};
  if (o.path.empty()) fail(argument, "no key path before '='");
  parseKeyPath(o.path, argument);
  return o;
}

std::vector<KeyStep> parseKeyPath(const std::string& path, const std::string& argument) {
  std::vector<KeyStep> steps;
  std::size_t pos = 0;
  while (pos < path.size()) {
    KeyStep step;
    if (path[pos] == '[') {
      pos = readIndex(path, pos, argument, step);
    } else {
      const auto end = std::min(path.find('.', pos), path.find('[', pos));
      step.key = path.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
      if (step.key.empty() || step.key.find(']') != std::string::npos)
        fail(argument, "'" + path + "' is not a key path (keys separated by '.', list items as [N] or by name)");
      pos = end == std::string::npos ? path.size() : end;
    }
    if (pos < path.size() && path[pos] != '[') {
      const bool emptyNext = path[pos] != '.' || pos + 1 == path.size() || path[pos + 1] == '.' || path[pos + 1] == '[';
      if (emptyNext) fail(argument, "'" + path + "' is not a key path (keys separated by '.', list items as [N] or by name)");
      ++pos;
    }
    steps.push_back(step);
  }
  if (steps.empty() || steps.front().isIndex) fail(argument, "a key path starts with a top-level key of the scene");
  return steps;
}

std::string applyOverrides(const std::string& sceneText, const std::string& sceneFile,
                           const std::vector<SceneOverride>& overrides) {
  YAML::Node root = config::loadYamlString(sceneText, sceneFile);
  if (!root.IsMap()) throw config::ConfigError({sceneFile + ": a scene is a map; --set needs its keys"});
  for (const auto& o : overrides) applyOne(root, o);
  YAML::Emitter out;
  emitNode(out, root);
  if (!out.good()) throw OverrideError("--set: cannot write the changed scene: " + out.GetLastError());
  std::string header = "# effective scene: " + oneLine(sceneFile) + " with";
  for (const auto& o : overrides) header += " --set " + oneLine(o.argument);
  return header + "\n" + out.c_str() + "\n";
}

static bool usableAsPath(const std::string& text) {
  return std::none_of(text.begin(), text.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; });
}

fs::path runDirectoryOf(const std::string& sceneText, const std::string& sceneFile, const std::string& outDir) {
  if (!outDir.empty()) return outDir;
  const YAML::Node root = config::loadYamlString(sceneText, sceneFile);
  const auto scalarAt = [](const YAML::Node& n) { return n && n.IsScalar() && !n.Scalar().empty() ? n.Scalar() : ""; };
  // Only what can name a directory: the loader reports an unusable name or
  // dir at its line, in the effective scene written beside the file's stem.
  static const std::regex sceneName("[A-Za-z0-9][A-Za-z0-9_.-]*");
  if (root.IsMap()) {
    if (root["output"] && root["output"].IsMap())
      if (auto dir = scalarAt(root["output"]["dir"]); !dir.empty() && usableAsPath(dir)) return dir;
    if (auto name = scalarAt(root["scene"]); std::regex_match(name, sceneName)) return fs::path("runs") / name;
  }
  return fs::path("runs") / fs::path(sceneFile).stem();
}

Scene loadSceneWithOverrides(const std::string& path, const std::vector<SceneOverride>& overrides,
                             const std::string& outDir) {
  if (overrides.empty()) return loadScene(path);
  const std::string text = applyOverrides(readFile(path), path, overrides);
  const fs::path effective = runDirectoryOf(text, path, outDir) / "scene.effective.yaml";
  writeFile(effective, text);
  return loadSceneText(text, effective.string(), fs::absolute(path).parent_path().string());
}

}  // namespace cosim::coupler
