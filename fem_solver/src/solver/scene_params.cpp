#include "cosim/fem/solver/scene_params.hpp"

#include <cmath>

namespace cosim::fem {

namespace {
/// What a YAML node is, for `expected ..., got <this>` messages.
std::string describe(const YAML::Node& n) {
  if (n.IsMap()) return "a map";
  if (n.IsSequence()) return "a list";
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  return "nothing";
}
}  // namespace

ParamMap::ParamMap(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {
  if (!node_.IsMap()) fail(node_, path_ + " must be a map");
}

std::string ParamMap::where(const YAML::Node& at) const {
  const int line = at.Mark().line >= 0 ? at.Mark().line + 1 : node_.Mark().line + 1;
  return file_ + ":" + std::to_string(line);
}

void ParamMap::fail(const YAML::Node& at, const std::string& message) const {
  throw InputError(where(at) + ": " + message);
}

bool ParamMap::has(const std::string& key) const {
  used_.insert(key);
  return static_cast<bool>(node_[key]);
}

YAML::Node ParamMap::get(const std::string& key) {
  used_.insert(key);
  YAML::Node n = node_[key];
  if (!n) fail(node_, path_ + ": missing key '" + key + "'");
  return n;
}

double ParamMap::number(const std::string& key) {
  YAML::Node n = get(key);
  double v = 0.0;
  try {
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    fail(n, path_ + "." + key + " must be a number");
  }
  if (!std::isfinite(v)) fail(n, path_ + "." + key + " must be finite");
  return v;
}

double ParamMap::number(const std::string& key, double fallback) { return has(key) ? number(key) : fallback; }

int ParamMap::integer(const std::string& key, int fallback) {
  if (!has(key)) return fallback;
  YAML::Node n = get(key);
  try {
    return n.as<int>();
  } catch (const YAML::Exception&) {
    fail(n, path_ + "." + key + " must be an integer");
  }
}

std::string ParamMap::text(const std::string& key) {
  YAML::Node n = get(key);
  if (!n.IsScalar()) fail(n, path_ + "." + key + " must be a string");
  return n.as<std::string>();
}

std::string ParamMap::text(const std::string& key, const std::string& fallback) {
  return has(key) ? text(key) : fallback;
}

bool ParamMap::flag(const std::string& key, bool fallback) {
  if (!has(key)) return fallback;
  YAML::Node n = get(key);
  try {
    return n.as<bool>();
  } catch (const YAML::Exception&) {
    fail(n, path_ + "." + key + " must be true or false");
  }
}

Vec3 ParamMap::vec3(const std::string& key) {
  YAML::Node n = get(key);
  if (!n.IsSequence() || n.size() != 3) fail(n, path_ + "." + key + " must be a list of three numbers");
  Vec3 v;
  for (std::size_t i = 0; i < 3; ++i) {
    try {
      v[static_cast<int>(i)] = n[i].as<double>();
    } catch (const YAML::Exception&) {
      fail(n, path_ + "." + key + " must be a list of three numbers");
    }
    if (!std::isfinite(v[static_cast<int>(i)])) fail(n, path_ + "." + key + " must be finite");
  }
  return v;
}

ParamMap ParamMap::map(const std::string& key) {
  YAML::Node n = get(key);
  if (!n.IsMap()) fail(n, path_ + "." + key + " must be a map");
  return ParamMap(n, file_, path_ + "." + key);
}

std::vector<std::string> ParamMap::names(const std::string& key, const std::string& what) {
  YAML::Node n = get(key);
  const std::string name = path_ + "." + key;
  if (!n.IsSequence()) fail(n, name + ": expected a list of " + what + ", got " + describe(n));
  std::vector<std::string> out;
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (!n[i].IsScalar())
      fail(n[i], name + "[" + std::to_string(i) + "]: expected a name, got " + describe(n[i]) + " (" + key +
                     " is a list of " + what + ")");
    out.push_back(n[i].Scalar());
  }
  return out;
}

std::string ParamMap::keyName(const YAML::Node& key, const std::string& of) const {
  if (!key.IsScalar()) fail(key, of + ": expected a name as key, got " + describe(key));
  return key.Scalar();
}

void ParamMap::finish() const {
  for (const auto& kv : node_) {
    const std::string key = keyName(kv.first, path_);
    if (!used_.count(key)) fail(kv.first, "unknown key '" + key + "' in " + path_);
  }
}

}  // namespace cosim::fem
