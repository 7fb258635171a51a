// Scene C1 cut short (tests/coupling/c1_short.yaml) through the real coupler,
// fem_solver and dem_solver: the particles rest on the beam's coupling
// surface, every mapped nodal force balances the contact forces, and the run
// report carries the scene's error metric against the beam-theory reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>

#include "cosim/io/h5_file.hpp"
#include "subprocess.hpp"

namespace cosim::testing {
namespace {

struct C1Run {
  std::filesystem::path dir = freshDirectory("c1");
  Finished run(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv{binary("coupler"), "run", sourcePath("tests/coupling/c1_short.yaml"), "--out",
                                  (dir / "run").string(), "--no-progress"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return cosim::testing::run(argv, 240.0);
  }
  nlohmann::json report() const {
    std::ifstream in(dir / "run" / "run_report.json");
    return nlohmann::json::parse(in);
  }
};

/// The mapped nodal forces of every recorded row equal the contact forces
/// (both maps conserve the total force exactly); returns the contact rows.
std::vector<double> expectMappedForcesBalance(const std::filesystem::path& run) {
  auto h5 = io::H5File::openReadOnly(run / "coupler.h5");
  const auto contact = h5.readArray("/series/top/contact_force");
  const auto nodal = h5.readArray("/series/top/nodal_force");
  EXPECT_EQ(contact.size(), nodal.size());
  for (std::size_t k = 0; k < std::min(contact.size(), nodal.size()); ++k)
    EXPECT_NEAR(nodal[k], contact[k], 1e-9 * (1.0 + std::abs(contact[k]))) << "row " << k / 3;
  return contact;
}

TEST(SurfaceCouplingRun, ParticlesRestOnTheBeamAndTheMapBalancesTheContactForces) {
  C1Run c1;
  const auto done = c1.run();
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  const auto report = c1.report();
  ASSERT_FALSE(report["errors"].empty());
  EXPECT_EQ(report["errors"][0]["name"], "time_averaged_trajectory_error");
  // 30 coarse steps (19 ms): the particles barely move from the reference path.
  EXPECT_LT(report["errors"][0]["value"].get<double>(), 1e-4);
  // Kinetic 2 x 0.5 x 83.78 x 0.1^2 = 0.838 J plus the two contact springs
  // 2 x (m g)^2 / (2 k_n) = 0.034 J: 0.872 J at t = 0.
  EXPECT_GT(report["figures"]["max_total_energy_J"].get<double>(), 0.87);
  EXPECT_LT(report["figures"]["max_total_energy_J"].get<double>(), 0.94);

  const auto contact = expectMappedForcesBalance(c1.dir / "run");
  const auto count = io::H5File::openReadOnly(c1.dir / "run" / "coupler.h5").readArray("/series/top/contacts");
  ASSERT_GT(count.size(), 10u);
  ASSERT_GE(contact.size(), 3u);
  // Both particles' weight (2 x 83.78 x 9.81 = 1643.7 N) rests on the surface at setup.
  EXPECT_NEAR(contact[2], -1643.7, 0.05 * 1643.7);
  EXPECT_GE(count.front(), 2.0);
}

// Resumed from its earlier checkpoint, the run reports the uninterrupted
// run's error and figures: the reference keeps its time integral, start
// positions and drifts in the checkpoint, so drift is measured from the
// run's start, not from the resumed positions.
TEST(SurfaceCouplingRun, AResumedRunReportsTheUninterruptedRunsError) {
  C1Run c1;
  const auto done = c1.run({"--set", "output.checkpoint_interval=10"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  namespace fs = std::filesystem;
  const auto cut = c1.dir / "cut";
  const fs::path point = cutBackToEarlierCheckpoint(c1.dir / "run", cut);
  const auto resumed = run({binary("coupler"), "run", sourcePath("tests/coupling/c1_short.yaml"), "--resume", "--out",
                            cut.string(), "--no-progress", "--set", "output.checkpoint_interval=10"},
                           240.0);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  EXPECT_NE(resumed.err.find("resuming from exchange " + point.filename().string().substr(9)), std::string::npos)
      << resumed.err;
  std::ifstream in(cut / "run_report.json");
  const auto part = nlohmann::json::parse(in);
  const auto whole = c1.report();
  ASSERT_FALSE(whole["errors"].empty());
  EXPECT_GT(whole["errors"][0]["value"].get<double>(), 0.0);
  EXPECT_EQ(part["errors"], whole["errors"]);
  EXPECT_EQ(part["figures"], whole["figures"]);
}

/// Every dataset under `path` of a run's coupler.h5, by its path, but the
/// timings (compute_s, communication_s: wall-clock, never twice the same).
void collectSeries(const io::H5File& h5, const std::string& path, std::map<std::string, std::vector<double>>& out) {
  const auto leaf = path.substr(path.rfind('/') + 1);
  if (leaf == "compute_s" || leaf == "communication_s") return;
  try {
    out[path] = h5.readArray(path);
  } catch (const std::exception&) {  // a group
    for (const auto& child : h5.children(path)) collectSeries(h5, path + "/" + child, out);
  }
}

std::map<std::string, std::vector<double>> seriesOf(const std::filesystem::path& run) {
  std::map<std::string, std::vector<double>> series;
  collectSeries(io::H5File::openReadOnly(run / "coupler.h5"), "/series", series);
  return series;
}

// The data path is the transport's business: C1's every series, bit for bit,
// whether the beam and the particles talk through shared memory or sockets.
TEST(SurfaceCouplingRun, TheSharedMemoryPathGivesTheSocketPathsSeriesToTheBit) {
  C1Run shm, zmq;
  const auto a = shm.run({"--set", "transport={data: shm}"});
  ASSERT_EQ(a.code, 0) << a.out << a.err;
  const auto b = zmq.run({"--set", "transport={data: zmq}"});
  ASSERT_EQ(b.code, 0) << b.out << b.err;
  const auto shmReport = shm.report(), zmqReport = zmq.report();
  for (const auto& peer : shmReport["peers"]) EXPECT_EQ(peer["data_path"], "shm");
  for (const auto& peer : zmqReport["peers"]) EXPECT_EQ(peer["data_path"], "zmq");
  const auto viaShm = seriesOf(shm.dir / "run"), viaZmq = seriesOf(zmq.dir / "run");
  ASSERT_GT(viaShm.size(), 5u);
  ASSERT_EQ(viaShm.size(), viaZmq.size());
  for (const auto& [name, values] : viaShm) {
    ASSERT_TRUE(viaZmq.count(name)) << name;
    ASSERT_EQ(values.size(), viaZmq.at(name).size()) << name;
    EXPECT_EQ(std::memcmp(values.data(), viaZmq.at(name).data(), values.size() * sizeof(double)), 0) << name;
  }
}

TEST(SurfaceCouplingRun, PointFormWithParallelScheduleRuns) {
  C1Run c1;
  const auto done = c1.run({"--set", "couplings.top.kernel=dirac", "--set", "couplings.top.width=0", "--set",
                            "schedule.order=parallel", "--set", "couplings.top.wall_kinematics=extrapolated"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  EXPECT_LT(c1.report()["errors"][0]["value"].get<double>(), 1e-4);
}

TEST(SurfaceCouplingRun, SmoothedWallRunsTheScenesScheduleAndBalancesTheForces) {
  // The energy-consistent wall (SmoothedSurface) on C1's own schedule, 0.04 s.
  C1Run c1;
  const auto done = c1.run({"--set", "couplings.top.wall_kinematics=smoothed", "--set", "schedule.order=fine-first",
                            "--set", "schedule.ratio=1", "--set", "schedule.coarse_steps=600"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  const auto report = c1.report();
  EXPECT_LT(report["errors"][0]["value"].get<double>(), 1e-4);
  EXPECT_GT(report["figures"]["max_total_energy_J"].get<double>(), 0.8);
  EXPECT_LT(report["figures"]["max_total_energy_J"].get<double>(), 0.9);
  expectMappedForcesBalance(c1.dir / "run");
}

TEST(SurfaceCouplingRun, PaperVariantSpreadsOverTheVolumeGaussPointsAndBalancesTheForces) {
  // configs/c1/cantilever_surface_paper.yaml for 600 steps (0.055 s): the
  // lagged wall and the CG over the beam's Gauss points (cg_points: volume)
  // hand FEM exactly the contact force, row by row.
  const auto dir = freshDirectory("c1-paper");
  const auto done = cosim::testing::run({binary("coupler"), "run", sourcePath("configs/c1/cantilever_surface_paper.yaml"), "--out",
                                         (dir / "run").string(), "--no-progress", "--set", "schedule.end_time=0.0546"},
                                        240.0);
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  EXPECT_GT(expectMappedForcesBalance(dir / "run").size(), 3u);
  // A zone fem_solver does not export is refused at setup, naming it.
  const auto missing = cosim::testing::run({binary("coupler"), "run", sourcePath("configs/c1/cantilever_surface_paper.yaml"), "--out",
                                            (dir / "missing").string(), "--no-progress", "--set", "couplings.top.volume_zone=nowhere",
                                            "--set", "schedule.end_time=0.001"},
                                           120.0);
  EXPECT_NE(missing.code, 0);
  EXPECT_NE((missing.out + missing.err).find("sent no array 'nowhere/"), std::string::npos) << missing.out << missing.err;
}

TEST(SurfaceCouplingRun, RunReportSharesDoNotOverlapOnOneCpu) {
  // Packed on one CPU, a solver may run its whole step while the coupler is
  // still inside the send. That time belongs to the round trip (between the
  // send and the reply, less the solver's compute), not to the mapping: on a
  // sequential schedule mapping + output + every peer's compute and
  // communication add up to at most the exchange loop (they once summed to
  // 123 % of it in C1, and the overhead read 72 % instead of 40 %).
  C1Run c1;
  const auto done = c1.run({"--set", "placement.processes=packed", "--set", "schedule.order=fine-first", "--set",
                            "schedule.ratio=1", "--set", "schedule.coarse_steps=1500"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  const auto report = c1.report();
  const auto& t = report["wall_s"];
  double accounted = t["coupler_mapping"].get<double>() + t["coupler_output"].get<double>();
  for (const auto& peer : report["peers"])
    accounted += peer["compute_s"].get<double>() + peer["communication_s"].get<double>();
  const double loop = t["exchange_loop"].get<double>();
  EXPECT_LE(accounted, 1.01 * loop) << report.dump(2);
  EXPECT_GT(accounted, 0.5 * loop) << report.dump(2);
  EXPECT_LT(report["coupling_overhead_share"].get<double>(), 1.0);
}

TEST(SurfaceCouplingRun, EnergyGrowthBeyondTheLimitStopsTheRunAsUnstable) {
  C1Run c1;
  // The coupled energy drifts by a few per mille over these 30 steps: a limit of
  // 1.0001 x the initial energy must stop the run, naming the numbers.
  const auto done = c1.run({"--set", "analysis.max_energy_growth=1.0001"});
  EXPECT_EQ(done.code, 4) << done.out << done.err;
  EXPECT_NE(done.err.find("unstable run"), std::string::npos) << done.err;
  EXPECT_NE(done.err.find("max_energy_growth"), std::string::npos) << done.err;
}

// A coupling that finds the setup replies lacking what the scene names (here a
// surface the beam does not export) refuses the run before time zero, exit 3,
// like every other scene error found at setup (it exited 1, "coupler failure").
TEST(SurfaceCouplingRun, ASurfaceTheBeamDoesNotExportIsRefusedBeforeTimeZero) {
  C1Run c1;
  const auto done = c1.run({"--set", "couplings.top.surface=ymax"});
  EXPECT_EQ(done.code, 3) << done.out << done.err;
  EXPECT_NE(done.err.find("coupling 'top': solver 'beam' exported no surface 'ymax' at exchange 0"), std::string::npos)
      << done.err;
  EXPECT_NE(done.err.find("before time zero"), std::string::npos) << done.err;
}

TEST(SurfaceCouplingRun, CheckRefusesAKernelWithoutWidth) {
  C1Run c1;
  const auto scene = c1.dir / "bad.yaml";
  {
    std::ifstream in(sourcePath("tests/coupling/c1_short.yaml"));
    std::stringstream text;
    text << in.rdbuf();
    std::string s = text.str();
    s.replace(s.find("    width: 10d\n"), 15, "");
    std::ofstream(scene) << s;
  }
  const auto done = run({binary("coupler"), "check", scene.string()}, 30.0);
  EXPECT_EQ(done.code, 2);
  EXPECT_NE(done.err.find("needs a CG width"), std::string::npos) << done.err;
}

}  // namespace
}  // namespace cosim::testing
