#include "cosim/config/config_reader.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <sstream>

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

namespace cosim::config {
namespace {

std::string join(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += (out.empty() ? "" : "\n") + l;
  return out;
}

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// Each document of a YAML stream: where it starts (its first token) and
// where its top-level node is. yaml-cpp's LoadAll loops forever on a stream
// whose next token starts no document (a stray ','): this stops at the first
// document that consumes nothing.
struct Document {
  YAML::Mark start, root;
};

class Documents : public YAML::EventHandler {
 public:
  std::vector<Document> documents;
  void OnDocumentStart(const YAML::Mark& mark) override {
    documents.push_back({mark, mark});
    rootSeen_ = false;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { node(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override { node(mark); }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    node(mark);
  }
  void OnMapEnd() override {}

 private:
  void node(const YAML::Mark& mark) {
    if (!rootSeen_ && !documents.empty()) documents.back().root = mark;
    rootSeen_ = true;
  }
  bool rootSeen_ = false;
};

std::vector<Document> documentsOf(const std::string& text) {
  std::istringstream in(text);
  YAML::Parser parser(in);
  Documents handler;
  while (parser.HandleNextDocument(handler)) {
    const auto& d = handler.documents;
    if (d.size() > 1 && d[d.size() - 1].start.pos == d[d.size() - 2].start.pos) break;
  }
  return handler.documents;
}

}  // namespace

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

ConfigError::ConfigError(const std::vector<std::string>& lines) : std::runtime_error(join(lines)), lines_(lines) {}

std::string Diagnostics::where(const YAML::Mark& mark) const {
  return file_ + ":" + std::to_string(mark.line >= 0 ? mark.line + 1 : 1);
}

void Diagnostics::error(const YAML::Mark& mark, const std::string& message) {
  lines_.push_back(where(mark) + ": " + message);
}

void Diagnostics::throwIfAny() const {
  if (!lines_.empty()) throw ConfigError(lines_);
}

YAML::Node loadYamlString(const std::string& text, const std::string& name) {
  const auto where = [&name](const YAML::Mark& mark) { return name + ":" + std::to_string(mark.line + 1); };
  YAML::Node first;
  std::vector<Document> documents;
  try {
    documents = documentsOf(text);
    first = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError({where(e.mark) + ": YAML syntax error: " + e.msg});
  }
  // yaml-cpp starts an empty document at a token it cannot place, without
  // consuming it (a ',' after the top-level node): an error, not a document.
  for (std::size_t k = 1; k < documents.size(); ++k)
    if (documents[k].start.pos == documents[k - 1].start.pos) {
      const auto at = static_cast<std::size_t>(std::max(documents[k].start.pos, 0));
      throw ConfigError({where(documents[k].start) + ": YAML syntax error: unexpected '" + text.substr(at, 1) +
                         "' outside a [ ] or { } list"});
    }
  // A second document would be silently ignored by everyone reading the first.
  if (documents.size() > 1)
    throw ConfigError({where(documents[1].root) + ": a config is one YAML document; this file has " +
                       std::to_string(documents.size()) + " (remove the '---' separator)"});
  return first;
}

YAML::Node loadYamlFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError({path + ": cannot open the file"});
  std::stringstream text;
  text << in.rdbuf();
  return loadYamlString(text.str(), path);
}

std::optional<double> parseNumber(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::string lower = text;
  for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == ".inf" || lower == "+.inf") return std::numeric_limits<double>::infinity();
  if (lower == "-.inf") return -std::numeric_limits<double>::infinity();
  if (lower == ".nan") return std::numeric_limits<double>::quiet_NaN();
  // strtod, not stod: a subnormal such as 1e-310 is a number, and an overflow
  // comes back as inf (reported as "must be finite") rather than an exception.
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || text.find_first_of("xXpP") != std::string::npos) return std::nullopt;
  return v;
}

std::string Range::describe() const {
  std::string lo = std::isinf(min) ? "" : (minExclusive ? "> " : ">= ") + formatNumber(min);
  std::string hi = std::isinf(max) ? "" : "<= " + formatNumber(max);
  if (!lo.empty() && !hi.empty()) return lo + " and " + hi;
  return lo.empty() ? hi : lo;
}

MapReader::MapReader(const YAML::Node& node, std::string path, Diagnostics& diagnostics)
    : node_(node), path_(std::move(path)), diag_(diagnostics), mark_(node.Mark()) {
  if (!node.IsMap()) {
    valid_ = false;
    diag_.error(mark_, (path_.empty() ? std::string("the file") : path_) + ": expected a map of keys");
    return;
  }
  std::set<std::string> seen;
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) continue;  // finish() reports it
    const auto key = kv.first.Scalar();
    if (!seen.insert(key).second) diag_.error(kv.first.Mark(), keyPath(key) + ": duplicate key");
  }
}

std::string MapReader::keyPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

bool MapReader::has(const std::string& key) const { return valid_ && node_[key].IsDefined() && !node_[key].IsNull(); }

YAML::Node MapReader::node(const std::string& key) {
  if (!valid_) return YAML::Node(YAML::NodeType::Undefined);
  used_.insert(key);
  return node_[key];
}

YAML::Mark MapReader::markOf(const std::string& key) const {
  if (!valid_) return mark_;
  for (const auto& kv : node_)
    if (kv.first.as<std::string>("") == key) return kv.first.Mark();
  return mark_;
}

void MapReader::error(const std::string& key, const std::string& message) {
  diag_.error(markOf(key), keyPath(key) + ": " + message);
}

std::optional<std::string> MapReader::optionalString(const std::string& key) {
  auto n = node(key);
  if (!n.IsDefined() || n.IsNull()) return std::nullopt;
  if (!n.IsScalar()) {
    error(key, "expected a text value, got a " + std::string(n.IsMap() ? "map" : "list"));
    return std::nullopt;
  }
  return n.Scalar();
}

std::string MapReader::requireString(const std::string& key) {
  if (!has(key)) {
    diag_.error(mark_, (path_.empty() ? std::string("scene") : path_) + ": missing required key '" + key + "'");
    node(key);
    return {};
  }
  return optionalString(key).value_or("");
}

std::string MapReader::string(const std::string& key, const std::string& fallback) {
  return optionalString(key).value_or(fallback);
}

std::string MapReader::choice(const std::string& key, const std::vector<std::string>& allowed,
                              const std::optional<std::string>& fallback) {
  std::string value = fallback ? string(key, *fallback) : requireString(key);
  if (value.empty() && !fallback) return value;
  if (std::find(allowed.begin(), allowed.end(), value) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    error(key, "'" + value + "' is not one of: " + list);
  }
  return value;
}

std::optional<double> MapReader::optionalNumber(const std::string& key, Range range) {
  auto text = optionalString(key);
  if (!text) return std::nullopt;
  auto v = parseNumber(*text);
  if (!v) {
    error(key, "expected a number, got '" + *text + "'");
    return std::nullopt;
  }
  if (!std::isfinite(*v)) {
    error(key, "must be finite, got '" + *text + "'");
    return std::nullopt;
  }
  if (!range.contains(*v)) {
    error(key, "must be " + range.describe() + " (got " + *text + ")");
    return std::nullopt;
  }
  return v;
}

std::optional<double> MapReader::numberIn(const YAML::Node& item, const std::string& key, Range range) {
  const auto fail = [&](const std::string& message) {
    diag_.error(item.Mark(), keyPath(key) + ": " + message);
    return std::nullopt;
  };
  if (!item.IsScalar())
    return fail(std::string("expected a number, got a ") + (item.IsMap() ? "map" : item.IsSequence() ? "list" : "null"));
  const auto v = parseNumber(item.Scalar());
  if (!v) return fail("expected a number, got '" + item.Scalar() + "'");
  if (!std::isfinite(*v)) return fail("must be finite, got '" + item.Scalar() + "'");
  if (!range.contains(*v)) return fail("must be " + range.describe() + " (got " + item.Scalar() + ")");
  return v;
}

std::optional<double> MapReader::optionalLength(const std::string& key, const std::map<std::string, double>& scales,
                                                Range range) {
  auto text = optionalString(key);
  if (!text) return std::nullopt;
  std::size_t split = text->size();
  while (split > 0 && std::isalpha(static_cast<unsigned char>((*text)[split - 1]))) --split;
  const std::string unit = text->substr(split);
  std::optional<double> v = parseNumber(text->substr(0, split));
  if (!unit.empty() && v) {
    auto scale = scales.find(unit);
    if (scale == scales.end()) {
      std::string known;
      for (const auto& [name, value] : scales) known += (known.empty() ? "" : ", ") + name;
      error(key, "unknown length scale '" + unit + "' in '" + *text + "' (known: " + (known.empty() ? "none" : known) +
                     ")");
      return std::nullopt;
    }
    *v *= scale->second;
  }
  if (!v || !std::isfinite(*v)) {
    error(key, "expected a length (a number, or a multiple of a scale such as 10d), got '" + *text + "'");
    return std::nullopt;
  }
  if (!range.contains(*v)) {
    error(key, "must be " + range.describe() + " (got " + *text + ")");
    return std::nullopt;
  }
  return v;
}

double MapReader::requireNumber(const std::string& key, Range range) {
  if (!has(key)) {
    diag_.error(mark_, (path_.empty() ? std::string("scene") : path_) + ": missing required key '" + key + "'");
    node(key);
    return 0.0;
  }
  return optionalNumber(key, range).value_or(0.0);
}

double MapReader::number(const std::string& key, double fallback, Range range) {
  return optionalNumber(key, range).value_or(fallback);
}

std::optional<long> MapReader::optionalInteger(const std::string& key, long min, long max) {
  auto text = optionalString(key);
  if (!text) return std::nullopt;
  const auto range = "must be between " + std::to_string(min) + " and " + std::to_string(max) + " (got " + *text + ")";
  try {
    std::size_t used = 0;
    const long v = std::stol(*text, &used);
    if (used != text->size()) throw std::invalid_argument(*text);
    if (v < min || v > max) {
      error(key, range);
      return std::nullopt;
    }
    return v;
  } catch (const std::out_of_range&) {
    error(key, range);
    return std::nullopt;
  } catch (const std::exception&) {
    error(key, "expected an integer, got '" + *text + "'");
    return std::nullopt;
  }
}

long MapReader::integer(const std::string& key, long fallback, long min, long max) {
  return optionalInteger(key, min, max).value_or(fallback);
}

bool MapReader::boolean(const std::string& key, bool fallback) {
  auto text = optionalString(key);
  if (!text) return fallback;
  if (*text == "true" || *text == "yes" || *text == "on") return true;
  if (*text == "false" || *text == "no" || *text == "off") return false;
  error(key, "expected true or false, got '" + *text + "'");
  return fallback;
}

std::vector<std::string> MapReader::stringList(const std::string& key) {
  auto n = node(key);
  std::vector<std::string> out;
  if (!n.IsDefined() || n.IsNull()) return out;
  if (!n.IsSequence()) {
    error(key, "expected a list");
    return out;
  }
  for (const auto& item : n) {
    if (!item.IsScalar()) {
      diag_.error(item.Mark(), keyPath(key) + ": expected a list of text values");
      continue;
    }
    out.push_back(item.Scalar());
  }
  return out;
}

void MapReader::finish() {
  if (!valid_) return;
  std::vector<std::string> known(used_.begin(), used_.end());
  for (const auto& kv : node_) {
    if (!kv.first.IsScalar()) {
      diag_.error(kv.first.Mark(), (path_.empty() ? std::string("the file") : path_) + ": a key is a name, not a list or map");
      continue;
    }
    const auto key = kv.first.as<std::string>("");
    if (used_.count(key)) continue;
    std::string hint;
    for (const auto& k : known)
      if (editDistance(k, key) <= 2) hint = " (did you mean '" + k + "'?)";
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
    diag_.error(kv.first.Mark(), keyPath(key) + ": unknown key" + hint + "; known keys here: " + list);
  }
}

}  // namespace cosim::config
