#pragma once
// Strict reading of the solver's `params:` map: every key is looked up by
// name, unknown keys are errors, and every message is `<scene>:<line>: ...`.
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

#include "cosim/fem/types.hpp"

namespace cosim::fem {

class ParamMap {
 public:
  ParamMap(YAML::Node node, std::string file, std::string path);
  bool has(const std::string& key) const;
  YAML::Node get(const std::string& key);  // required
  double number(const std::string& key);
  double number(const std::string& key, double fallback);
  int integer(const std::string& key, int fallback);
  std::string text(const std::string& key);
  std::string text(const std::string& key, const std::string& fallback);
  bool flag(const std::string& key, bool fallback);
  Vec3 vec3(const std::string& key);
  ParamMap map(const std::string& key);
  /// A list of names (`key: [a, b]`); anything else, or an entry that is not a
  /// name, fails as `<file>:<line>: <path>.key: expected a list of <what>, got ...`.
  std::vector<std::string> names(const std::string& key, const std::string& what);
  /// A key of a user map (`sets:`, `zones:`) as text; a list or map key fails naming `of`.
  std::string keyName(const YAML::Node& key, const std::string& of) const;
  /// Throws for any key that was never asked for.
  void finish() const;
  [[noreturn]] void fail(const YAML::Node& at, const std::string& message) const;
  std::string where(const YAML::Node& at) const;
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }
  YAML::Node node() const { return node_; }

 private:
  YAML::Node node_;
  std::string file_, path_;
  mutable std::set<std::string> used_;
};

}  // namespace cosim::fem
