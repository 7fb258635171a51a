// `--set key.path=value`: the scene text changed before validation. Unit tests
// of key paths, values and errors; the effective scene file that later
// messages name; and `coupler run|check --set` end to end with mock solvers.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene_overrides.hpp"
#include "subprocess.hpp"

namespace fs = std::filesystem;
using cosim::coupler::applyOverrides;
using cosim::coupler::loadSceneWithOverrides;
using cosim::coupler::OverrideError;
using cosim::coupler::parseOverride;
using cosim::coupler::SceneOverride;

namespace {

const char* kScene =
    "scene: unit\n"
    "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 1.0}\n"
    "solvers:\n"
    "  - name: left\n"
    "    kind: mock\n"
    "    params: {seed: 1, label: \"007\"}\n"
    "  - name: right\n"
    "    kind: mock\n"
    "    params:\n"
    "      seed: 2\n"
    "couplings:\n"
    "  - name: top\n"
    "    kind: direct-transfer\n"
    "    width: 5d\n";

std::vector<SceneOverride> sets(const std::vector<std::string>& arguments) {
  std::vector<SceneOverride> out;
  for (const auto& a : arguments) out.push_back(parseOverride(a));
  return out;
}

YAML::Node applied(const std::vector<std::string>& arguments) {
  return YAML::Load(applyOverrides(kScene, "unit.yaml", sets(arguments)));
}

/// The message of the OverrideError that applying the arguments throws ("" when none is thrown).
std::string overrideError(const std::vector<std::string>& arguments) {
  try {
    applied(arguments);
  } catch (const OverrideError& e) {
    return e.what();
  }
  return {};
}

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string lineOf(const std::string& text, int line) {
  std::istringstream in(text);
  std::string l;
  for (int i = 0; i < line && std::getline(in, l); ++i) {
  }
  return l;
}

std::string demoScene() { return cosim::testing::sourcePath("configs/demo/two_mocks.yaml"); }

}  // namespace

TEST(SceneOverrides, SetsAMapKeyAndKeepsEverythingElse) {
  const auto root = applied({"schedule.dt=1e-5"});
  EXPECT_EQ(root["schedule"]["dt"].as<std::string>(), "1e-5");
  EXPECT_EQ(root["schedule"]["end_time"].as<std::string>(), "1.0");
  EXPECT_EQ(root["schedule"]["kind"].as<std::string>(), "lockstep");
  ASSERT_EQ(root["solvers"].size(), 2u);
  EXPECT_EQ(root["solvers"][1]["params"]["seed"].as<int>(), 2);
  EXPECT_EQ(root["couplings"][0]["width"].as<std::string>(), "5d");
}

TEST(SceneOverrides, AddressesListItemsByNameAndByIndex) {
  const auto root = applied({"solvers.right.params.seed=7", "solvers[0].params.seed=9", "couplings.top.width=10d"});
  EXPECT_EQ(root["solvers"][0]["params"]["seed"].as<int>(), 9);
  EXPECT_EQ(root["solvers"][1]["params"]["seed"].as<int>(), 7);
  EXPECT_EQ(root["couplings"][0]["width"].as<std::string>(), "10d");
}

TEST(SceneOverrides, ParsesTheValueAsYaml) {
  const auto root = applied({"solvers[1].params.gravity=[0,0,-9.81]", "solvers.left.params.box={min: [0, 0], max: [1, 2]}"});
  const auto gravity = root["solvers"][1]["params"]["gravity"];
  ASSERT_TRUE(gravity.IsSequence());
  ASSERT_EQ(gravity.size(), 3u);
  EXPECT_DOUBLE_EQ(gravity[2].as<double>(), -9.81);
  EXPECT_DOUBLE_EQ(root["solvers"][0]["params"]["box"]["max"][1].as<double>(), 2.0);
}

TEST(SceneOverrides, CreatesAMissingLastKeyInAnExistingMap) {
  const auto root = applied({"schedule.safety=0.25", "output={dir: runs/x}"});
  EXPECT_DOUBLE_EQ(root["schedule"]["safety"].as<double>(), 0.25);
  EXPECT_EQ(root["output"]["dir"].as<std::string>(), "runs/x");
}

TEST(SceneOverrides, ReplacesAWholeListItemAndAppliesInOrder) {
  const auto root = applied({"schedule.dt=1", "schedule.dt=2", "solvers[1]={name: other, kind: mock}"});
  EXPECT_EQ(root["schedule"]["dt"].as<int>(), 2);
  EXPECT_EQ(root["solvers"][1]["name"].as<std::string>(), "other");
  EXPECT_FALSE(root["solvers"][1]["params"]);
}

TEST(SceneOverrides, QuotedStringsStayStrings) {
  const auto text = applyOverrides(kScene, "unit.yaml", sets({"scene=\"yes\"", "solvers.left.params.n=\"1.0\""}));
  EXPECT_NE(text.find("\"007\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"yes\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"1.0\""), std::string::npos) << text;
  EXPECT_EQ(text.rfind("# effective scene: unit.yaml with --set scene=\"yes\"", 0), 0u) << text;
}

TEST(SceneOverrides, AMissingKeyOnTheWayNamesTheArgumentAndTheMissingPart) {
  const auto message = overrideError({"schedule.nokey.dt=1"});
  EXPECT_NE(message.find("--set 'schedule.nokey.dt=1'"), std::string::npos) << message;
  EXPECT_NE(message.find("schedule has no key 'nokey'"), std::string::npos) << message;
  EXPECT_NE(message.find("to add it, give the whole map: --set 'schedule.nokey={dt: 1}'"), std::string::npos) << message;
  const auto top = overrideError({"placement.processes=packed"});
  EXPECT_NE(top.find("--set 'placement={processes: packed}'"), std::string::npos) << top;
}

TEST(SceneOverrides, AnUnknownItemNameListsTheNames) {
  const auto message = overrideError({"solvers.middle.params.seed=3"});
  EXPECT_NE(message.find("--set 'solvers.middle.params.seed=3'"), std::string::npos) << message;
  EXPECT_NE(message.find("no item named 'middle' (names: left, right)"), std::string::npos) << message;
  EXPECT_NE(overrideError({"solvers.1.params.seed=3"}).find("write solvers[1]"), std::string::npos);
}

TEST(SceneOverrides, AnIndexPastTheEndIsAnError) {
  const auto message = overrideError({"solvers[2].params.seed=3"});
  EXPECT_NE(message.find("solvers[2] does not exist: solvers has 2 item(s)"), std::string::npos) << message;
  EXPECT_NE(overrideError({"solvers[2]={name: x}"}).find("solvers[2]"), std::string::npos);
  EXPECT_NE(overrideError({"solvers.nobody={name: x}"}).find("no item named 'nobody'"), std::string::npos);
}

TEST(SceneOverrides, ASingleValueIsNotAMap) {
  const auto message = overrideError({"schedule.dt.value=3"});
  EXPECT_NE(message.find("schedule.dt is a single value, not a map"), std::string::npos) << message;
  EXPECT_NE(overrideError({"schedule[0]=3"}).find("schedule is not a list"), std::string::npos);
}

TEST(SceneOverrides, MalformedArgumentsAreRefused) {
  for (const std::string bad : {"schedule.dt", "=1", "a..b=1", "a.=1", ".a=1", "a[x]=1", "[0].a=1", "a[1]b=1", "a[]=1",
                                "a.[1]=1", "a]=1"})
    EXPECT_THROW(parseOverride(bad), OverrideError) << bad;
  EXPECT_NE(overrideError({"schedule.dt="}).find("no value after '='"), std::string::npos);
  EXPECT_NE(overrideError({"schedule.dt=[1,2"}).find("is not valid YAML"), std::string::npos);
  const auto steps = cosim::coupler::parseKeyPath("solvers[1].params.list[0][2]", "x");
  ASSERT_EQ(steps.size(), 6u);
  EXPECT_TRUE(steps[1].isIndex);
  EXPECT_EQ(steps[1].index, 1u);
  EXPECT_EQ(steps[3].key, "list");
  EXPECT_EQ(steps[5].index, 2u);
}

TEST(SceneOverrides, RunDirectoryFollowsOutThenOutputDirThenSceneName) {
  using cosim::coupler::runDirectoryOf;
  EXPECT_EQ(runDirectoryOf(kScene, "unit.yaml", "given"), fs::path("given"));
  EXPECT_EQ(runDirectoryOf(kScene, "unit.yaml", ""), fs::path("runs/unit"));
  EXPECT_EQ(runDirectoryOf("scene: s\noutput: {dir: out/here}\n", "x.yaml", ""), fs::path("out/here"));
  EXPECT_EQ(runDirectoryOf("schedule: {}\n", "dir/my_scene.yaml", ""), fs::path("runs/my_scene"));
}

// Validation messages name DIR/scene.effective.yaml and its line numbers are right.
TEST(SceneOverrides, ValidationMessagesNameTheEffectiveScene) {
  const auto dir = cosim::testing::freshDirectory("overrides");
  try {
    loadSceneWithOverrides(demoScene(), sets({"schedule.dt=-1e-3"}), dir.string());
    FAIL() << "a negative dt must be refused";
  } catch (const cosim::config::ConfigError& e) {
    const auto effective = (dir / "scene.effective.yaml").string();
    const std::string message = e.what();
    ASSERT_EQ(message.rfind(effective + ":", 0), 0u) << message;
    const int line = std::stoi(message.substr(effective.size() + 1));
    EXPECT_NE(message.find("schedule.dt"), std::string::npos) << message;
    EXPECT_NE(lineOf(readText(effective), line).find("dt: -1e-3"), std::string::npos) << "line " << line;
  }
  fs::remove_all(dir);
}

TEST(SceneOverrides, AnOverriddenSceneLoadsFromItsEffectiveFile) {
  const auto dir = cosim::testing::freshDirectory("overrides");
  const auto scene = loadSceneWithOverrides(demoScene(), sets({"schedule.end_time=0.01"}), dir.string());
  EXPECT_EQ(scene.file, (dir / "scene.effective.yaml").string());
  EXPECT_EQ(scene.text, readText(dir / "scene.effective.yaml"));
  EXPECT_EQ(scene.schedule->exchanges(), 10u);
  ASSERT_EQ(scene.solvers.size(), 2u);
  EXPECT_FALSE(scene.solvers[0].binary.empty());
  const auto plain = loadSceneWithOverrides(demoScene(), {}, dir.string());
  EXPECT_EQ(plain.file, demoScene());
  EXPECT_EQ(plain.schedule->exchanges(), 1000u);
  fs::remove_all(dir);
}

// The solvers re-parse the scene text they are sent: a solver parameter set
// on the command line must reach them (the mock fails at the exchange asked for).
TEST(SceneOverrides, RunSendsTheOverriddenSceneToTheSolvers) {
  const auto dir = cosim::testing::freshDirectory("overrides-run");
  const auto run = cosim::testing::run({cosim::testing::binary("coupler"), "run", demoScene(), "--out", dir.string(),
                                        "--no-progress", "--set", "schedule.end_time=0.01", "--set",
                                        "solvers.left.params.fail_at=3"},
                                       30.0);
  EXPECT_EQ(run.code, 4) << run.out << run.err;
  const auto report = readText(dir / "run_report.json");
  EXPECT_NE(report.find("scripted failure at exchange 3"), std::string::npos) << report;
  EXPECT_NE(readText(dir / "scene.effective.yaml").find("fail_at: 3"), std::string::npos);
  fs::remove_all(dir);
}

TEST(SceneOverrides, CheckRefusesABadSetArgumentByName) {
  const auto dir = cosim::testing::freshDirectory("overrides-check");
  const auto bad = cosim::testing::run({cosim::testing::binary("coupler"), "check", demoScene(), "--out", dir.string(),
                                        "--set", "schedule.nokey.dt=1"},
                                       30.0);
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--set 'schedule.nokey.dt=1': schedule has no key 'nokey'"), std::string::npos) << bad.err;
  const auto good = cosim::testing::run({cosim::testing::binary("coupler"), "check", demoScene(), "--out", dir.string(),
                                         "--set", "schedule.dt=2e-3"},
                                        30.0);
  EXPECT_EQ(good.code, 0) << good.err;
  EXPECT_NE(good.out.find("dt = 0.002 s"), std::string::npos) << good.out;
  EXPECT_NE(good.out.find("scene.effective.yaml"), std::string::npos) << good.out;
  fs::remove_all(dir);
}
