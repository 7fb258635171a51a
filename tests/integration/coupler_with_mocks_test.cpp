// Integration: `coupler run` with scripted mock solvers. Each test writes a
// scene, runs the real coupler (which starts real mock processes), and checks
// exit code, messages, coupler.h5, the run report, and that no process is
// left behind.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "cosim/io/h5_file.hpp"
#include "cosim/util/cpu_affinity.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/sockets.hpp"
#include "mock_pattern.hpp"
#include "subprocess.hpp"

namespace cosim::testing {
namespace {
namespace fs = std::filesystem;

struct SceneOptions {
  std::string left = "{seed: 1, length: 64, expect_seed: 2}";
  std::string right = "{seed: 2, length: 64, expect_seed: 1}";
  std::string leftExtra;   // more keys of the left solver entry, e.g. "args: [...]"
  std::string rightExtra;
  std::string schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 100}";
  std::string transport = "{heartbeat_interval: 0.1, heartbeat_timeout: 1.0, request_timeout: 30}";
  std::string outputExtra;  // more keys under output:, e.g. "checkpoint_interval: 50"
  std::string placement;    // the placement: map, when set
  std::string record = "[left.digest, left.mismatches, right.digest, right.mismatches]";
};

class CouplerRun : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = freshDirectory("cosim-it"); }
  void TearDown() override {
    EXPECT_TRUE(processesMentioning(dir_.string()).empty()) << "processes left behind for " << dir_;
    if (!HasFailure()) fs::remove_all(dir_);
  }

  std::string writeScene(const SceneOptions& o) {
    const auto path = dir_ / "scene.yaml";
    std::ofstream f(path);
    f << "scene: it\n"
      << "schedule: " << o.schedule << "\n"
      << "transport: " << o.transport << "\n"
      << (o.placement.empty() ? "" : "placement: " + o.placement + "\n")
      << "solvers:\n"
      << "  - name: left\n    kind: mock\n    params: " << o.left << "\n"
      << (o.leftExtra.empty() ? "" : "    " + o.leftExtra + "\n")
      << "  - name: right\n    kind: mock\n    params: " << o.right << "\n"
      << (o.rightExtra.empty() ? "" : "    " + o.rightExtra + "\n")
      << "couplings:\n"
      << "  - {name: l2r, kind: direct-transfer, from: left, to: right, arrays: [state]}\n"
      << "  - {name: r2l, kind: direct-transfer, from: right, to: left, arrays: [state]}\n"
      << "output:\n  dir: " << (dir_ / "run").string() << "\n"
      << "  record: " << o.record << "\n"
      << (o.outputExtra.empty() ? "" : "  " + o.outputExtra + "\n");
    return path.string();
  }

  Finished runCoupler(const SceneOptions& o, std::vector<std::string> extra = {}, double timeoutS = 60) {
    std::vector<std::string> argv{binary("coupler"), "run", writeScene(o), "--no-progress"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto f = run(argv, timeoutS);
    EXPECT_FALSE(f.timedOut) << "the coupler hung; stderr:\n" << f.err;
    return f;
  }

  nlohmann::json report() const {
    std::ifstream in(dir_ / "run" / "run_report.json");
    return nlohmann::json::parse(in);
  }

  fs::path runDir() const { return dir_ / "run"; }
  fs::path dir_;
};

/// The fingerprint a mock reports for a pattern, as its two 32-bit halves.
std::pair<double, double> expectedDigest(std::uint64_t seed, std::uint64_t exchange, std::size_t length) {
  const auto fp = wire::fingerprint(mock::pattern(seed, exchange, length));
  return {static_cast<double>(fp >> 32), static_cast<double>(fp & 0xffffffffull)};
}

/// Each mock received, at every exchange, exactly the pattern its peer sent.
void expectEveryExchangeBitForBit(const fs::path& run, std::uint64_t exchanges, std::size_t length) {
  auto h5 = io::H5File::openReadOnly(run / "coupler.h5");
  const auto time = h5.readArray("/series/time");
  ASSERT_EQ(time.size(), exchanges + 1);  // setup + exchanges
  EXPECT_DOUBLE_EQ(time.back(), 1.0e-3 * static_cast<double>(exchanges));
  for (const auto& [name, peerSeed] : {std::pair{"left", 22}, std::pair{"right", 11}}) {
    const auto digest = h5.readArray(std::string("/series/") + name + "/digest");
    const auto mismatches = h5.readArray(std::string("/series/") + name + "/mismatches");
    ASSERT_EQ(digest.size(), 2 * (exchanges + 1));
    EXPECT_EQ(digest[0], -1.0) << "nothing is received at setup";
    for (std::uint64_t k = 1; k <= exchanges; ++k) {
      const auto [hi, lo] = expectedDigest(static_cast<std::uint64_t>(peerSeed), k - 1, length);
      ASSERT_EQ(digest[2 * k], hi) << name << " exchange " << k;
      ASSERT_EQ(digest[2 * k + 1], lo) << name << " exchange " << k;
      ASSERT_EQ(mismatches[k], 0.0) << name << " exchange " << k;
    }
  }
}

SceneOptions thousandExchanges(const std::string& data = "auto") {
  SceneOptions o;
  o.left = "{seed: 11, length: 1000, expect_seed: 22}";
  o.right = "{seed: 22, length: 1000, expect_seed: 11}";
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 1000}";
  o.transport = "{heartbeat_interval: 0.1, heartbeat_timeout: 1.0, request_timeout: 30, data: " + data + "}";
  return o;
}

TEST_F(CouplerRun, ThousandExchangesAreBitForBit) {
  const auto f = runCoupler(thousandExchanges());
  ASSERT_EQ(f.code, 0) << f.err;
  expectEveryExchangeBitForBit(runDir(), 1000, 1000);
  const auto r = report();
  EXPECT_EQ(r["status"], "completed");
  EXPECT_EQ(r["exchanges"], 1000);
  EXPECT_EQ(r["peers"].size(), 2u);
  EXPECT_GT(r["peers"][0]["bytes_sent"].get<double>(), 1000 * 1000 * 8.0);
  EXPECT_NE(f.out.find("run report: scene 'it' completed"), std::string::npos) << f.out;
}

// Peers on the coupler's host talk through shared memory unless the scene
// says zmq; either way every byte arrives, and the run directory keeps no
// segment: each is unlinked once its solver has mapped it, the rest at exit.
TEST_F(CouplerRun, SharedMemoryAndSocketsCarryTheSameBitsAndLeaveNoSegmentBehind) {
  for (const std::string data : {"auto", "zmq", "shm"}) {
    const auto f = runCoupler(thousandExchanges(data));
    ASSERT_EQ(f.code, 0) << data << ": " << f.err;
    expectEveryExchangeBitForBit(runDir(), 1000, 1000);
    const auto r = report();
    for (const auto& peer : r["peers"])
      EXPECT_EQ(peer["data_path"], data == "zmq" ? "zmq" : "shm") << data << ": " << peer["name"];
    EXPECT_NE(f.out.find(data == "zmq" ? "MiB moved over zmq" : "MiB moved over shm"), std::string::npos) << f.out;
    EXPECT_FALSE(fs::exists(runDir() / "shm")) << data;
  }
}

// A solver binary without the capability keeps ZeroMQ beside one that has
// it; a scene that insists on shared memory refuses it by name.
TEST_F(CouplerRun, ASolverWithoutSharedMemoryTalksOverZeroMqUnlessTheSceneInsists) {
  SceneOptions o = thousandExchanges();
  o.leftExtra = "args: [--mock-capabilities, 'setup,advance,fields,checkpoint,restore,arrays']";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  expectEveryExchangeBitForBit(runDir(), 1000, 1000);
  std::map<std::string, std::string> paths;
  const auto r = report();
  for (const auto& peer : r["peers"]) paths[peer["name"].get<std::string>()] = peer["data_path"].get<std::string>();
  EXPECT_EQ(paths["left"], "zmq");
  EXPECT_EQ(paths["right"], "shm");

  SceneOptions insists = thousandExchanges("shm");
  insists.leftExtra = o.leftExtra;
  const auto refused = runCoupler(insists);
  EXPECT_NE(refused.code, 0);
  EXPECT_NE(refused.err.find("peer 'left'"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("transport.data: shm"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("does not offer 'shm-data'"), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(runDir() / "shm"));
}

// A coupler killed with SIGKILL cannot remove what it created; the next run
// in its directory clears it and runs.
TEST_F(CouplerRun, AKilledCouplersSegmentsDoNotTripTheNextRun) {
  SceneOptions o = thousandExchanges();
  o.left = "{seed: 11, length: 1000, expect_seed: 22, compute_seconds: 0.005}";
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 1000000}";
  Subprocess coupler({binary("coupler"), "run", writeScene(o), "--no-progress"});
  for (int i = 0; i < 200 && !fs::exists(runDir() / "coupler.h5"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  coupler.signal(SIGKILL);
  coupler.wait(5);
  for (int i = 0; i < 200 && !processesMentioning(dir_.string()).empty(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_TRUE(fs::exists(runDir() / "shm" / "doorbell"));
  EXPECT_FALSE(fs::exists(runDir() / "shm" / "left")) << "a mapped segment keeps no name";
  const auto f = runCoupler(thousandExchanges());
  ASSERT_EQ(f.code, 0) << f.err;
  expectEveryExchangeBitForBit(runDir(), 1000, 1000);
  EXPECT_FALSE(fs::exists(runDir() / "shm"));
}

TEST_F(CouplerRun, PackedPlacementPutsEveryStartedPeerOnTheNamedCpu) {
  const auto allowed = util::allowedCpus();
  const int cpu = allowed.back();  // not necessarily the one this test runs on
  const std::string expected = "[" + std::to_string(cpu) + "]";
  SceneOptions o;
  o.placement = "{processes: packed, cpus: " + expected + "}";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto r = report();
  EXPECT_EQ(r["placement"], "packed on CPUs " + expected);
  ASSERT_EQ(r["peers"].size(), 2u);
  for (const auto& p : r["peers"]) EXPECT_EQ(p["cpus"], expected) << p["name"];
  // Spread (the default) leaves every peer the whole machine.
  const auto spread = runCoupler(SceneOptions{});
  ASSERT_EQ(spread.code, 0) << spread.err;
  const auto spreadReport = report();  // kept: the loop walks into it
  EXPECT_EQ(spreadReport["placement"], "spread");
  for (const auto& p : spreadReport["peers"]) EXPECT_EQ(p["cpus"], util::describeCpus(allowed)) << p["name"];
}

TEST_F(CouplerRun, PackedPlacementOnACpuThisMachineLacksIsRefusedBeforeStart) {
  SceneOptions o;
  o.placement = "{processes: packed, cpus: [1023]}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 2) << f.err;
  EXPECT_NE(f.err.find("placement.cpus: CPU 1023 is not one this process may use"), std::string::npos) << f.err;
  EXPECT_FALSE(fs::exists(runDir() / "coupler.h5")) << "refused while loading: nothing was started";
  // `coupler check` says the same, starting nothing.
  const auto check = run({binary("coupler"), "check", (dir_ / "scene.yaml").string()}, 30);
  EXPECT_EQ(check.code, 2) << check.out << check.err;
  EXPECT_NE(check.err.find("scene.yaml:"), std::string::npos) << check.err;
  EXPECT_NE(check.err.find("placement.cpus: CPU 1023"), std::string::npos) << check.err;
}

TEST_F(CouplerRun, KilledPeerIsNamedAndOutputStaysReadable) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, die_at: 50}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("peer 'left'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("killed by signal 9"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("exchange 50"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("last heard"), std::string::npos) << f.err;
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  EXPECT_EQ(h5.readArray("/series/time").size(), 50u);  // setup + exchanges 1..49
  EXPECT_EQ(report()["status"], "failed");
}

TEST_F(CouplerRun, FrozenPeerIsCaughtByTheHeartbeat) {
  SceneOptions o;
  o.right = "{seed: 2, length: 64, freeze_at: 20}";
  const auto f = runCoupler(o, {}, 30);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("peer 'right'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("heartbeat timeout"), std::string::npos) << f.err;
  EXPECT_LT(f.wallS, 10.0);
}

TEST_F(CouplerRun, StalledComputationMissesItsDeadline) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, stall_at: 5}";
  o.transport = "{heartbeat_interval: 0.1, heartbeat_timeout: 1.0, request_timeout: 1.5}";
  const auto f = runCoupler(o, {}, 30);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("no reply to 'advance'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("heartbeat (computing)"), std::string::npos) << f.err;
}

// Protocol paths before time zero: a solver that exits before its hello, and
// one that never says it (connect timeout), are named with what was heard of
// them; neither leaves anything behind, a child of its own included.
TEST_F(CouplerRun, ASolverThatExitsBeforeItsHelloIsNamed) {
  const auto script = dir_ / "quits.sh";
  std::ofstream(script) << "#!/bin/sh\n[ \"$1\" = --check ] && exit 0\nexit 7\n";
  fs::permissions(script, fs::perms::owner_all);
  SceneOptions o;
  o.rightExtra = "binary: " + script.string();
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("peer 'right'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("exited with code 7, before time zero"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("it never said hello"), std::string::npos) << f.err;
}

TEST_F(CouplerRun, ASilentSolverMissesTheConnectTimeoutAndItsChildrenGoWithIt) {
  const auto script = dir_ / "silent.sh";
  const auto marker = dir_ / "marker";
  std::ofstream(marker) << "a file the solver's child keeps open\n";
  std::ofstream(script) << "#!/bin/sh\n[ \"$1\" = --check ] && exit 0\ntail -f " << marker.string()
                        << " > /dev/null &\nwait\n";
  fs::permissions(script, fs::perms::owner_all);
  SceneOptions o;
  o.rightExtra = "binary: " + script.string();
  o.transport = "{connect_timeout: 1.0, heartbeat_interval: 0.1, heartbeat_timeout: 1.0}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("peer 'right', before time zero: no hello within 1.00 s"), std::string::npos) << f.err;
  for (int i = 0; i < 100 && !processesMentioning(marker.string()).empty(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_TRUE(processesMentioning(marker.string()).empty()) << "the silent solver's child outlived the run";
}

TEST_F(CouplerRun, ProtocolMismatchIsRefusedBeforeTimeZero) {
  SceneOptions o;
  o.rightExtra = "args: [--mock-protocol-major, '99']";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("solver 'right'"), std::string::npos) << f.err;
  const std::string minor = std::to_string(proto::PROTOCOL_MINOR);
  EXPECT_NE(f.err.find("speaks protocol 99." + minor), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("the coupler speaks 1." + minor), std::string::npos) << f.err;
  EXPECT_EQ(report()["exchanges"], 0);
}

TEST_F(CouplerRun, MissingCapabilityIsRefused) {
  SceneOptions o;
  o.leftExtra = "args: [--mock-capabilities, 'setup,advance']";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("lacks capability 'arrays'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("it offers: setup, advance"), std::string::npos) << f.err;
}

TEST_F(CouplerRun, WrongKindIsRefused) {
  SceneOptions o;
  o.leftExtra = "args: [--mock-kind, dem]";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("reports kind 'dem' but the scene declares kind 'mock'"), std::string::npos) << f.err;
}

// The solvers check their params before the run starts them (coupler check's
// path): a refused section is a bad scene, exit 2, and no run directory is made.
TEST_F(CouplerRun, BadSolverParamsNameTheSceneLine) {
  SceneOptions o;
  o.right = "{seed: 2, length: -5}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 2) << f.err;
  EXPECT_NE(f.err.find("scene.yaml:10: solvers.right.params.length"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("run refused before any solver started"), std::string::npos) << f.err;
  EXPECT_FALSE(fs::exists(dir_ / "run")) << "a refused scene made its run directory";
}

TEST_F(CouplerRun, SolverErrorDuringRunStopsIt) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, fail_at: 10}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("scripted failure at exchange 10"), std::string::npos) << f.err;
}

TEST_F(CouplerRun, NonFiniteEnergyStopsTheRunWithADiagnosis) {
  SceneOptions o;
  o.right = "{seed: 2, length: 64, nan_at: 7}";
  const auto f = runCoupler(o);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("solver 'right' reported kinetic = nan at exchange 7"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("unstable"), std::string::npos) << f.err;
}

// A NaN energy in the setup reply, or a critical step that is negative (or
// NaN, infinite) at setup or later, is a broken solver: a negative step would
// otherwise read as "no limit" and skip the refusal of a too long dt.
TEST_F(CouplerRun, BrokenSetupEnergyOrCriticalStepIsRefusedNamingTheSolver) {
  SceneOptions o;
  o.right = "{seed: 2, length: 64, nan_at: 0}";
  auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("solver 'right' reported kinetic = nan at setup, before any step"), std::string::npos) << f.err;
  o = SceneOptions{};
  o.left = "{seed: 1, length: 64, critical_dt: -1.0e-4}";
  f = runCoupler(o, {"--force"});
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("solver 'left' reports a critical time step of -0.0001 s at setup (it must be positive and "
                       "finite, or 0 for no limit)"),
            std::string::npos) << f.err;
  o.left = "{seed: 1, length: 64, critical_dt: 2.0e-3, critical_dt_later: -1.0, critical_dt_from: 35}";
  f = runCoupler(o);
  EXPECT_EQ(f.code, 4) << f.err;
  EXPECT_NE(f.err.find("solver 'left' reports a critical time step of -1 s at exchange 35"), std::string::npos) << f.err;
}

TEST_F(CouplerRun, StepAboveTheCriticalStepIsRefusedUnlessForced) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, critical_dt: 1.0e-4}";
  auto f = runCoupler(o);
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("exceeds the critical time step 0.0001 s of solver 'left'"), std::string::npos) << f.err;
  f = runCoupler(o, {"--force"});
  EXPECT_EQ(f.code, 0) << f.err;
}

// Advanced.criticalDt is asked for on series rows only (a Hertz-aware DEM step
// is a sweep over the particles), recorded there, and a step that has become
// larger than it is reported once, on stderr and in the run report.
TEST_F(CouplerRun, CriticalStepIsAskedOnSeriesRowsAndAShrinkingOneIsReported) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, expect_seed: 2, critical_dt: 2.0e-3, critical_dt_later: 5.0e-4, critical_dt_from: 35, "
           "count_critical_dt: true}";
  o.outputExtra = "series_every: 10";
  o.record = "[left.critical_dt_calls]";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  const std::string warning =
      "solver 'left' reports a critical step of 0.0005 s at exchange 40 (t = 0.04 s), below the step dt = 0.001 s";
  EXPECT_NE(f.err.find(warning), std::string::npos) << f.err;
  EXPECT_EQ(f.err.find("solver 'left' reports a critical step", f.err.find(warning) + 1), std::string::npos)
      << "reported more than once:\n" << f.err;
  EXPECT_EQ(f.err.find("solver 'right' reports"), std::string::npos) << f.err;  // no limit: never reported
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  const auto critical = h5.readArray("/series/left/critical_dt_s");
  ASSERT_EQ(critical.size(), 11u);  // setup and exchanges 10, 20, ..., 100
  for (std::size_t k = 0; k < critical.size(); ++k) EXPECT_EQ(critical[k], k < 4 ? 2.0e-3 : 5.0e-4) << "row " << k;
  // Emitted before the host asks: row k has seen setup and rows 1 .. k-1 ask.
  const auto calls = h5.readArray("/series/left/critical_dt_calls");
  ASSERT_EQ(calls.size(), 11u);
  for (std::size_t k = 0; k < calls.size(); ++k) EXPECT_EQ(calls[k], static_cast<double>(k)) << "row " << k;
  const auto r = report();
  ASSERT_EQ(r["warnings"].size(), 1u);
  EXPECT_NE(r["warnings"][0].get<std::string>().find(warning), std::string::npos);
  for (const auto& p : r["peers"])
    if (p["name"] == "left") {
      EXPECT_EQ(p["critical_dt_s"].get<double>(), 2.0e-3);
      EXPECT_EQ(p["critical_dt_min_s"].get<double>(), 5.0e-4);
    }
}

TEST_F(CouplerRun, AutoStepUsesTheSafetyFactor) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, critical_dt: 2.0e-4}";
  o.schedule = "{kind: lockstep, dt: auto, safety: 0.5, exchanges: 10}";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  EXPECT_NEAR(h5.readArray("/series/time").back(), 10 * 1.0e-4, 1e-15);
}

TEST_F(CouplerRun, TcpTransportOnLoopback) {
  SceneOptions o;
  o.transport = "{kind: tcp, heartbeat_interval: 0.1, heartbeat_timeout: 1.0}";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  EXPECT_EQ(h5.readArray("/series/right/mismatches").size(), 101u);
  for (double m : h5.readArray("/series/right/mismatches")) EXPECT_EQ(m, 0.0);
}

TEST_F(CouplerRun, CurveEncryptedTcp) {
  SceneOptions o;
  o.transport = "{kind: tcp, curve: true, heartbeat_interval: 0.1, heartbeat_timeout: 1.0}";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto key = runDir() / "coupler.pub";
  ASSERT_TRUE(fs::exists(key));
  EXPECT_EQ(fs::status(key).permissions() & (fs::perms::group_all | fs::perms::others_all), fs::perms::none);
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  for (double m : h5.readArray("/series/right/mismatches")) EXPECT_EQ(m, 0.0);
}

TEST_F(CouplerRun, GarbageSentToTheEndpointDoesNotDisturbTheRun) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, expect_seed: 2, compute_seconds: 0.003}";
  // 3 s of exchanges at least: the run must still be going when the intruder's
  // frames arrive, also in a sanitizer build, whose start takes longer.
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 1000}";
  Subprocess coupler({binary("coupler"), "run", writeScene(o), "--no-progress"});
  const auto socketPath = runDir() / "coupler.sock";
  for (int i = 0; i < 200 && !fs::exists(socketPath); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(socketPath));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::mt19937 rng(7);
  // Raw bytes that are not even ZMTP.
  for (int i = 0; i < 20; ++i) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, socketPath.c_str(), sizeof(addr.sun_path) - 1);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0) {
      std::vector<char> junk(1 + rng() % 4096);
      for (auto& c : junk) c = static_cast<char>(rng());
      [[maybe_unused]] auto n = ::write(fd, junk.data(), junk.size());
    }
    ::close(fd);
  }
  // Well-formed ZeroMQ frames that are not our protocol, from an unknown peer,
  // and a valid envelope from one that never said hello.
  {
    wire::DealerSocket intruder("ipc://" + socketPath.string(), "intruder");
    for (int i = 0; i < 50; ++i) {
      std::vector<char> junk(1 + rng() % 512);
      for (auto& c : junk) c = static_cast<char>(rng());
      zmq::message_t m(junk.data(), junk.size());
      intruder.raw().send(m, zmq::send_flags::none);
    }
    wire::OutMessage advance;
    advance.envelope().setSeq(1);
    advance.envelope().getBody().initAdvance().setSteps(1);
    intruder.send(advance);
    auto answer = intruder.receive(std::chrono::milliseconds(5000));
    ASSERT_TRUE(answer && answer->message);
    EXPECT_TRUE(answer->message->envelope().getBody().isError());
  }
  const int code = coupler.wait(60);
  ASSERT_EQ(code, 0) << coupler.err();
  EXPECT_NE(coupler.err().find("malformed"), std::string::npos) << "garbage should be logged";
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  for (double m : h5.readArray("/series/left/mismatches")) ASSERT_EQ(m, 0.0);
}

TEST_F(CouplerRun, InterruptStopsTheRunCleanly) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, compute_seconds: 0.005}";
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 1000000}";
  Subprocess coupler({binary("coupler"), "run", writeScene(o), "--no-progress"});
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  coupler.signal(SIGINT);
  const int code = coupler.wait(20);
  EXPECT_EQ(code, 130) << coupler.err();
  EXPECT_NE(coupler.err().find("stopped by signal 2"), std::string::npos) << coupler.err();
  EXPECT_EQ(report()["status"], "interrupted");
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  EXPECT_GT(h5.readArray("/series/time").size(), 10u);
}

TEST_F(CouplerRun, SolversDieWithAKilledCoupler) {
  SceneOptions o;
  o.left = "{seed: 1, length: 64, compute_seconds: 0.005}";
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 1000000}";
  Subprocess coupler({binary("coupler"), "run", writeScene(o), "--no-progress"});
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  ASSERT_EQ(processesMentioning(dir_.string()).size(), 3u);  // coupler + 2 mocks
  coupler.signal(SIGKILL);
  coupler.wait(5);
  for (int i = 0; i < 100 && !processesMentioning(dir_.string()).empty(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_TRUE(processesMentioning(dir_.string()).empty());
}

TEST_F(CouplerRun, AttachedSolverStartedByHand) {
  SceneOptions o;
  o.rightExtra = "launch: attach";
  Subprocess coupler({binary("coupler"), "run", writeScene(o), "--no-progress"});
  const auto socketPath = runDir() / "coupler.sock";
  for (int i = 0; i < 200 && !fs::exists(socketPath); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(fs::exists(socketPath));
  Subprocess byHand({binary("mock_solver"), "--endpoint", "ipc://" + socketPath.string(), "--name", "right"});
  ASSERT_EQ(coupler.wait(60), 0) << coupler.err();
  EXPECT_EQ(byHand.wait(10), 0) << byHand.err();
  EXPECT_NE(coupler.err().find("waiting for solver 'right' to connect"), std::string::npos);
}

TEST_F(CouplerRun, SolverLeavesWhenTheCouplerFallsSilent) {
  // A solver whose coupler vanishes (no heartbeats) exits by itself.
  const auto endpoint = "ipc://" + (dir_ / "silent.sock").string();
  wire::RouterSocket router(endpoint);
  Subprocess solver({binary("mock_solver"), "--endpoint", endpoint, "--name", "lonely"});
  std::optional<wire::Received> hello;
  for (int i = 0; i < 50 && !(hello && hello->identity == "lonely"); ++i)
    hello = router.receive(std::chrono::milliseconds(100));
  ASSERT_TRUE(hello && hello->message && hello->message->envelope().getBody().isHello());
  wire::OutMessage welcome;
  auto w = welcome.envelope().getBody().initWelcome();
  w.setProtocolMajor(proto::PROTOCOL_MAJOR);
  w.setProtocolMinor(proto::PROTOCOL_MINOR);
  w.setHeartbeatIntervalS(0.1);
  w.setHeartbeatTimeoutS(0.5);
  ASSERT_TRUE(router.send("lonely", welcome));
  EXPECT_EQ(solver.wait(10), 4) << solver.err();
  EXPECT_NE(solver.err().find("the coupler went away"), std::string::npos) << solver.err();
}

TEST_F(CouplerRun, ResumedRunContinuesBitForBit) {
  SceneOptions o;
  o.left = "{seed: 3, length: 256, expect_seed: 4, compute_seconds: 0.002}";
  o.right = "{seed: 4, length: 256, expect_seed: 3}";
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 300}";
  o.outputExtra = "checkpoint_interval: 50";
  // history: each mock's running hash of what it received, so a restore that is skipped shows
  o.record = "[left.digest, left.mismatches, left.history, right.digest, right.mismatches, right.history]";
  const auto scene = writeScene(o);
  const auto whole = dir_ / "whole";
  const auto cut = dir_ / "cut";
  auto f = run({binary("coupler"), "run", scene, "--out", whole.string(), "--no-progress"}, 60);
  ASSERT_EQ(f.code, 0) << f.err;
  {
    Subprocess victim({binary("coupler"), "run", scene, "--out", cut.string(), "--no-progress"});
    for (int i = 0; i < 1000 && !fs::exists(cut / "checkpoints" / "exchange-150"); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    ASSERT_TRUE(fs::exists(cut / "checkpoints" / "exchange-150"));
    victim.signal(SIGKILL);  // no chance to clean up: the solvers die with it
    victim.wait(10);
  }
  for (int i = 0; i < 100 && !processesMentioning(cut.string()).empty(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  f = run({binary("coupler"), "run", scene, "--out", cut.string(), "--resume", "--no-progress"}, 60);
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_NE(f.err.find("resuming from exchange"), std::string::npos) << f.err;
  auto a = io::H5File::openReadOnly(whole / "coupler.h5");
  auto b = io::H5File::openReadOnly(cut / "coupler.h5");
  for (const std::string series : {"time", "exchange", "left/digest", "right/digest", "left/mismatches",
                                   "left/history", "right/history", "right/energy/kinetic"}) {
    const auto x = a.readArray("/series/" + series);
    const auto y = b.readArray("/series/" + series);
    ASSERT_EQ(x.size(), y.size()) << series;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(double))) << series;
  }
  EXPECT_EQ(a.readArray("/series/time").size(), 301u);
}

TEST_F(CouplerRun, ResumeRefusesAChangedScene) {
  SceneOptions o;
  o.outputExtra = "checkpoint_interval: 10";
  auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  o.right = "{seed: 9, length: 64}";
  f = runCoupler(o, {"--resume"});
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("differs from the scene the run"), std::string::npos) << f.err;
}

TEST_F(CouplerRun, ResumeRefusesACorruptCheckpointState) {
  SceneOptions o;
  o.outputExtra = "checkpoint_interval: 10";
  auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  fs::path newest;
  std::uint64_t most = 0;
  for (const auto& e : fs::directory_iterator(runDir() / "checkpoints")) {
    const std::string n = e.path().filename().string();
    if (n.rfind("exchange-", 0) == 0 && std::stoull(n.substr(9)) >= most) most = std::stoull(n.substr(9)), newest = e.path();
  }
  ASSERT_FALSE(newest.empty());
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{}", "needs an unsigned 'exchange'"},
      {"{\"exchange\": 1000000, \"time_hex\": \"0x1p-3\"}", "'exchange' is 1000000 in the directory of exchange"},
      {"{\"exchange\": " + std::to_string(most) + ", \"time_hex\": \"nan\"}", "not a finite time"},
      {"{\"exchange\": ", "corrupt checkpoint state"}};
  for (const auto& [state, expected] : cases) {
    std::ofstream(newest / "coupler_state.json") << state;
    f = runCoupler(o, {"--resume"});
    EXPECT_EQ(f.code, 3) << state << "\n" << f.err;
    EXPECT_NE(f.err.find(newest.string() + "/coupler_state.json: corrupt checkpoint state"), std::string::npos) << f.err;
    EXPECT_NE(f.err.find(expected), std::string::npos) << f.err;
  }
}

TEST_F(CouplerRun, ResumeNamesAMissingOrCorruptSolverCheckpoint) {
  SceneOptions o;
  o.outputExtra = "checkpoint_interval: 10";
  auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto point = runDir() / "checkpoints" / "exchange-100";
  ASSERT_TRUE(fs::exists(point / "right.chk"));
  std::ofstream(point / "right.chk") << "mock-checkpoint 2\n17";
  f = runCoupler(o, {"--resume"});
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("peer 'right'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find("answered 'restore'"), std::string::npos) << f.err;
  EXPECT_NE(f.err.find((point / "right.chk").string() + "' is truncated"), std::string::npos) << f.err;
  std::ofstream(point / "right.chk") << "mock-checkpoint 2\n100 100 0x1.999999999999ap-4 0x0p+0 5\n";
  std::ofstream(point / "left.last.bin") << "12345678";
  f = runCoupler(o, {"--resume"});
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find("solver 'left''s last reply in the checkpoint: " + (point / "left.last.bin").string() +
                       ": not a valid Envelope"),
            std::string::npos)
      << f.err;
  fs::remove(point / "left.chk");
  f = runCoupler(o, {"--resume"});
  EXPECT_EQ(f.code, 3) << f.err;
  EXPECT_NE(f.err.find(point.string() + ": the checkpoint lacks solver 'left''s state (left.chk)"),
            std::string::npos)
      << f.err;
  EXPECT_FALSE(fs::exists(runDir() / "checkpoints" / "exchange-110")) << "no solver may have run";
}

}  // namespace
}  // namespace cosim::testing

namespace cosim::testing {
namespace {

TEST_F(CouplerRun, SeriesEveryThinsTheRowsAndKeepsTheLast) {
  SceneOptions o;
  o.schedule = "{kind: lockstep, dt: 1.0e-3, exchanges: 100}";
  o.outputExtra = "series_every: 7";
  const auto f = runCoupler(o);
  ASSERT_EQ(f.code, 0) << f.err;
  auto h5 = io::H5File::openReadOnly(runDir() / "coupler.h5");
  const auto exchange = h5.readArray("/series/exchange");
  // Exchanges 0 (setup), 7, 14, ..., 98, and the last one (100).
  ASSERT_EQ(exchange.size(), 16u);
  EXPECT_DOUBLE_EQ(exchange[1], 7.0);
  EXPECT_DOUBLE_EQ(exchange.back(), 100.0);
  EXPECT_EQ(h5.readArray("/series/left/digest").size(), 2 * exchange.size());  // two halves per row
}

}  // namespace
}  // namespace cosim::testing
