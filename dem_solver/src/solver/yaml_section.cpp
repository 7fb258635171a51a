#include "cosim/dem/solver/yaml_section.hpp"

#include <cmath>
#include <limits>

namespace cosim::dem {

namespace {
// A missing or empty section reads as an empty map (yaml-cpp's missing-key
// nodes cannot be assigned to, so replace them before storing).
YAML::Node orEmptyMap(const YAML::Node& n) {
  if (!n.IsDefined() || n.IsNull()) return YAML::Node(YAML::NodeType::Map);
  return n;
}

// A value as a message shows it.
std::string shown(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  return n.IsSequence() ? "a list" : n.IsMap() ? "a map" : "nothing";
}
}  // namespace

double toNumber(const YAML::Node& n, const std::string& where) {
  double v = 0.0;
  try {
    v = n.as<double>();
  } catch (const YAML::Exception&) {
    throw SceneError(where + ": expected a number, got " + shown(n));
  }
  if (!std::isfinite(v)) throw SceneError(where + ": must be finite, got " + shown(n));
  return v;
}

long toInteger(const YAML::Node& n, const std::string& where, long lo, long hi) {
  long v = 0;
  try {
    v = n.as<long>();
  } catch (const YAML::Exception&) {
    throw SceneError(where + ": expected an integer, got " + shown(n));
  }
  if (v < lo || v > hi)
    throw SceneError(where + ": " + std::to_string(v) + " is out of range [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
  return v;
}

std::string toText(const YAML::Node& n, const std::string& where) {
  if (!n || !n.IsScalar()) throw SceneError(where + ": expected a string, got " + shown(n));
  return n.Scalar();
}

YamlSection::YamlSection(YAML::Node node, std::string file, std::string path, const std::set<std::string>& allowed)
    : node_(orEmptyMap(node)), file_(std::move(file)), path_(std::move(path)) {
  if (!node_.IsMap()) throw SceneError(where(node_) + ": " + path_ + ": expected a map");
  for (const auto& kv : node_) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : "(a list or map as key)";
    if (!allowed.count(key)) {
      std::string known;
      for (const auto& a : allowed) known += (known.empty() ? "" : ", ") + a;
      throw SceneError(where(kv.first) + ": " + path_ + ": unknown key '" + key + "' (allowed: " + known + ")");
    }
  }
}

std::string YamlSection::where(const YAML::Node& node) const {
  return file_ + ":" + std::to_string(node.Mark().line + 1);
}

std::string YamlSection::where(const std::string& key) const {
  return node_[key] ? where(node_[key]) : where(node_);
}

void YamlSection::fail(const std::string& key, const std::string& message) const {
  throw SceneError(where(key) + ": " + path_ + "." + key + ": " + message);
}

double YamlSection::number(const std::string& key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

double YamlSection::number(const std::string& key) const {
  if (!has(key)) fail(key, "required number is missing");
  return toNumber(node_[key], where(key) + ": " + path_ + "." + key);
}

double YamlSection::positive(const std::string& key, double fallback) const {
  return has(key) ? positive(key) : fallback;
}

double YamlSection::positive(const std::string& key) const {
  const double v = number(key);
  if (!(v > 0.0)) fail(key, "must be positive, got " + std::to_string(v));
  return v;
}

long YamlSection::integer(const std::string& key, long fallback) const {
  if (!has(key)) return fallback;
  return toInteger(node_[key], where(key) + ": " + path_ + "." + key, std::numeric_limits<long>::min(),
                   std::numeric_limits<long>::max());
}

bool YamlSection::flag(const std::string& key, bool fallback) const {
  if (!has(key)) return fallback;
  try {
    return node_[key].as<bool>();
  } catch (const YAML::Exception&) {
    fail(key, "expected true or false");
  }
}

std::string YamlSection::text(const std::string& key, const std::string& fallback) const {
  return has(key) ? text(key) : fallback;
}

std::string YamlSection::text(const std::string& key) const {
  const YAML::Node n = node_[key];
  if (!n) fail(key, "required value is missing");
  if (!n.IsScalar()) fail(key, "expected a string");
  return n.Scalar();
}

Vec3 toVec3(const YAML::Node& n, const std::string& where) {
  if (!n.IsSequence() || n.size() != 3) throw SceneError(where + ": expected a list of 3 numbers");
  Vec3 v;
  for (int d = 0; d < 3; ++d) {
    try {
      v[d] = n[static_cast<std::size_t>(d)].as<double>();
    } catch (const YAML::Exception&) {
      throw SceneError(where + ": expected a list of 3 numbers");
    }
    if (!std::isfinite(v[d])) throw SceneError(where + ": non-finite component");
  }
  return v;
}

Vec3 YamlSection::vec3(const std::string& key, const Vec3& fallback) const {
  return has(key) ? vec3(key) : fallback;
}

Vec3 YamlSection::vec3(const std::string& key) const {
  if (!has(key)) fail(key, "required vector is missing");
  return toVec3(node_[key], where(key) + ": " + path_ + "." + key);
}

YamlSection YamlSection::child(const std::string& key, const std::set<std::string>& allowed) const {
  return YamlSection(node_[key], file_, path_ + "." + key, allowed);
}

}  // namespace cosim::dem
