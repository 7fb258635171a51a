#pragma once
// Typed, checked access to one YAML map of the scene: unknown keys, wrong
// types and bad values are errors that read "<file>:<line>: <key path>: ...".
#include <yaml-cpp/yaml.h>

#include <array>
#include <set>
#include <stdexcept>
#include <string>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

class SceneError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class YamlSection {
 public:
  YamlSection(YAML::Node node, std::string file, std::string path, const std::set<std::string>& allowed);
  std::string where(const YAML::Node& node) const;        // "<file>:<line>"
  std::string where(const std::string& key) const;         // location of a key's value
  [[noreturn]] void fail(const std::string& key, const std::string& message) const;
  bool has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  double number(const std::string& key, double fallback) const;
  double number(const std::string& key) const;  // required
  double positive(const std::string& key, double fallback) const;
  double positive(const std::string& key) const;
  long integer(const std::string& key, long fallback) const;
  bool flag(const std::string& key, bool fallback) const;
  std::string text(const std::string& key, const std::string& fallback) const;
  std::string text(const std::string& key) const;
  Vec3 vec3(const std::string& key, const Vec3& fallback) const;
  Vec3 vec3(const std::string& key) const;
  YAML::Node node(const std::string& key) const { return node_[key]; }
  YamlSection child(const std::string& key, const std::set<std::string>& allowed) const;
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  YAML::Node raw() const { return node_; }

 private:
  YAML::Node node_;
  std::string file_, path_;
};

Vec3 toVec3(const YAML::Node& node, const std::string& where);
/// A list element or nested value, checked: `where` is "<file>:<line>: <key path>".
double toNumber(const YAML::Node& node, const std::string& where);                // finite
long toInteger(const YAML::Node& node, const std::string& where, long lo, long hi);  // in [lo, hi]
std::string toText(const YAML::Node& node, const std::string& where);             // a scalar

}  // namespace cosim::dem
