#pragma once
// Reading a YAML config with validation that points at the line: every value
// is read through a MapReader, which knows the dotted key path, checks types
// and ranges, and reports keys nobody asked for. Errors are collected so a
// user sees all of them at once, each as `file:line: key: message`.
#include <yaml-cpp/yaml.h>

#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace cosim::config {

/// All problems found in one config file; what() is one `file:line: message` per line.
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(const std::vector<std::string>& lines);
  const std::vector<std::string>& lines() const { return lines_; }

 private:
  std::vector<std::string> lines_;
};

class Diagnostics {
 public:
  explicit Diagnostics(std::string file) : file_(std::move(file)) {}
  void error(const YAML::Mark& mark, const std::string& message);
  bool ok() const { return lines_.empty(); }
  /// Throws ConfigError when anything was reported.
  void throwIfAny() const;
  const std::string& file() const { return file_; }
  std::string where(const YAML::Mark& mark) const;

 private:
  std::string file_;
  std::vector<std::string> lines_;
};

/// Loads a YAML file; a missing file or a syntax error becomes a ConfigError.
YAML::Node loadYamlFile(const std::string& path);
YAML::Node loadYamlString(const std::string& text, const std::string& nameForMessages);

struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool minExclusive = false;
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true}; }
  static Range nonNegative() { return {0.0, std::numeric_limits<double>::infinity(), false}; }
  static Range closed(double lo, double hi) { return {lo, hi, false}; }
  bool contains(double v) const { return (minExclusive ? v > min : v >= min) && v <= max; }
  std::string describe() const;
};

class MapReader {
 public:
  /// node must be a map; path is the dotted key path for messages ("solvers[1]").
  MapReader(const YAML::Node& node, std::string path, Diagnostics& diagnostics);
  MapReader(const MapReader&) = delete;
  MapReader& operator=(const MapReader&) = delete;

  bool valid() const { return valid_; }
  bool has(const std::string& key) const;
  /// The raw node (marks the key as used); undefined node when absent.
  YAML::Node node(const std::string& key);
  const YAML::Mark& mark() const { return mark_; }
  YAML::Mark markOf(const std::string& key) const;
  std::string keyPath(const std::string& key) const;
  Diagnostics& diagnostics() { return diag_; }

  std::optional<std::string> optionalString(const std::string& key);
  std::string requireString(const std::string& key);
  std::string string(const std::string& key, const std::string& fallback);
  /// One of the allowed words.
  std::string choice(const std::string& key, const std::vector<std::string>& allowed,
                     const std::optional<std::string>& fallback = std::nullopt);
  std::optional<double> optionalNumber(const std::string& key, Range range = {});
  double requireNumber(const std::string& key, Range range = {});
  double number(const std::string& key, double fallback, Range range = {});
  /// A length in metres, written as a number or as a multiple of a named
  /// scale the way the papers do (`10d`, `1.5dx` with scales {d: 0.2, dx: 0.4}).
  std::optional<double> optionalLength(const std::string& key, const std::map<std::string, double>& scales,
                                       Range range = {});
  /// An item of the list under `key` (a point's coordinate, one of several
  /// depths), checked as optionalNumber and reported at the item's line.
  std::optional<double> numberIn(const YAML::Node& item, const std::string& key, Range range = {});
  long integer(const std::string& key, long fallback, long min, long max);
  std::optional<long> optionalInteger(const std::string& key, long min, long max);
  bool boolean(const std::string& key, bool fallback);
  std::vector<std::string> stringList(const std::string& key);

  /// Reports every key that was not read (with a suggestion for near misses).
  void finish();
  void error(const std::string& key, const std::string& message);
  void errorAt(const YAML::Mark& mark, const std::string& message) { diag_.error(mark, message); }

 private:
  YAML::Node node_;
  std::string path_;
  Diagnostics& diag_;
  YAML::Mark mark_;
  bool valid_ = true;
  std::set<std::string> used_;
};

/// Reads a scalar as a number (YAML's .inf/.nan spellings included); empty when it is not one.
std::optional<double> parseNumber(const std::string& text);

/// Shortest decimal text of a number, for messages ("0.001", not "0.001000").
std::string formatNumber(double value);

}  // namespace cosim::config

namespace cosim::config {

/// A solver's own section of a scene: the `params:` map of the `solvers:`
/// entry whose name is instance (an empty map when it has none). Throws
/// ConfigError naming the file when the scene has no such solver.
YAML::Node solverParams(const std::string& sceneYaml, const std::string& sceneFile, const std::string& instance);

}  // namespace cosim::config
