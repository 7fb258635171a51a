// MapReader: typed reads with ranges, integer and boolean parsing, unknown
// keys with suggestions, duplicate keys, and errors collected as
// `file:line: key.path: message`.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "cosim/config/config_reader.hpp"

using cosim::config::ConfigError;
using cosim::config::Diagnostics;
using cosim::config::MapReader;
using cosim::config::Range;

namespace {

YAML::Node parse(const std::string& text) { return cosim::config::loadYamlString(text, "test.yaml"); }

/// The collected error lines (empty when none).
std::vector<std::string> errorsOf(const Diagnostics& d) {
  try {
    d.throwIfAny();
  } catch (const ConfigError& e) {
    return e.lines();
  }
  return {};
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += "\n  " + l;
  return out;
}

// ---------------------------------------------------------------------------
// Ranges

TEST(ConfigRange, Contains) {
  EXPECT_FALSE(Range::positive().contains(0.0));
  EXPECT_TRUE(Range::positive().contains(1e-300));
  EXPECT_FALSE(Range::positive().contains(-1.0));
  EXPECT_TRUE(Range::nonNegative().contains(0.0));
  EXPECT_FALSE(Range::nonNegative().contains(-1e-300));
  EXPECT_TRUE(Range::closed(0.0, 1.0).contains(0.0));
  EXPECT_TRUE(Range::closed(0.0, 1.0).contains(1.0));
  EXPECT_FALSE(Range::closed(0.0, 1.0).contains(1.0000001));
  const Range openBelow{0.0, 1.0, true};
  EXPECT_FALSE(openBelow.contains(0.0));
  EXPECT_TRUE(openBelow.contains(1.0));
  EXPECT_TRUE(Range{}.contains(-1e300));
}

TEST(ConfigRange, Describe) {
  EXPECT_EQ(Range::positive().describe(), "> 0");
  EXPECT_EQ(Range::nonNegative().describe(), ">= 0");
  EXPECT_EQ(Range::closed(0.0, 1.0).describe(), ">= 0 and <= 1");
  EXPECT_EQ((Range{0.0, 1.0, true}).describe(), "> 0 and <= 1");
  EXPECT_EQ((Range{-std::numeric_limits<double>::infinity(), 5.0, false}).describe(), "<= 5");
}

TEST(ConfigParseNumber, AcceptsYamlNumbersOnly) {
  using cosim::config::parseNumber;
  EXPECT_EQ(parseNumber("1.5"), 1.5);
  EXPECT_EQ(parseNumber("-2e-3"), -2e-3);
  EXPECT_EQ(parseNumber("10"), 10.0);
  EXPECT_EQ(parseNumber(".inf"), std::numeric_limits<double>::infinity());
  EXPECT_EQ(parseNumber("-.inf"), -std::numeric_limits<double>::infinity());
  ASSERT_TRUE(parseNumber(".nan"));
  EXPECT_TRUE(std::isnan(*parseNumber(".nan")));
  EXPECT_FALSE(parseNumber("abc"));
  EXPECT_FALSE(parseNumber("1.5x"));
  EXPECT_FALSE(parseNumber("1.5 m"));
  EXPECT_FALSE(parseNumber(""));
}

// ---------------------------------------------------------------------------
// Numbers

TEST(MapReaderNumbers, RangeTypeAndFiniteness) {
  Diagnostics diag("test.yaml");
  const auto root = parse("a: 2.5\nb: -1\nc: text\nd: .nan\ne: .inf\nf: [1]\n");
  MapReader m(root, "", diag);
  EXPECT_DOUBLE_EQ(m.number("a", 0.0, Range::positive()), 2.5);
  EXPECT_DOUBLE_EQ(m.number("b", 7.0, Range::positive()), 7.0);  // fallback after the error
  EXPECT_FALSE(m.optionalNumber("c"));
  EXPECT_FALSE(m.optionalNumber("d"));
  EXPECT_FALSE(m.optionalNumber("e"));
  EXPECT_FALSE(m.optionalNumber("f"));
  EXPECT_DOUBLE_EQ(m.number("absent", 3.0, Range::positive()), 3.0);
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 5u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:2: b: must be > 0 (got -1)");
  EXPECT_EQ(lines[1], "test.yaml:3: c: expected a number, got 'text'");
  EXPECT_EQ(lines[2], "test.yaml:4: d: must be finite, got '.nan'");
  EXPECT_EQ(lines[3], "test.yaml:5: e: must be finite, got '.inf'");
  EXPECT_EQ(lines[4], "test.yaml:6: f: expected a text value, got a list");
}

TEST(MapReaderNumbers, RequiredNumberMissingPointsAtTheMap) {
  Diagnostics diag("test.yaml");
  const auto root = parse("# comment\nouter:\n  x: 1\n");
  MapReader m(root["outer"], "outer", diag);
  EXPECT_DOUBLE_EQ(m.requireNumber("x"), 1.0);
  EXPECT_DOUBLE_EQ(m.requireNumber("y"), 0.0);
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 1u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:3: outer: missing required key 'y'");
}

// ---------------------------------------------------------------------------
// Integers

TEST(MapReaderIntegers, ParsingAndRange) {
  Diagnostics diag("test.yaml");
  const auto root = parse("n: 42\nf: 4.5\nj: 12abc\nbig: 70000\nneg: -3\ne: 1e3\nplus: +7\n");
  MapReader m(root, "", diag);
  EXPECT_EQ(m.integer("n", 0, 0, 100), 42);
  EXPECT_EQ(m.integer("f", -1, 0, 100), -1);
  EXPECT_EQ(m.integer("j", -1, 0, 100), -1);
  EXPECT_EQ(m.integer("big", 0, 0, 65535), 0);
  EXPECT_EQ(m.integer("neg", 5, 0, 10), 5);
  EXPECT_EQ(m.integer("e", -1, 0, 10000), -1);
  EXPECT_EQ(m.integer("plus", 0, 0, 10), 7);
  EXPECT_EQ(m.integer("absent", 9, 0, 10), 9);
  EXPECT_FALSE(m.optionalInteger("absent2", 0, 10));
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 5u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:2: f: expected an integer, got '4.5'");
  EXPECT_EQ(lines[1], "test.yaml:3: j: expected an integer, got '12abc'");
  EXPECT_EQ(lines[2], "test.yaml:4: big: must be between 0 and 65535 (got 70000)");
  EXPECT_EQ(lines[3], "test.yaml:5: neg: must be between 0 and 10 (got -3)");
  EXPECT_EQ(lines[4], "test.yaml:6: e: expected an integer, got '1e3'");
}

// ---------------------------------------------------------------------------
// Booleans

TEST(MapReaderBooleans, AcceptedSpellingsAndErrors) {
  Diagnostics diag("test.yaml");
  const auto root = parse("a: true\nb: yes\nc: on\nd: false\ne: no\nf: off\ng: maybe\nh: 1\n");
  MapReader m(root, "", diag);
  EXPECT_TRUE(m.boolean("a", false));
  EXPECT_TRUE(m.boolean("b", false));
  EXPECT_TRUE(m.boolean("c", false));
  EXPECT_FALSE(m.boolean("d", true));
  EXPECT_FALSE(m.boolean("e", true));
  EXPECT_FALSE(m.boolean("f", true));
  EXPECT_TRUE(m.boolean("g", true));  // fallback after the error
  EXPECT_FALSE(m.boolean("h", false));
  EXPECT_TRUE(m.boolean("absent", true));
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 2u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:7: g: expected true or false, got 'maybe'");
  EXPECT_EQ(lines[1], "test.yaml:8: h: expected true or false, got '1'");
}

// ---------------------------------------------------------------------------
// Text, choices and lists

TEST(MapReaderText, TypesAndKeyPaths) {
  Diagnostics diag("test.yaml");
  const auto root = parse("solvers:\n  - name: left\n    kind: {a: 1}\n    args: [x]\n    empty:\n");
  MapReader m(root["solvers"][0], "solvers[0]", diag);
  EXPECT_EQ(m.requireString("name"), "left");
  EXPECT_FALSE(m.optionalString("kind"));
  EXPECT_FALSE(m.optionalString("args"));
  EXPECT_EQ(m.string("empty", "dflt"), "dflt");  // a null value counts as absent
  EXPECT_FALSE(m.has("empty"));
  EXPECT_TRUE(m.has("name"));
  EXPECT_EQ(m.requireString("binary"), "");
  EXPECT_EQ(m.keyPath("kind"), "solvers[0].kind");
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 3u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:3: solvers[0].kind: expected a text value, got a map");
  EXPECT_EQ(lines[1], "test.yaml:4: solvers[0].args: expected a text value, got a list");
  EXPECT_EQ(lines[2], "test.yaml:2: solvers[0]: missing required key 'binary'");
}

TEST(MapReaderText, Choice) {
  Diagnostics diag("test.yaml");
  const auto root = parse("a: tcp\nb: udp\n");
  MapReader m(root, "transport", diag);
  EXPECT_EQ(m.choice("a", {"ipc", "tcp"}), "tcp");
  EXPECT_EQ(m.choice("b", {"ipc", "tcp"}, std::string("ipc")), "udp");
  EXPECT_EQ(m.choice("c", {"ipc", "tcp"}, std::string("ipc")), "ipc");
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 1u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:2: transport.b: 'udp' is not one of: ipc, tcp");
}

TEST(MapReaderText, StringLists) {
  Diagnostics diag("test.yaml");
  const auto root = parse("l: [a, b]\ns: a\nm:\n  - a\n  - {b: 1}\n");
  MapReader m(root, "", diag);
  EXPECT_EQ(m.stringList("l"), (std::vector<std::string>{"a", "b"}));
  EXPECT_TRUE(m.stringList("s").empty());
  EXPECT_EQ(m.stringList("m"), std::vector<std::string>{"a"});
  EXPECT_TRUE(m.stringList("absent").empty());
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 2u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:2: s: expected a list");
  EXPECT_EQ(lines[1], "test.yaml:5: m: expected a list of text values");
}

// ---------------------------------------------------------------------------
// Unknown and duplicate keys

TEST(MapReaderKeys, UnknownKeysWithSuggestions) {
  Diagnostics diag("test.yaml");
  const auto root = parse("alpha: 1\nbeta: 2\nalpah: 3\nzzzzzz: 4\ngama: 5\n");
  MapReader m(root, "section", diag);
  m.number("alpha", 0.0);
  m.number("beta", 0.0);
  m.number("gamma", 0.0);  // asked for but absent: still a known key
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 3u) << joined(lines);
  EXPECT_EQ(lines[0],
            "test.yaml:3: section.alpah: unknown key (did you mean 'alpha'?); known keys here: alpha, beta, gamma");
  EXPECT_EQ(lines[1], "test.yaml:4: section.zzzzzz: unknown key; known keys here: alpha, beta, gamma");
  EXPECT_EQ(lines[2],
            "test.yaml:5: section.gama: unknown key (did you mean 'gamma'?); known keys here: alpha, beta, gamma");
}

TEST(MapReaderKeys, NodeMarksAKeyAsUsed) {
  Diagnostics diag("test.yaml");
  const auto root = parse("params: {x: 1}\nother: 2\n");
  MapReader m(root, "", diag);
  EXPECT_TRUE(m.node("params").IsMap());
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 1u) << joined(lines);
  EXPECT_NE(lines[0].find("test.yaml:2: other: unknown key"), std::string::npos) << lines[0];
}

TEST(MapReaderKeys, DuplicateKeysReportedOnce) {
  Diagnostics diag("test.yaml");
  const auto root = parse("a: 1\nb: 2\na: 3\n");
  MapReader m(root, "sec", diag);
  m.number("a", 0.0);
  m.number("b", 0.0);
  m.finish();
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 1u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:3: sec.a: duplicate key");
  EXPECT_EQ(m.markOf("a").line + 1, 1);  // the first occurrence is the one read
}

TEST(MapReaderKeys, NotAMap) {
  Diagnostics diag("test.yaml");
  const auto root = parse("# c\nsched:\n  - 1\n  - 2\n");
  MapReader m(root["sched"], "sched", diag);
  EXPECT_FALSE(m.valid());
  EXPECT_FALSE(m.has("x"));
  EXPECT_DOUBLE_EQ(m.number("x", 4.0), 4.0);
  EXPECT_EQ(m.string("y", "z"), "z");
  m.finish();  // nothing more to say about a non-map
  const auto lines = errorsOf(diag);
  ASSERT_EQ(lines.size(), 1u) << joined(lines);
  EXPECT_EQ(lines[0], "test.yaml:3: sched: expected a map of keys");
}

// ---------------------------------------------------------------------------
// Collection, files and the solver's own section

TEST(ConfigDiagnostics, CollectsAndThrowsTogether) {
  Diagnostics diag("scene.yaml");
  EXPECT_TRUE(diag.ok());
  EXPECT_NO_THROW(diag.throwIfAny());
  YAML::Mark first;
  first.line = 4;
  diag.error(first, "first problem");
  diag.error(YAML::Mark::null_mark(), "no position");
  EXPECT_FALSE(diag.ok());
  try {
    diag.throwIfAny();
    FAIL() << "did not throw";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.lines().size(), 2u);
    EXPECT_EQ(e.lines()[0], "scene.yaml:5: first problem");
    EXPECT_EQ(e.lines()[1], "scene.yaml:1: no position");
    EXPECT_EQ(std::string(e.what()), "scene.yaml:5: first problem\nscene.yaml:1: no position");
  }
}

TEST(ConfigFiles, SyntaxErrorNamesFileAndLine) {
  try {
    cosim::config::loadYamlString("a: 1\nb:\n  c: 2\n d: 3\n", "broken.yaml");
    FAIL() << "parsed";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.yaml:4: YAML syntax error"), std::string::npos) << e.what();
  }
}

TEST(ConfigFiles, MissingFile) {
  try {
    cosim::config::loadYamlFile("/nonexistent/x.yaml");
    FAIL() << "loaded";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/x.yaml: cannot open the file");
  }
}

TEST(ConfigFiles, LoadsAFile) {
  const auto path = std::filesystem::temp_directory_path() / ("cosim_cfg_reader_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << "k: 3\n";
  const auto node = cosim::config::loadYamlFile(path.string());
  std::filesystem::remove(path);
  EXPECT_EQ(node["k"].as<int>(), 3);
}

TEST(ConfigSolverParams, FindsTheInstanceSection) {
  const std::string scene =
      "scene: s\n"
      "solvers:\n"
      "  - {name: a, kind: mock, params: {seed: 3}}\n"
      "  - {name: b, kind: mock}\n";
  const auto a = cosim::config::solverParams(scene, "s.yaml", "a");
  ASSERT_TRUE(a.IsMap());
  EXPECT_EQ(a["seed"].as<int>(), 3);
  const auto b = cosim::config::solverParams(scene, "s.yaml", "b");
  EXPECT_TRUE(b.IsMap());
  EXPECT_EQ(b.size(), 0u);
  try {
    cosim::config::solverParams(scene, "s.yaml", "c");
    FAIL() << "found a solver that is not there";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "s.yaml: no solver named 'c' under solvers");
  }
}

}  // namespace
