// Scene validation: every bad scene in tests/coupler/bad_scenes/ carries, on
// its first line, `# expect: <line>: <text>`; loading it must fail with a
// ConfigError line `<file>:<line>: ...<text>...`. Good scenes (the demo and a
// few variants) must load with the values they state, and `coupler check`
// must exit 2 on a bad scene and 0 on a good one, starting no process.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/launch/slurm.hpp"
#include "cosim/coupler/run/coupler_run.hpp"

namespace fs = std::filesystem;
using cosim::config::ConfigError;
using cosim::coupler::loadScene;
using cosim::coupler::Scene;
using cosim::coupler::SolverSpec;

namespace {

// ctest sets these; the compile-time values serve test discovery and direct runs.
std::string envOr(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : std::string(fallback);
}
fs::path sourceDir() { return envOr("COSIM_SOURCE_DIR", COSIM_TEST_SOURCE_DIR); }
fs::path binDir() { return envOr("COSIM_BIN_DIR", COSIM_TEST_BIN_DIR); }
fs::path badSceneDir() { return sourceDir() / "tests" / "coupler" / "bad_scenes"; }
fs::path demoScene() { return sourceDir() / "configs" / "demo" / "two_mocks.yaml"; }

std::vector<std::string> badSceneFiles() {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(badSceneDir(), ec))
    if (e.is_regular_file() && e.path().extension() == ".yaml") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

struct Expectation {
  int line = 0;
  std::string text;
};

/// Parses `# expect: <line>: <text>` from the first line; line 0 when malformed.
Expectation readExpectation(const std::string& file) {
  std::ifstream in(file);
  std::string first;
  std::getline(in, first);
  const std::string tag = "# expect: ";
  Expectation e;
  if (first.rfind(tag, 0) != 0) return e;
  const auto colon = first.find(": ", tag.size());
  if (colon == std::string::npos) return e;
  try {
    e.line = std::stoi(first.substr(tag.size(), colon - tag.size()));
  } catch (const std::exception&) {
    return e;
  }
  e.text = first.substr(colon + 2);
  while (!e.text.empty() && std::isspace(static_cast<unsigned char>(e.text.back()))) e.text.pop_back();
  return e;
}

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The ConfigError lines of loading path; fails the test when it loads.
std::vector<std::string> loadErrors(const std::string& path) {
  try {
    loadScene(path);
  } catch (const ConfigError& e) {
    return e.lines();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": threw something other than ConfigError: " << e.what();
    return {};
  }
  ADD_FAILURE() << path << ": loaded, but it should have been refused";
  return {};
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const auto& l : lines) out += "\n  " + l;
  return out;
}

/// True when one error line starts with `file:line: ` and contains text.
bool reported(const std::vector<std::string>& lines, const std::string& file, int line, const std::string& text) {
  const std::string where = file + ":" + std::to_string(line) + ": ";
  return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) {
    return l.rfind(where, 0) == 0 && l.find(text, where.size()) != std::string::npos;
  });
}

/// A private scratch directory, removed with everything in it.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "cosim_cfg_test_XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path_ / name) << text;
    return (path_ / name).string();
  }

 private:
  fs::path path_;
};

// ---------------------------------------------------------------------------
// Every bad scene is refused at the line and with the message it announces.

class BadScene : public ::testing::TestWithParam<std::string> {};

TEST_P(BadScene, IsRefusedAtTheAnnouncedLine) {
  const std::string file = GetParam();
  const Expectation expected = readExpectation(file);
  ASSERT_GT(expected.line, 0) << file << ": first line must be '# expect: <line>: <message part>'";
  ASSERT_FALSE(expected.text.empty()) << file << ": the expected message part is empty";
  const auto lines = loadErrors(file);
  ASSERT_FALSE(lines.empty());
  EXPECT_TRUE(reported(lines, file, expected.line, expected.text))
      << "expected a line '" << file << ":" << expected.line << ": ..." << expected.text << "...'; got:"
      << joined(lines);
  // Every line names the file and a line number.
  for (const auto& l : lines) EXPECT_EQ(l.rfind(file + ":", 0), 0u) << l;
}

std::string sceneTestName(const ::testing::TestParamInfo<std::string>& info) {
  std::string name = fs::path(info.param).stem().string();
  for (auto& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Scenes, BadScene, ::testing::ValuesIn(badSceneFiles()), sceneTestName);

TEST(BadSceneCollection, HasAtLeast24Scenes) {
  const auto files = badSceneFiles();
  EXPECT_GE(files.size(), 24u) << "in " << badSceneDir();
  for (const auto& f : files) EXPECT_GT(readExpectation(f).line, 0) << f << " has no '# expect:' first line";
}

// A stated line must exist in the file (or be line 1 of an empty document),
// so a typo in an expectation cannot pass by pointing past the end.
TEST(BadSceneCollection, ExpectedLinesExistInTheirFiles) {
  for (const auto& f : badSceneFiles()) {
    const auto text = readText(f);
    const auto lineCount = static_cast<int>(std::count(text.begin(), text.end(), '\n'));
    EXPECT_LE(readExpectation(f).line, lineCount) << f;
  }
}

// ---------------------------------------------------------------------------
// Good scenes load with the values they state.

TEST(GoodScene, DemoLoads) {
  const Scene scene = loadScene(demoScene().string());
  EXPECT_EQ(scene.name, "two-mocks");
  EXPECT_FALSE(scene.description.empty());
  ASSERT_EQ(scene.solvers.size(), 2u);
  for (const auto& s : scene.solvers) {
    EXPECT_EQ(s.kind, "mock");
    EXPECT_EQ(s.launch, SolverSpec::Launch::spawn);
    EXPECT_EQ(fs::path(s.binary).filename(), "mock_solver") << s.binary;
    EXPECT_EQ(::access(s.binary.c_str(), X_OK), 0) << s.binary;
  }
  EXPECT_EQ(scene.solvers[0].name, "left");
  // SolverSpec::line is the line of the entry's first key.
  const auto text = readText(demoScene());
  const auto entry = text.find("- name: left");
  ASSERT_NE(entry, std::string::npos);
  EXPECT_EQ(scene.solvers[0].line, 1 + std::count(text.begin(), text.begin() + static_cast<long>(entry), '\n'));
  EXPECT_EQ(scene.solvers[1].name, "right");
  ASSERT_EQ(scene.couplings.size(), 2u);
  EXPECT_EQ(scene.couplings[0]->name(), "left-to-right");
  EXPECT_EQ(scene.couplings[0]->kind(), "direct-transfer");
  EXPECT_EQ(scene.couplings[0]->participants(), (std::vector<std::string>{"left", "right"}));
  ASSERT_TRUE(scene.schedule);
  EXPECT_EQ(scene.schedule->kind(), "lockstep");
  EXPECT_EQ(scene.schedule->exchanges(), 1000u);  // end_time 1.0 / dt 1e-3
  EXPECT_EQ(scene.transport.kind, cosim::wire::TransportOptions::Kind::ipc);
  EXPECT_DOUBLE_EQ(scene.link.heartbeatIntervalS, 0.5);
  EXPECT_DOUBLE_EQ(scene.link.heartbeatTimeoutS, 10.0);
  EXPECT_EQ(scene.output.dir, "runs/two-mocks");
  ASSERT_EQ(scene.output.record.size(), 6u);
  EXPECT_EQ(scene.output.record[1].solver, "left");
  EXPECT_EQ(scene.output.record[1].array, "mismatches");
  EXPECT_EQ(scene.output.record[2].array, "history");
  const auto caps = scene.requiredCapabilities("left");
  EXPECT_NE(std::find(caps.begin(), caps.end(), "arrays"), caps.end());
  EXPECT_NE(std::find(caps.begin(), caps.end(), "advance"), caps.end());
}

TEST(GoodScene, TcpTransportWithAllTimeouts) {
  TempDir dir;
  const auto path = dir.write("tcp.yaml",
                              "scene: tcp-run\n"
                              "transport:\n"
                              "  kind: tcp\n"
                              "  interface: 0.0.0.0\n"
                              "  port: 5555\n"
                              "  heartbeat_interval: 0.2\n"
                              "  heartbeat_timeout: 1.0\n"
                              "  request_timeout: 60\n"
                              "  connect_timeout: 5\n"
                              "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                              "solvers:\n"
                              "  - {name: left, kind: mock, args: [--verbose], requires: [checkpoint]}\n"
                              "  - {name: right, kind: mock, launch: attach}\n");
  const Scene scene = loadScene(path);
  EXPECT_EQ(scene.transport.kind, cosim::wire::TransportOptions::Kind::tcp);
  EXPECT_EQ(scene.transport.interface, "0.0.0.0");
  EXPECT_EQ(scene.transport.port, 5555);
  EXPECT_DOUBLE_EQ(scene.link.heartbeatIntervalS, 0.2);
  EXPECT_DOUBLE_EQ(scene.link.heartbeatTimeoutS, 1.0);
  EXPECT_DOUBLE_EQ(scene.link.requestTimeoutS, 60.0);
  EXPECT_DOUBLE_EQ(scene.connectTimeoutS, 5.0);
  ASSERT_EQ(scene.solvers.size(), 2u);
  EXPECT_EQ(scene.solvers[0].args, std::vector<std::string>{"--verbose"});
  const auto caps = scene.requiredCapabilities("left");
  EXPECT_NE(std::find(caps.begin(), caps.end(), "checkpoint"), caps.end());
  EXPECT_EQ(scene.solvers[1].launch, SolverSpec::Launch::attach);
  EXPECT_TRUE(scene.couplings.empty());
  EXPECT_EQ(scene.output.dir, "runs/tcp-run");
  EXPECT_EQ(scene.schedule->exchanges(), 10u);
}

/// Two mocks, `right` a Slurm job step (with `resources` and `transport` as given).
std::string srunScene(TempDir& dir, const std::string& resources, const std::string& transport = "") {
  return dir.write("srun.yaml", "scene: srun-run\n" + transport +
                                    "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                                    "solvers:\n"
                                    "  - {name: left, kind: mock}\n"
                                    "  - {name: right, kind: mock, launch: srun" + resources + "}\n");
}

/// A GMH pool of five srun workers, two per node (three nodes), fed by a mock FEM block.
std::string srunPoolScene(TempDir& dir) {
  return dir.write("pool.yaml",
                   "scene: pool\n"
                   "schedule: {kind: multirate, fine: [cells], dt: 1.0e-3, ratio: 1, coarse_steps: 2}\n"
                   "solvers:\n"
                   "  - {name: block, kind: mock}\n"
                   "  - name: cells\n"
                   "    kind: dem\n"
                   "    binary: /bin/true\n"
                   "    launch: srun\n"
                   "    pool: {workers: 5, workers_per_node: 2}\n"
                   "couplings:\n"
                   "  - {name: cells, kind: gmh, fem: block, workers: [cells]}\n");
}

TEST(GoodScene, SrunSolversDefaultToTcpWithCurveAndKeepAnExplicitTransport) {
  TempDir dir;
  const Scene cluster = loadScene(srunScene(dir, ", resources: {cpus_per_task: 4, memory: 8G, overlap: true}"));
  EXPECT_TRUE(cluster.usesSlurm());
  EXPECT_EQ(cluster.transport.kind, cosim::wire::TransportOptions::Kind::tcp);
  EXPECT_EQ(cluster.transport.interface, "0.0.0.0");
  EXPECT_TRUE(cluster.transport.curve);
  const auto& r = cluster.solvers[1].resources;
  EXPECT_EQ(r.cpusPerTask, 4);
  EXPECT_EQ(r.memory, "8G");
  EXPECT_TRUE(r.overlap);
  EXPECT_FALSE(cluster.solvers[1].binary.empty());  // resolved like a spawned solver's
  const Scene ipc = loadScene(srunScene(dir, "", "transport: {kind: ipc}\n"));
  EXPECT_EQ(ipc.transport.kind, cosim::wire::TransportOptions::Kind::ipc);
  const Scene plain = loadScene(srunScene(dir, "", "transport: {kind: tcp, interface: 10.0.0.1}\n"));
  EXPECT_EQ(plain.transport.interface, "10.0.0.1");
  EXPECT_FALSE(plain.transport.curve);  // the scene chose its transport
}

TEST(SlurmLaunch, AStepIsOneTaskWithItsCoresThreadsAndMemory) {
  TempDir dir;
  const Scene scene = loadScene(srunScene(dir, ", resources: {cpus_per_task: 4, memory: 8G}"));
  const auto args = cosim::coupler::srunArguments(scene.solvers[1], {"--endpoint", "tcp://h:1", "--name", "right"});
  const std::vector<std::string> expected{"--job-name=right", "--nodes=1", "--ntasks=1", "--cpus-per-task=4",
                                          "--export=ALL,OMP_NUM_THREADS=4", "--exact", "--quiet", "--mem=8G", "--",
                                          scene.solvers[1].binary, "--endpoint", "tcp://h:1", "--name", "right"};
  EXPECT_EQ(args, expected);
}

TEST(SlurmLaunch, ThePlanGroupsTheStepsIntoComponentsAndTheBatchScriptAsksForThem) {
  TempDir dir;
  const auto path = dir.write("pool.yaml",
                              "scene: pool\n"
                              "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                              "solvers:\n"
                              "  - {name: block, kind: mock}\n"
                              "  - {name: w0, kind: mock, launch: srun, resources: {cpus_per_task: 2, memory: 4G}}\n"
                              "  - {name: w1, kind: mock, launch: srun, resources: {cpus_per_task: 2, memory: 3G}}\n"
                              "  - {name: w2, kind: mock, launch: srun, resources: {cpus_per_task: 1, memory: 512M}}\n");
  const Scene scene = loadScene(path);
  const auto plan = cosim::coupler::planResources(scene);
  EXPECT_EQ(plan.localProcesses, 2);  // the coupler and block
  EXPECT_EQ(plan.steps, 3);
  ASSERT_EQ(plan.components.size(), 4u);  // the coupler's; w0; w1; w2 (each asks for other cores or memory)
  EXPECT_EQ(plan.components[0].cpusPerTask, 2);
  EXPECT_EQ(plan.components[1].solvers, std::vector<std::string>{"w0"});
  EXPECT_EQ(plan.components[1].memoryPerCpuMb(), 2048);  // 4 GB over 2 cores
  EXPECT_EQ(plan.components[3].memoryPerCpuMb(), 512);
  EXPECT_EQ(plan.cores(), 2 + 2 + 2 + 1);
  EXPECT_EQ(plan.componentOf("w2"), 3);
  EXPECT_EQ(plan.componentOf("block"), -1);
  std::ostringstream described;
  cosim::coupler::describeResources(scene, described);
  EXPECT_NE(described.str().find("job: 4 component(s), 7 cores"), std::string::npos) << described.str();
  EXPECT_NE(described.str().find("component 1: 1 task(s) x 2 core(s), 4G each: w0"), std::string::npos) << described.str();
  const auto alike = cosim::coupler::sbatchScript(scene, "/opt/cosim/coupler", {"runs/pool", "debug", "02:00:00", false});
  EXPECT_NE(alike.find("#SBATCH --ntasks=4 --cpus-per-task=2 --mem-per-cpu=2048M --partition=debug --time=02:00:00\n"),
            std::string::npos) << alike;
  EXPECT_NE(alike.find("# (1 of its 8 cores go unused"), std::string::npos) << alike;
  EXPECT_EQ(alike.find("hetjob"), std::string::npos) << alike;
  const auto script = cosim::coupler::sbatchScript(scene, "/opt/cosim/coupler", {"runs/pool", "debug", "02:00:00", true});
  for (const char* line : {"#!/bin/bash\n", "#SBATCH --job-name=pool\n",
                           "#SBATCH --ntasks=1 --cpus-per-task=2 --partition=debug --time=02:00:00\n#SBATCH hetjob\n",
                           "#SBATCH --ntasks=1 --cpus-per-task=2 --mem-per-cpu=2048M --partition=debug --time=02:00:00\n",
                           "#SBATCH --ntasks=1 --cpus-per-task=1 --mem-per-cpu=512M", "exec '/opt/cosim/coupler' run '"})
    EXPECT_NE(script.find(line), std::string::npos) << line << "\n" << script;
  EXPECT_EQ(cosim::coupler::srunArguments(scene.solvers[3], {}, 3)[1], "--het-group=3");
  EXPECT_NE(script.find("--out '" + fs::absolute("runs/pool").string() + "' --no-progress"), std::string::npos) << script;
}

TEST(SlurmLaunch, APoolEntryStandsForItsWorkersEachPlacedOnItsNode) {
  TempDir dir;
  const Scene scene = loadScene(srunPoolScene(dir));
  ASSERT_EQ(scene.solvers.size(), 6u);
  for (int k = 0; k < 5; ++k) {
    const auto& w = scene.solvers[static_cast<std::size_t>(k) + 1];
    EXPECT_EQ(w.name, "cells-" + std::to_string(k));
    EXPECT_EQ(w.poolEntry, "cells");
    EXPECT_EQ(w.poolIndex, k);
    EXPECT_EQ(w.poolSize, 5);
  }
  const auto parts = scene.couplings.at(0)->participants();
  EXPECT_EQ(std::count_if(parts.begin(), parts.end(), [](const std::string& p) { return p.rfind("cells-", 0) == 0; }), 5);
  const auto caps = scene.requiredCapabilities("cells-3");
  EXPECT_NE(std::find(caps.begin(), caps.end(), "pool-member"), caps.end());
  // Worker k on node k / 2 of its component: cells-3 on the second.
  const auto args = cosim::coupler::srunArguments(scene.solvers[4], {});
  EXPECT_NE(std::find(args.begin(), args.end(), "--relative=1"), args.end());
  const auto plan = cosim::coupler::planResources(scene);
  ASSERT_EQ(plan.components.size(), 2u);
  EXPECT_EQ(plan.components[1].tasks, 5);
  EXPECT_EQ(plan.components[1].nodes, 3);
  std::ostringstream described;
  cosim::coupler::describeResources(scene, described);
  EXPECT_NE(described.str().find("pool cells: 5 workers (cells-0 .. cells-4), 2 per node on 3 node(s)"), std::string::npos)
      << described.str();
  const auto alike = cosim::coupler::sbatchScript(scene, "/opt/cosim/coupler", {"runs/pool", "", "", false});
  EXPECT_NE(alike.find("#SBATCH --nodes=3 --ntasks-per-node=2 --ntasks=6 --cpus-per-task=2\n"), std::string::npos) << alike;
  const auto het = cosim::coupler::sbatchScript(scene, "/opt/cosim/coupler", {"runs/pool", "", "", true});
  EXPECT_NE(het.find("#SBATCH hetjob\n#SBATCH --nodes=3 --ntasks-per-node=2 --ntasks=5 --cpus-per-task=1\n"),
            std::string::npos) << het;
}

TEST(GoodScene, AutoTimeStepResolvesFromTheCriticalStep) {
  TempDir dir;
  const auto path = dir.write("auto.yaml",
                              "scene: auto-dt\n"
                              "schedule:\n"
                              "  kind: lockstep\n"
                              "  dt: auto\n"
                              "  safety: 0.4\n"
                              "  end_time: 0.1\n"
                              "solvers:\n"
                              "  - {name: left, kind: mock}\n"
                              "  - {name: right, kind: mock}\n");
  const Scene scene = loadScene(path);
  EXPECT_NE(scene.schedule->describe().find("auto"), std::string::npos) << scene.schedule->describe();
  // 0.4 * min(1e-3, 5e-3) = 4e-4 s; 0.1 s / 4e-4 s = 250 exchanges. 0 = no limit.
  scene.schedule->resolveTimeStep({{"left", 1e-3}, {"right", 5e-3}, {"other", 0.0}}, false);
  EXPECT_EQ(scene.schedule->exchanges(), 250u);
  EXPECT_NEAR(scene.schedule->endTime(), 0.1, 1e-12);
}

TEST(GoodScene, FixedExchangeCountInsteadOfEndTime) {
  TempDir dir;
  const auto path = dir.write("exchanges.yaml",
                              "scene: counted\n"
                              "schedule:\n"
                              "  kind: lockstep\n"
                              "  dt: 1.0e-3\n"
                              "  steps_per_exchange: 4\n"
                              "  exchanges: 25\n"
                              "solvers:\n"
                              "  - {name: left, kind: mock}\n"
                              "  - {name: right, kind: mock}\n"
                              "couplings:\n"
                              "  - {kind: direct-transfer, from: left, to: right, arrays: [state]}\n"
                              "output: {dir: out/counted, flush_interval: 5, record: [right.state]}\n");
  const Scene scene = loadScene(path);
  EXPECT_EQ(scene.schedule->exchanges(), 25u);
  EXPECT_NEAR(scene.schedule->endTime(), 0.1, 1e-12);  // 25 * 4 * 1e-3
  ASSERT_EQ(scene.couplings.size(), 1u);
  EXPECT_EQ(scene.couplings[0]->name(), "coupling0");  // default name
  EXPECT_EQ(scene.output.dir, "out/counted");
  EXPECT_EQ(scene.output.flushInterval, 5);
}

// A run ends on an exchange: an end_time between two is rounded up, and the
// schedule's description says where the run ends, as the report does.
TEST(GoodScene, AnEndTimeBetweenExchangesIsRoundedUpAndSaysSo) {
  TempDir dir;
  for (const char* kind : {"kind: lockstep, dt: 1.0e-3, steps_per_exchange: 4",
                           "kind: multirate, fine: left, dt: 1.0e-3, ratio: 4"}) {
    const auto path = dir.write("round.yaml", std::string("scene: round\nschedule: {") + kind +
                                                  ", end_time: 0.01}\n"
                                                  "solvers:\n  - {name: left, kind: mock}\n  - {name: right, kind: mock}\n");
    const Scene scene = loadScene(path);
    EXPECT_EQ(scene.schedule->exchanges(), 3u) << kind;
    EXPECT_NEAR(scene.schedule->endTime(), 0.012, 1e-12) << kind;
    EXPECT_NE(scene.schedule->describe().find(
                  "until t = 0.012 s: end_time 0.01 s rounded up to whole exchanges of 0.004 s"),
              std::string::npos)
        << scene.schedule->describe();
  }
  const auto exact = dir.write("exact.yaml", "scene: exact\nschedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                                             "solvers:\n  - {name: left, kind: mock}\n");
  const std::string text = loadScene(exact).schedule->describe();
  EXPECT_NE(text.find("until t = 0.01 s"), std::string::npos) << text;
  EXPECT_EQ(text.find("rounded"), std::string::npos) << text;
}

TEST(GoodScene, BinaryPathIsResolvedNextToTheScene) {
  TempDir dir;
  dir.write("my_solver", "#!/bin/sh\nexit 0\n");
  fs::permissions(dir.path() / "my_solver", fs::perms::owner_all);
  const auto path = dir.write("custom.yaml",
                              "scene: custom\n"
                              "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                              "solvers:\n"
                              "  - {name: grains, kind: lammps, binary: ./my_solver}\n");
  const Scene scene = loadScene(path);
  ASSERT_EQ(scene.solvers.size(), 1u);
  EXPECT_EQ(fs::path(scene.solvers[0].binary), (dir.path() / "my_solver").lexically_normal());
}

// ---------------------------------------------------------------------------
// All mistakes in one file are reported together, each at its own line.

// Every shipped scene validates (scenes of solvers this build leaves out are skipped).
TEST(ShippedScenes, EveryConfigValidates) {
  int checked = 0;
  for (const auto& entry : fs::recursive_directory_iterator(sourceDir() / "configs")) {
    if (entry.path().extension() != ".yaml") continue;
    const auto text = [&] {
      std::ifstream in(entry.path());
      std::stringstream s;
      s << in.rdbuf();
      return s.str();
    }();
    bool built = true;
    for (const char* kind : {"dem", "fem", "pd"})
      if (text.find(std::string("kind: ") + kind + "\n") != std::string::npos &&
          !fs::exists(binDir() / (std::string(kind) + "_solver")))
        built = false;
    if (!built) continue;
    EXPECT_NO_THROW(cosim::coupler::loadScene(entry.path().string())) << entry.path();
    ++checked;
  }
  EXPECT_GE(checked, 1);
}

TEST(SceneErrors, SeveralMistakesAreAllReported) {
  TempDir dir;
  const auto path = dir.write("many.yaml",
                              "scene: many-mistakes\n"       // 1
                              "transport:\n"                 // 2
                              "  kind: ipc\n"                // 3
                              "  port: 5555\n"               // 4  port with ipc
                              "schedule:\n"                  // 5
                              "  kind: lockstep\n"           // 6
                              "  dt: -1\n"                   // 7  negative
                              "  end_time: 0.01\n"           // 8
                              "solvers:\n"                   // 9
                              "  - name: left\n"             // 10
                              "    kind: mock\n"             // 11
                              "    parms: {}\n"              // 12 unknown key
                              "  - name: right\n"            // 13
                              "    kind: mock\n"             // 14
                              "couplings:\n"                 // 15
                              "  - kind: direct-transfer\n"  // 16
                              "    from: left\n"             // 17
                              "    to: left\n"               // 18 same solver
                              "    arrays: [state]\n"        // 19
                              "output:\n"                    // 20
                              "  record: [nobody.x]\n"       // 21 undeclared
                              "colour: blue\n");             // 22 unknown top-level key
  const auto lines = loadErrors(path);
  EXPECT_EQ(lines.size(), 6u) << joined(lines);
  EXPECT_TRUE(reported(lines, path, 4, "transport.port: only a tcp transport has a port")) << joined(lines);
  EXPECT_TRUE(reported(lines, path, 7, "schedule.dt: must be > 0 (got -1)")) << joined(lines);
  EXPECT_TRUE(reported(lines, path, 12, "solvers[0].parms: unknown key (did you mean 'params'?)")) << joined(lines);
  EXPECT_TRUE(reported(lines, path, 18, "couplings[0].to: a transfer needs two different solvers")) << joined(lines);
  EXPECT_TRUE(reported(lines, path, 21, "output.record: 'nobody.x' names no declared solver 'nobody'"))
      << joined(lines);
  EXPECT_TRUE(reported(lines, path, 22, "colour: unknown key")) << joined(lines);
}

TEST(SceneErrors, WhatJoinsAllLines) {
  TempDir dir;
  const auto path = dir.write("two.yaml",
                              "scene: two-mistakes\n"
                              "schedule: {kind: lockstep, dt: 0, exchanges: 0}\n"
                              "solvers: [{name: left, kind: mock}]\n");
  try {
    loadScene(path);
    FAIL() << "loaded";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.lines().size(), 2u) << e.what();
    EXPECT_EQ(std::string(e.what()), e.lines()[0] + "\n" + e.lines()[1]);
  }
}

TEST(SceneErrors, MissingFileIsAConfigError) {
  const std::string path = "/nonexistent/dir/scene.yaml";
  try {
    loadScene(path);
    FAIL() << "loaded";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": cannot open the scene file"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------
// `coupler check`: the real binary, its exit code and its output.

struct ProcessResult {
  int exitCode = -1;
  std::string out;
  std::string err;
};

/// Runs argv in cwd with stdout and stderr captured to files; waits for it.
ProcessResult runProcess(const std::vector<std::string>& argv, const fs::path& cwd) {
  TempDir capture;
  const auto outPath = (capture.path() / "stdout").string();
  const auto errPath = (capture.path() / "stderr").string();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    const int out = ::open(outPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    const int err = ::open(errPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    if (out < 0 || err < 0 || ::dup2(out, 1) < 0 || ::dup2(err, 2) < 0 || ::chdir(cwd.c_str()) != 0) ::_exit(126);
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  ProcessResult r;
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.out = readText(outPath);
  r.err = readText(errPath);
  return r;
}

std::string couplerBinary() { return (binDir() / "coupler").string(); }

class CouplerCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::access(couplerBinary().c_str(), X_OK) != 0) GTEST_FAIL() << "no coupler binary at " << couplerBinary();
  }
  TempDir cwd_;
};

TEST_F(CouplerCheck, BadSceneExitsTwoWithTheMessageOnStderr) {
  for (const char* name : {"17_negative_dt.yaml", "01_yaml_syntax_error.yaml", "32_dangling_coupling_solver.yaml"}) {
    const auto scene = (badSceneDir() / name).string();
    const auto expected = readExpectation(scene);
    const auto r = runProcess({couplerBinary(), "check", scene}, cwd_.path());
    EXPECT_EQ(r.exitCode, cosim::coupler::kExitBadConfig) << name << "\nstderr: " << r.err;
    const std::string where = scene + ":" + std::to_string(expected.line) + ": ";
    EXPECT_NE(r.err.find(where), std::string::npos) << name << "\nstderr: " << r.err;
    EXPECT_NE(r.err.find(expected.text), std::string::npos) << name << "\nstderr: " << r.err;
    EXPECT_EQ(r.out, "") << name;
  }
  EXPECT_TRUE(fs::is_empty(cwd_.path())) << "check wrote into its working directory";
}

TEST_F(CouplerCheck, DemoSceneExitsZeroAndListsTheProcesses) {
  const auto r = runProcess({couplerBinary(), "check", demoScene().string()}, cwd_.path());
  EXPECT_EQ(r.exitCode, cosim::coupler::kExitOk) << "stderr: " << r.err;
  EXPECT_NE(r.out.find("scene 'two-mocks'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("schedule: lockstep"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mock_solver --endpoint <endpoint> --name left"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mock_solver --endpoint <endpoint> --name right"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("left-to-right [direct-transfer] left -> right"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("right-to-left [direct-transfer] right -> left"), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("error"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_empty(cwd_.path())) << "check created output (e.g. runs/two-mocks)";
}

/// A scene of two mock solvers (their entries' keys after the name) coupled
/// by one direct transfer of `array`, written as `file` into `dir`.
std::string twoMockScene(const TempDir& dir, const std::string& file, const std::string& left, const std::string& right,
                         const std::string& array = "state") {
  return dir.write(file, "scene: " + fs::path(file).stem().string() + "\n"
                         "schedule: {kind: lockstep, dt: 1.0e-3, end_time: 0.01}\n"
                         "solvers:\n"
                         "  - {name: left, kind: mock" + left + "}\n"
                         "  - {name: right, kind: mock" + right + "}\n"
                         "couplings:\n"
                         "  - {name: l2r, kind: direct-transfer, from: left, to: right, arrays: [" + array + "]}\n");
}

/// An executable shell script in `dir`.
void writeScript(const TempDir& dir, const std::string& name, const std::string& text) {
  dir.write(name, "#!/bin/sh\n" + text);
  fs::permissions(dir.path() / name, fs::perms::owner_all);
}

TEST_F(CouplerCheck, RunsTheSolversOnlyInTheirCheckMode) {
  // A solver binary that notes how it was run: check runs it with --check (and
  // the scene's args), never as a peer of a run.
  TempDir sceneDir;
  writeScript(sceneDir, "spy_solver", "echo \"$*\" >> \"$(dirname \"$0\")/started\"\n");
  const auto scene =
      twoMockScene(sceneDir, "spy.yaml", ", binary: ./spy_solver, args: [--flag]", ", binary: ./spy_solver", "x");
  const auto r = runProcess({couplerBinary(), "check", scene}, cwd_.path());
  EXPECT_EQ(r.exitCode, cosim::coupler::kExitOk) << "stderr: " << r.err;
  const auto spy = (sceneDir.path() / "spy_solver").lexically_normal().string();
  EXPECT_NE(r.out.find("start " + spy + " --endpoint <endpoint> --name left --flag"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("start " + spy + " --endpoint <endpoint> --name right"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("solver params: every solver the run starts accepts its section"), std::string::npos) << r.out;
  std::ifstream started(sceneDir.path() / "started");
  std::vector<std::string> runs;
  for (std::string line; std::getline(started, line);) runs.push_back(line);
  ASSERT_EQ(runs.size(), 2u);
  for (const auto& line : runs) {
    EXPECT_EQ(line.rfind("--check ", 0), 0u) << line;
    EXPECT_EQ(line.find("--endpoint"), std::string::npos) << line;
  }
  EXPECT_TRUE(runs[0].ends_with(" --flag") || runs[1].ends_with(" --flag"));
  EXPECT_TRUE(fs::is_empty(cwd_.path()));
}

TEST_F(CouplerCheck, ASolverThatRefusesItsParamsIsNamedWithItsMessage) {
  TempDir sceneDir;
  const auto scene = twoMockScene(sceneDir, "mocks.yaml", ", params: {seed: 1}", ", params: {seed: 2, length: -5}");
  const auto r = runProcess({couplerBinary(), "check", scene}, cwd_.path());
  EXPECT_EQ(r.exitCode, cosim::coupler::kExitBadConfig) << r.out << r.err;
  EXPECT_NE(r.err.find("solver 'right' refuses its params (exit 2)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("mocks.yaml:5: solvers.right.params.length"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("solver 'left'"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("solver params: 1 solver(s) refuse theirs"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::is_empty(cwd_.path()));
}

// A check that ends without a verdict (killed, crashed) is the binary's
// failure, not a refusal of the scene: named so, and refused as a run that
// cannot start (exit 3), not as a bad scene (exit 2).
TEST_F(CouplerCheck, ASolverKilledWhileCheckingIsAFailureNotARefusal) {
  TempDir sceneDir;
  writeScript(sceneDir, "dies", "kill -9 $$\n");
  const auto scene = twoMockScene(sceneDir, "dies.yaml", ", params: {seed: 1}", ", binary: ./dies");
  const auto checked = runProcess({couplerBinary(), "check", scene}, cwd_.path());
  EXPECT_EQ(checked.exitCode, cosim::coupler::kExitRefused) << checked.out << checked.err;
  EXPECT_NE(checked.err.find("solver 'right' was killed by signal 9 while checking its params"), std::string::npos)
      << checked.err;
  EXPECT_EQ(checked.err.find("refuses"), std::string::npos) << checked.err;
  EXPECT_NE(checked.out.find("solver params: 1 solver(s) failed to check theirs"), std::string::npos) << checked.out;
  const auto run = runProcess({couplerBinary(), "run", scene, "--no-progress"}, cwd_.path());
  EXPECT_EQ(run.exitCode, cosim::coupler::kExitRefused) << run.err;
  EXPECT_NE(run.err.find("run refused before any solver started"), std::string::npos) << run.err;
}

TEST_F(CouplerCheck, SrunOutsideAnAllocationIsRefusedAndSbatchWritesTheScript) {
  ::unsetenv("SLURM_JOB_ID");  // this test's coupler runs in no allocation, wherever the tests run
  TempDir sceneDir;
  const auto scene = srunScene(sceneDir, ", resources: {cpus_per_task: 2}");
  const auto refused = runProcess({couplerBinary(), "run", scene, "--out", "run", "--no-progress"}, cwd_.path());
  EXPECT_EQ(refused.exitCode, cosim::coupler::kExitRefused) << refused.err;
  EXPECT_NE(refused.err.find("solvers with launch: srun start as job steps of a Slurm allocation, and this coupler "
                             "runs in none (SLURM_JOB_ID is not set)"),
            std::string::npos)
      << refused.err;
  const auto check = runProcess({couplerBinary(), "check", scene}, cwd_.path());
  EXPECT_EQ(check.exitCode, cosim::coupler::kExitOk) << check.err;
  EXPECT_NE(check.out.find("job step: srun --job-name=right --nodes=1 --ntasks=1 --cpus-per-task=2"), std::string::npos)
      << check.out;
  EXPECT_NE(check.out.find("slurm: 1 solver(s) as job steps"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("component 1: 1 task(s) x 2 core(s): right"), std::string::npos) << check.out;
  const auto batch = runProcess({couplerBinary(), "sbatch", scene, "--out", "batch", "--time", "00:10:00"}, cwd_.path());
  EXPECT_EQ(batch.exitCode, cosim::coupler::kExitOk) << batch.err;
  const auto file = cwd_.path() / "batch" / "srun-run.sbatch";
  EXPECT_NE(batch.out.find("submit it with: sbatch " + file.string()), std::string::npos) << batch.out;
  const auto text = readText(file);
  EXPECT_NE(text.find(" --time=00:10:00\n"), std::string::npos) << text;
  EXPECT_NE(text.find(" run '" + scene + "' --out '" + (cwd_.path() / "batch").string() + "'"), std::string::npos) << text;
}

TEST_F(CouplerCheck, APoolNeedingMoreNodesThanTheAllocationIsRefusedBeforeAnyStep) {
  TempDir sceneDir;
  const auto scene = srunPoolScene(sceneDir);
  // A one-node allocation as Slurm describes it to the processes in it.
  ::setenv("SLURM_JOB_ID", "77", 1);
  ::setenv("SLURM_JOB_NUM_NODES", "1", 1);
  const auto refused = runProcess({couplerBinary(), "run", scene, "--out", "run", "--no-progress"}, cwd_.path());
  ::unsetenv("SLURM_JOB_ID");
  ::unsetenv("SLURM_JOB_NUM_NODES");
  EXPECT_EQ(refused.exitCode, cosim::coupler::kExitRefused) << refused.err;
  EXPECT_NE(refused.err.find("pool 'cells' places 2 workers per node on 3 nodes, and Slurm job 77 has 1"),
            std::string::npos)
      << refused.err;
}

TEST_F(CouplerCheck, UsageErrorsExitTwo) {
  const auto noScene = runProcess({couplerBinary(), "check"}, cwd_.path());
  EXPECT_EQ(noScene.exitCode, cosim::coupler::kExitBadConfig);
  EXPECT_NE(noScene.err.find("no scene file given"), std::string::npos) << noScene.err;
  const auto badCommand = runProcess({couplerBinary(), "frobnicate", demoScene().string()}, cwd_.path());
  EXPECT_EQ(badCommand.exitCode, cosim::coupler::kExitBadConfig);
  EXPECT_NE(badCommand.err.find("unknown command 'frobnicate'"), std::string::npos) << badCommand.err;
  const auto missing = runProcess({couplerBinary(), "check", "no_such_scene.yaml"}, cwd_.path());
  EXPECT_EQ(missing.exitCode, cosim::coupler::kExitBadConfig);
  EXPECT_NE(missing.err.find("no_such_scene.yaml: cannot open the scene file"), std::string::npos) << missing.err;
}

}  // namespace
