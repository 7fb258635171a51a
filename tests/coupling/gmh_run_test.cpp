// The GMH loop through real processes: fem_solver (external material, one
// point per element, explicit) sends one unit-cell job per element each
// coarse step; two dem_solver workers each hold one prepared 100-sphere cell
// (dem_prepare_cell, 416 kPa); the gmh coupling splits the jobs by owner and
// gathers the stresses. Compressing the block raises the cells' pressure; a
// worker killed mid-run stops the run with a message naming its cells, or,
// with on_worker_loss: move, hands them to the other worker and the run's
// results stay those of an undisturbed run.
#include <gtest/gtest.h>

#include <algorithm>

#include <cmath>
#include <csignal>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "cosim/io/h5_file.hpp"
#include "subprocess.hpp"

namespace cosim::testing {
namespace {
namespace fs = std::filesystem;

class GmhRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cellDir_ = freshDirectory("gmh-cell");
    const auto f = run({binary("dem_prepare_cell"), "--out", (cellDir_ / "cell").string(), "--count", "100", "--seed", "3"},
                       120.0);
    ASSERT_EQ(f.code, 0) << f.out << f.err;
    // Another packing (seed 4), for scenes whose two cells must differ.
    const auto g = run({binary("dem_prepare_cell"), "--out", (cellDir_ / "other").string(), "--count", "100", "--seed", "4"},
                       120.0);
    ASSERT_EQ(g.code, 0) << g.out << g.err;
  }
  static void TearDownTestSuite() { fs::remove_all(cellDir_); }

  void SetUp() override { dir_ = freshDirectory("gmh-run"); }
  void TearDown() override {
    EXPECT_TRUE(processesMentioning(dir_.string()).empty()) << "processes left behind";
    if (!HasFailure()) fs::remove_all(dir_);
  }

  /// `elements` in a row along x, 0.01 m apart; each worker holds half the cells.
  std::string scene(int coarseSteps, const std::string& secondFirstId = "1", const std::string& couplingExtra = "",
                    int elements = 2) const {
    const std::string perWorker = std::to_string(elements / 2);
    const auto path = dir_ / "gmh.yaml";
    const std::string cell = (cellDir_ / "cell.ckpt").string();
    std::ofstream(path) << "scene: gmh-two-cells\n"
                        << "schedule: {kind: multirate, fine: [cells_a, cells_b], dt: 2.0e-5, ratio: 1, "
                        << "order: coarse-first, coarse_steps: " << coarseSteps << "}\n"
                        << R"(solvers:
  - name: block
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [)" << 0.01 * elements << R"(, 0.01, 0.01], divisions: [)" << elements << R"(, 1, 1]}}
      material: {model: external, E: 1.0e8, nu: 0.2, density: 1600}
      formulation: one-point
      sets:
        everything: {box: {min: [-1, -1, -1], max: [1, 1, 1]}}
        bottom: {box: {min: [-1, -1, -0.0001], max: [1, 1, 0.0001]}}
        top: {box: {min: [-1, -1, 0.0099], max: [1, 1, 0.0101]}}
      boundary:
        - {set: everything, dofs: [x, y], value: 0.0}
        - {set: bottom, dofs: [z], value: 0.0}
        - {set: top, dofs: [z], value: -1.0e-3, kind: velocity}
      integrator: {type: central-difference}
  - name: cells_a
    kind: dem
    params:
      unit_cells: {file: )" << cell << R"(, first_id: 0, count: )" << perWorker << R"(, max_steps: 20000, load_steps: 20}
  - name: cells_b
    kind: dem
    params:
      unit_cells: {file: )" << cell << ", first_id: " << secondFirstId << ", count: " << perWorker << R"(, max_steps: 20000, load_steps: 20}
couplings:
  - {name: cells, kind: gmh, fem: block, workers: [cells_a, cells_b])" << couplingExtra << R"(}
output: {dir: )" << (dir_ / "run").string() << "}\n";
    return path.string();
  }

  /// scene() with four elements, cell 2 started from the other packing
  /// (unit_cells.weakened names any cell file).
  std::string sceneWithTwoPackings(int coarseSteps, const std::string& couplingExtra) const {
    std::string text;
    {
      std::ifstream in(scene(coarseSteps, "2", couplingExtra, 4));
      text.assign(std::istreambuf_iterator<char>(in), {});
    }
    const std::string b = "first_id: 2, count: 2, max_steps: 20000, load_steps: 20";
    text.replace(text.find(b), b.size(), b + ", weakened: {file: " + (cellDir_ / "other.ckpt").string() + ", ids: [2]}");
    std::ofstream(dir_ / "gmh.yaml") << text;
    return (dir_ / "gmh.yaml").string();
  }

  /// Runs the scene at `path` whole into run/ with a checkpoint every `interval`
  /// exchanges, copies it to cut/ with only the checkpoint of exchange
  /// `interval`, and resumes cut/ from there; returns the resumed run.
  Finished runWholeAndResumed(const std::string& path, int interval) const {
    std::string text;
    {
      std::ifstream in(path);
      text.assign(std::istreambuf_iterator<char>(in), {});
    }
    const std::string out = "output: {dir: " + (dir_ / "run").string() + "}";
    text.replace(text.find(out), out.size(),
                 "output: {dir: " + (dir_ / "run").string() + ", checkpoint_interval: " + std::to_string(interval) + "}");
    std::ofstream(dir_ / "gmh.yaml") << text;
    const auto whole = run({binary("coupler"), "run", (dir_ / "gmh.yaml").string(), "--no-progress"}, 120.0);
    EXPECT_EQ(whole.code, 0) << whole.out << whole.err;
    fs::copy(dir_ / "run", dir_ / "cut", fs::copy_options::recursive);
    std::size_t kept = 0;
    for (const auto& e : fs::directory_iterator(dir_ / "cut" / "checkpoints"))
      if (e.path().filename() != "exchange-" + std::to_string(interval)) fs::remove_all(e.path());
      else ++kept;
    EXPECT_EQ(kept, 1u);
    return run({binary("coupler"), "run", (dir_ / "gmh.yaml").string(), "--resume", "--out", (dir_ / "cut").string(),
                "--no-progress"},
               120.0);
  }

  /// This run's worker cells_b, once it runs (-1 after `tries` x 50 ms). Its
  /// own: its endpoint lies in this test's directory, and other GmhRun tests
  /// beside it under ctest -j have a cells_b too (killing theirs left this
  /// run going for its million steps until the wait gave up).
  pid_t waitForWorkerB(int tries = 200) const {
    for (int i = 0; i < tries; ++i) {
      const auto ours = processesMentioning(dir_.string());
      for (pid_t p : processesMentioning("--name cells_b"))
        if (std::find(ours.begin(), ours.end(), p) != ours.end()) return p;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return -1;
  }

  static inline fs::path cellDir_;
  fs::path dir_;
};

TEST_F(GmhRun, CompressionRaisesThePressureOfEveryCell) {
  const auto f = run({binary("coupler"), "run", scene(20), "--no-progress"}, 120.0);
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  auto h5 = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5");
  const auto pressure = h5.readArray("/series/cells/mean_pressure");
  const auto jobs = h5.readArray("/series/cells/jobs");
  ASSERT_EQ(pressure.size(), 21u);  // the prepared cells at setup, then one gather per coarse step
  EXPECT_NEAR(pressure.front(), 416e3, 0.02 * 416e3);
  for (std::size_t k = 1; k < pressure.size(); ++k) EXPECT_GT(pressure[k], pressure[k - 1]) << "step " << k;
  // 20 steps of 1e-3 m/s on 0.01 m: 4e-5 axial strain raises the mean stress by
  // (K + 4G/3) 4e-5 / 3, between 2 and 30 kPa for any plausible packing.
  EXPECT_GT(pressure.back() - pressure.front(), 2e3);
  EXPECT_LT(pressure.back() - pressure.front(), 30e3);
  for (std::size_t k = 1; k < jobs.size(); ++k) EXPECT_EQ(jobs[k], 2.0);
  // Per-cell series: one row per gather, columns in cell id order; their means
  // are the pool means, and each cell's own pressure rises every step.
  EXPECT_EQ(h5.shape("/series/cells/cell_ids"), (std::vector<std::size_t>{21, 2}));
  EXPECT_EQ(h5.shape("/series/cells/cell_porosity"), (std::vector<std::size_t>{21, 2}));
  EXPECT_EQ(h5.shape("/series/cells/cell_coordination"), (std::vector<std::size_t>{21, 2}));
  EXPECT_EQ(h5.shape("/series/cells/cell_stress"), (std::vector<std::size_t>{21, 18}));
  const auto ids = h5.readArray("/series/cells/cell_ids");
  const auto porosity = h5.readArray("/series/cells/cell_porosity");
  const auto coordination = h5.readArray("/series/cells/cell_coordination");
  const auto stress = h5.readArray("/series/cells/cell_stress");
  const auto meanPorosity = h5.readArray("/series/cells/mean_porosity");
  const auto meanCoordination = h5.readArray("/series/cells/mean_coordination");
  const auto cellPressure = [&](std::size_t row, std::size_t c) {
    const double* sigma = &stress[18 * row + 9 * c];
    return -(sigma[0] + sigma[4] + sigma[8]) / 3.0;
  };
  for (std::size_t k = 0; k < pressure.size(); ++k) {
    EXPECT_EQ(ids[2 * k], 0.0);
    EXPECT_EQ(ids[2 * k + 1], 1.0);
    EXPECT_NEAR(0.5 * (porosity[2 * k] + porosity[2 * k + 1]), meanPorosity[k], 1e-15);
    EXPECT_NEAR(0.5 * (coordination[2 * k] + coordination[2 * k + 1]), meanCoordination[k], 1e-12);
    EXPECT_NEAR(0.5 * (cellPressure(k, 0) + cellPressure(k, 1)), pressure[k], 1e-9 * pressure[k]);
    EXPECT_GT(porosity[2 * k], 0.2);
    EXPECT_LT(porosity[2 * k], 0.5);
    EXPECT_GT(coordination[2 * k + 1], 3.0);
    if (k == 0) continue;
    for (std::size_t c = 0; c < 2; ++c) EXPECT_GT(cellPressure(k, c), cellPressure(k - 1, c)) << "cell " << c << " step " << k;
  }
  // The time-step relation of Liu Eqs. 63-66 in the run report.
  std::ifstream in(dir_ / "run" / "run_report.json");
  const auto figures = nlohmann::json::parse(in)["figures"];
  const double fine = figures["fine_critical_dt_s"], coarse = figures["coarse_critical_dt_s"];
  EXPECT_GT(fine, 1e-9);
  EXPECT_LT(fine, 1e-5);  // contacts of a 0.5 mm grain: far below the coarse step
  EXPECT_GT(figures["fine_dt_over_critical"].get<double>(), 0.0);
  EXPECT_LT(figures["fine_dt_over_critical"].get<double>(), 1.0);  // the cells relax stably
  EXPECT_EQ(figures["coarse_dt_s"].get<double>(), 2.0e-5);
  EXPECT_NEAR(figures["coarse_dt_over_critical"].get<double>(), 2.0e-5 / coarse, 1e-12);
  EXPECT_NEAR(figures["time_step_ratio_alpha"].get<double>(), coarse / fine, 1e-9 * coarse / fine);
  EXPECT_GT(figures["fine_damping_fraction"].get<double>(), 0.0);
  EXPECT_EQ(figures["answered_cell_jobs"].get<double>(), 40.0);  // 2 cells x 20 coarse steps, each once
}

std::vector<double> failedCellsSeries(const fs::path& run) {
  return io::H5File::openReadOnly(run / "coupler.h5").readArray("/series/cells/failed_cells");
}

TEST_F(GmhRun, FailedCellsStopTheRunOrAreAcceptedAndReported) {
  // A relaxation tolerance no job can meet within 5 steps: every loaded job fails.
  const std::string path = scene(4);
  std::vector<std::string> strict;
  for (const char* w : {"cells_a", "cells_b"})
    for (const char* kv : {"tolerance=1.0e-9", "max_steps=5"})
      strict.insert(strict.end(), {"--set", std::string("solvers.") + w + ".params.unit_cells." + kv});
  // on_failure: stop (the default): the first coarse step stops the run naming the cells.
  std::vector<std::string> args{binary("coupler"), "run", path, "--no-progress"};
  args.insert(args.end(), strict.begin(), strict.end());
  const auto stopped = run(args, 120.0);
  EXPECT_NE(stopped.code, 0);
  // Both workers fail; whichever answers first is named.
  const std::string stop = stopped.out + stopped.err;
  EXPECT_TRUE(stop.find("unit cells failed: cell 0: I_uf") != std::string::npos ||
              stop.find("unit cells failed: cell 1: I_uf") != std::string::npos)
      << stop;
  // on_failure: continue: the run completes, each failure is counted per step
  // and in the report, and the log names the cells with their numbers.
  for (const char* w : {"cells_a", "cells_b"})
    args.insert(args.end(), {"--set", std::string("solvers.") + w + ".params.unit_cells.on_failure=continue"});
  const auto f = run(args, 120.0);
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  const std::string log = f.out + f.err;
  for (const char* cell : {"unit cell 0 failed its job", "unit cell 1 failed its job"})
    EXPECT_NE(log.find(cell), std::string::npos) << log;
  EXPECT_NE(log.find("I_uf"), std::string::npos) << log;
  EXPECT_EQ(failedCellsSeries(dir_ / "run"), (std::vector<double>{0, 2, 2, 2, 2}));
  std::ifstream in(dir_ / "run" / "run_report.json");
  const auto report = nlohmann::json::parse(in);
  EXPECT_EQ(report["figures"]["failed_cell_jobs"].get<double>(), 8.0);
  EXPECT_EQ(report["figures"]["failed_cells"].get<double>(), 2.0);
  bool warned = false;
  for (const auto& w : report["warnings"]) warned = warned || w.get<std::string>().find("8 unit-cell jobs of 2 cells") != std::string::npos;
  EXPECT_TRUE(warned) << report["warnings"].dump();
  // Resumed from a checkpoint after the second coarse step, the report counts
  // what the uninterrupted run counted: the checkpoint carries the counts, and
  // its replies, replayed, are not counted again.
  std::string text;
  {
    std::ifstream scene(path);
    text.assign(std::istreambuf_iterator<char>(scene), {});
  }
  const std::string out = "output: {dir: " + (dir_ / "run").string() + "}";
  text.replace(text.find(out), out.size(), "output: {dir: " + (dir_ / "run").string() + ", checkpoint_interval: 4}");
  std::ofstream(path) << text;
  ASSERT_EQ(run(args, 120.0).code, 0);
  // Every resume below starts from exchange 4 (a resumed run adds later checkpoints).
  const auto keepOnlyExchange4 = [&] {
    for (const auto& e : fs::directory_iterator(dir_ / "run" / "checkpoints"))
      if (e.path().filename() != "exchange-4") fs::remove_all(e.path());
  };
  keepOnlyExchange4();
  args.push_back("--resume");
  const auto resumed = run(args, 120.0);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  std::ifstream again(dir_ / "run" / "run_report.json");
  const auto after = nlohmann::json::parse(again);
  EXPECT_EQ(after["resumed_from"]["exchange"].get<std::uint64_t>(), 4u);
  EXPECT_EQ(after["figures"]["failed_cell_jobs"].get<double>(), 8.0);
  EXPECT_EQ(after["figures"]["failed_cells"].get<double>(), 2.0);
  EXPECT_EQ(failedCellsSeries(dir_ / "run"), (std::vector<double>{0, 2, 2, 2, 2}));
  // A checkpoint without the counts (an older coupler's) still resumes; the
  // report then counts from the resume and says so.
  const fs::path counts = dir_ / "run" / "checkpoints" / "exchange-4" / "couplings.bin";
  ASSERT_TRUE(fs::exists(counts));
  fs::remove(counts);
  keepOnlyExchange4();
  const auto older = run(args, 120.0);
  ASSERT_EQ(older.code, 0) << older.out << older.err;
  std::ifstream third(dir_ / "run" / "run_report.json");
  const auto fromResume = nlohmann::json::parse(third);
  EXPECT_EQ(fromResume["figures"]["failed_cell_jobs"].get<double>(), 4.0);
  bool said = false;
  for (const auto& w : fromResume["warnings"])
    said = said || w.get<std::string>().find("after the resume only") != std::string::npos;
  EXPECT_TRUE(said) << fromResume["warnings"].dump();
  // A corrupt count is refused naming the file.
  keepOnlyExchange4();
  std::ofstream(counts, std::ios::binary) << "not a record";
  const auto corrupt = run(args, 120.0);
  EXPECT_NE(corrupt.code, 0);
  EXPECT_NE((corrupt.out + corrupt.err).find("couplings.bin"), std::string::npos) << corrupt.out << corrupt.err;
}

TEST_F(GmhRun, AResumedRunContinuesBitForBit) {
  // A checkpoint between FEM's predict and correct (its split step, the
  // workers' cells, the coupling's owners) and the coupler's series, whose
  // per-cell rows come once per coarse step, not once per exchange.
  const auto resumed = runWholeAndResumed(scene(10), 8);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  EXPECT_NE(resumed.err.find("resuming from exchange 8"), std::string::npos) << resumed.err;
  auto a = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5");
  auto b = io::H5File::openReadOnly(dir_ / "cut" / "coupler.h5");
  for (const std::string series : {"time", "exchange", "block/energy/kinetic", "block/energy/strain", "cells/jobs",
                                   "cells/mean_pressure", "cells/cell_stress", "cells/cell_porosity",
                                   "cells/max_relaxation_steps"}) {
    const auto x = a.readArray("/series/" + series), y = b.readArray("/series/" + series);
    ASSERT_EQ(x.size(), y.size()) << series;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(double))) << series;
  }
  EXPECT_EQ(a.readArray("/series/cells/mean_pressure").size(), 11u);
  // The report says where the run resumed, since its times cover only what followed.
  std::ifstream in(dir_ / "cut" / "run_report.json");
  const auto report = nlohmann::json::parse(in);
  EXPECT_EQ(report["resumed_from"]["exchange"].get<std::uint64_t>(), 8u);
  EXPECT_GT(report["resumed_from"]["time_s"].get<double>(), 0.0);
  EXPECT_NE(resumed.out.find("resumed       from exchange 8"), std::string::npos) << resumed.out;
  std::ifstream whole_in(dir_ / "run" / "run_report.json");
  const auto whole = nlohmann::json::parse(whole_in);
  EXPECT_FALSE(whole.contains("resumed_from"));
  // The report's figures (Liu's time-step relation over the whole run among
  // them) are the uninterrupted run's.
  EXPECT_EQ(report["figures"], whole["figures"]);
  EXPECT_EQ(report["errors"], whole["errors"]);
}

TEST_F(GmhRun, NonlocalIncrementsOfAUniformCompressionAreTheLocalOnes) {
  // Both element centres (0.01 m apart) lie within R = 0.015 m of each other:
  // each cell gets the bell-weighted mean of two equal increments (Liu Eq. 58).
  const auto local = run({binary("coupler"), "run", scene(10), "--no-progress"}, 120.0);
  ASSERT_EQ(local.code, 0) << local.out << local.err;
  const auto localPressure = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5").readArray("/series/cells/mean_pressure");
  const auto f = run({binary("coupler"), "run", scene(10, "1", ", nonlocal: {radius: 0.015}"), "--no-progress"}, 120.0);
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  EXPECT_NE((f.out + f.err).find("nonlocal operator over 2 points, R = 0.015000 m, 2.000000 neighbours"),
            std::string::npos) << f.out << f.err;
  const auto pressure = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5").readArray("/series/cells/mean_pressure");
  ASSERT_EQ(pressure.size(), localPressure.size());
  for (std::size_t k = 0; k < pressure.size(); ++k) EXPECT_NEAR(pressure[k], localPressure[k], 1e-6 * localPressure[k]);
  EXPECT_GT(pressure.back(), pressure.front());
}

TEST_F(GmhRun, AnIndefiniteNonlocalOperatorStopsTheRunWithTheLocalFractionItNeeds) {
  // Six points in a row, h = 0.01 m, R = 2h: the bell weights form the
  // tridiagonal W = tri(0.5625, 1, 0.5625), whose lowest eigenvalue is
  // 1 + 1.125 cos(6 pi / 7) = -0.0136 < 0 (A = D^-1 W has the same signs).
  const auto refused = run({binary("coupler"), "run", scene(5, "3", ", nonlocal: {radius: 0.02}", 6), "--no-progress"},
                           120.0);
  EXPECT_NE(refused.code, 0);
  const auto said = refused.out + refused.err;
  EXPECT_NE(said.find("nonlocal operator over 6 points (couplings[0].nonlocal.radius = 0.020000 m, local_fraction "
                      "= 0.000000) has the eigenvalue -0.0"),
            std::string::npos) << said;
  EXPECT_NE(said.find("Set couplings[0].nonlocal.local_fraction to at least 0.0065"), std::string::npos) << said;
  // The blend the message suggests lifts it: the run goes through.
  const auto blended = run({binary("coupler"), "run", scene(5, "3", ", nonlocal: {radius: 0.02, local_fraction: 0.15}", 6),
                            "--no-progress"},
                           120.0);
  ASSERT_EQ(blended.code, 0) << blended.out << blended.err;
  std::ifstream in(dir_ / "run" / "run_report.json");
  const auto figures = nlohmann::json::parse(in)["figures"];
  EXPECT_EQ(figures["nonlocal_local_fraction"].get<double>(), 0.15);
  EXPECT_GT(figures["nonlocal_smallest_eigenvalue"].get<double>(), 0.05);
}

TEST_F(GmhRun, CheckRefusesANonPositiveNonlocalRadius) {
  const auto f = run({binary("coupler"), "check", scene(5, "1", ", nonlocal: {radius: 0}")}, 30.0);
  EXPECT_EQ(f.code, 2);
  EXPECT_NE((f.out + f.err).find("radius"), std::string::npos) << f.out << f.err;
  for (const std::string beta : {"1", "-0.1"}) {
    const auto b = run({binary("coupler"), "check", scene(5, "1", ", nonlocal: {radius: 0.015, local_fraction: " + beta + "}")},
                       30.0);
    EXPECT_EQ(b.code, 2) << beta;
    EXPECT_NE((b.out + b.err).find("local_fraction"), std::string::npos) << b.out << b.err;
  }
}

TEST_F(GmhRun, AveragingTheInelasticStressHandsFemTheCellsDifference) {
  // Four elements in a row 0.01 m apart, R = 0.015 m: the bell weight to a
  // face neighbour is w = (1 - (0.01/0.015)^2)^2. Every cell gets the same
  // strain, so C : eps cancels, and s_I - <s>_I depends on the stress changes
  // D_I = sigma_I - sigma_I0 alone: cells 0, 1, 3 share a packing (D_A), cell 2
  // has the other (D_B). With D = D_B - D_A the corrections are 0 (cell 0,
  // whose only neighbour is its own packing), m w D / (1 + 2w) (cell 1),
  // -2 m w D / (1 + 2w) (cell 2) and m w D / (1 + w) (cell 3, one neighbour).
  const double m = 2.0, w = std::pow(1.0 - (0.01 / 0.015) * (0.01 / 0.015), 2);
  const auto path = sceneWithTwoPackings(10, ", nonlocal: {radius: 0.015, averages: inelastic_stress, over_nonlocal: 2, "
                                             "stiffness: {E: 3.0e8, nu: 0.15}}");
  const auto checked = run({binary("coupler"), "check", path}, 30.0);
  ASSERT_EQ(checked.code, 0) << checked.out << checked.err;
  EXPECT_NE(checked.out.find("nonlocal inelastic stress, bell kernel, R = 0.015 m, over-nonlocal factor 2"),
            std::string::npos) << checked.out;
  const auto f = run({binary("coupler"), "run", path, "--no-progress"}, 120.0);
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  auto h5 = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5");
  const auto stress = h5.readArray("/series/cells/cell_stress");  // rows: setup, then one per coarse step
  const auto rms = h5.readArray("/series/cells/inelastic_correction_rms");  // one per coarse step
  ASSERT_EQ(stress.size(), 11u * 36u);
  ASSERT_EQ(rms.size(), 10u);
  double largest = 0.0;
  for (std::size_t k = 0; k < rms.size(); ++k) {
    const double* now = &stress[36 * (k + 1)];
    double sum = 0.0;
    for (std::size_t c = 0; c < 9; ++c) {
      // cell 2 against cell 1 (same strain, the two packings)
      const double d = (now[18 + c] - stress[18 + c]) - (now[9 + c] - stress[9 + c]);
      sum += d * d;
      // cells 0, 1 and 3 are the same packing under the same strain: the same stress
      EXPECT_NEAR(now[c], now[9 + c], 1e-9 * 416e3);
      EXPECT_NEAR(now[27 + c], now[9 + c], 1e-9 * 416e3);
    }
    const double inner = w / (1.0 + 2.0 * w), end = w / (1.0 + w);
    EXPECT_NEAR(rms[k], m * std::sqrt(sum) * std::sqrt((5.0 * inner * inner + end * end) / 4.0), 1e-6 * 416e3)
        << "step " << k + 1;
    largest = std::max(largest, rms[k]);
  }
  EXPECT_GT(largest, 10.0);  // the two packings do answer differently
  std::ifstream in(dir_ / "run" / "run_report.json");
  const auto figures = nlohmann::json::parse(in)["figures"];
  EXPECT_EQ(figures["nonlocal_over_nonlocal"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(figures["nonlocal_max_inelastic_correction_rms_pa"].get<double>(), largest);
}

TEST_F(GmhRun, AResumedInelasticStressRunContinuesBitForBit) {
  // The cells' strains and reference stresses travel with the checkpoint; the
  // replayed replies of the resume count nothing twice. Exchange 7 is a
  // coarse half: the resumed run's first answers are to jobs sent before.
  const auto resumed = runWholeAndResumed(sceneWithTwoPackings(10, ", nonlocal: {radius: 0.015, averages: "
                                                                   "inelastic_stress, stiffness: {E: 3.0e8, nu: 0.15}}"),
                                          7);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  auto a = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5");
  auto b = io::H5File::openReadOnly(dir_ / "cut" / "coupler.h5");
  for (const std::string series : {"cells/cell_stress", "cells/inelastic_correction_rms", "block/energy/strain"}) {
    const auto x = a.readArray("/series/" + series), y = b.readArray("/series/" + series);
    ASSERT_EQ(x.size(), y.size()) << series;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(double))) << series;
  }
}

TEST_F(GmhRun, CheckNamesBadInelasticStressKeys) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"averages: inelastic_stress", "stiffness"},
      {"averages: inelastic_stress, local_fraction: 0.1, stiffness: {E: 3.0e8, nu: 0.15}", "local_fraction"},
      {"averages: inelastic_stress, stiffness: {E: 3.0e8, nu: 0.5}", "stiffness.nu"},
      {"averages: inelastic_stress, stiffness: {E: 0, nu: 0.2}", "stiffness.E"},
      {"averages: inelastic_stress, over_nonlocal: 0, stiffness: {E: 3.0e8, nu: 0.2}", "over_nonlocal"},
      {"averages: stress", "averages"},
      {"over_nonlocal: 2", "over_nonlocal"}};
  for (const auto& [keys, named] : cases) {
    const auto f = run({binary("coupler"), "check", scene(5, "1", ", nonlocal: {radius: 0.015, " + keys + "}")}, 30.0);
    EXPECT_EQ(f.code, 2) << keys;
    EXPECT_NE((f.out + f.err).find("couplings[0].nonlocal." + named), std::string::npos) << keys << "\n" << f.out << f.err;
  }
}

TEST_F(GmhRun, OverlappingWorkersAreRefused) {
  const auto f = run({binary("coupler"), "run", scene(5, "0"), "--no-progress"}, 60.0);
  EXPECT_NE(f.code, 0);
  EXPECT_NE(f.err.find("unit cell 0 is held by both 'cells_a' and 'cells_b'"), std::string::npos) << f.err;
}

TEST_F(GmhRun, ALostWorkerStopsTheRunNamingItsCells) {
  Subprocess coupler({binary("coupler"), "run", scene(1000000), "--no-progress"});
  const pid_t victim = waitForWorkerB();
  ASSERT_GT(victim, 0) << "worker cells_b never started";
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(victim, SIGKILL);
  const int code = coupler.wait(60.0);
  EXPECT_EQ(code, 4) << coupler.err();
  EXPECT_NE(coupler.err().find("worker 'cells_b' held unit cells 1"), std::string::npos) << coupler.err();
}

/// The pool's and FEM's series of two runs, compared to the bit (the lost
/// worker's own series end where it was lost).
void expectSamePoolSeries(const fs::path& a, const fs::path& b) {
  auto x = io::H5File::openReadOnly(a / "coupler.h5");
  auto y = io::H5File::openReadOnly(b / "coupler.h5");
  for (const std::string series : {"time", "exchange", "block/energy/kinetic", "block/energy/strain",
                                   "block/energy/external_work", "cells/jobs", "cells/mean_pressure",
                                   "cells/cell_ids", "cells/cell_stress", "cells/cell_porosity",
                                   "cells/cell_coordination", "cells/max_relaxation_steps"}) {
    const auto u = x.readArray("/series/" + series), v = y.readArray("/series/" + series);
    ASSERT_EQ(u.size(), v.size()) << series;
    EXPECT_EQ(0, std::memcmp(u.data(), v.data(), u.size() * sizeof(double))) << series;
  }
}

nlohmann::json reportOf(const fs::path& runDir) {
  std::ifstream in(runDir / "run_report.json");
  return nlohmann::json::parse(in);
}

TEST_F(GmhRun, APoolEntryRunsItsWorkersAsTheSameWorkersDeclaredOneByOne) {
  // Four cells: cells_a holds 0-1 and cells_b 2-3; the pool entry's two
  // workers cells-0 and cells-1 hold 0, 2 and 1, 3. Each cell's results are
  // its own, gathered in FEM's order: the series are the same to the bit.
  const std::string path = scene(40, "2", "", 4);
  std::string text;
  {
    std::ifstream in(path);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  const auto explicitRun = run({binary("coupler"), "run", path, "--out", (dir_ / "explicit").string(), "--no-progress"}, 120.0);
  ASSERT_EQ(explicitRun.code, 0) << explicitRun.out << explicitRun.err;
  replace("fine: [cells_a, cells_b]", "fine: [cells]");
  replace("workers: [cells_a, cells_b]", "workers: [cells]");
  const auto first = text.find("  - name: cells_a"), end = text.find("couplings:");
  text.replace(first, end - first,
               "  - name: cells\n    kind: dem\n    pool: {workers: 2}\n    params:\n      unit_cells: {file: " +
                   (cellDir_ / "cell.ckpt").string() + ", count: 4, max_steps: 20000, load_steps: 20}\n");
  std::ofstream(dir_ / "pool.yaml") << text;
  const auto pooled =
      run({binary("coupler"), "run", (dir_ / "pool.yaml").string(), "--out", (dir_ / "pool").string(), "--no-progress"}, 120.0);
  ASSERT_EQ(pooled.code, 0) << pooled.out << pooled.err;
  expectSamePoolSeries(dir_ / "explicit", dir_ / "pool");
  EXPECT_EQ(reportOf(dir_ / "pool")["figures"]["answered_cell_jobs"], reportOf(dir_ / "explicit")["figures"]["answered_cell_jobs"]);
  // Each worker set up its own share of the entry's cells.
  const auto check = run({binary("coupler"), "check", (dir_ / "pool.yaml").string()}, 60.0);
  EXPECT_EQ(check.code, 0) << check.out << check.err;
  EXPECT_NE(check.out.find("setup memory (peak resident size of each solver's check): block "), std::string::npos)
      << check.out;
  EXPECT_NE(check.out.find("; pool cells 2 workers, "), std::string::npos) << check.out;
}

TEST_F(GmhRun, ALostWorkersCellsMoveToTheOtherAndTheResultsStayTheSame) {
  // Four cells on two workers, a checkpoint every 10 exchanges; cells_b is
  // SIGKILLed once the run is past its first checkpoint. Its two cells move
  // to cells_a from the latest checkpoint with their jobs since replayed,
  // and the run goes on to its end as if nothing had happened.
  const std::string path = scene(300, "2", ", on_worker_loss: move", 4);
  std::string text;
  {
    std::ifstream in(path);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto withOutput = [&](const std::string& dir) {
    std::string t = text;
    const std::string out = "output: {dir: " + (dir_ / "run").string() + "}";
    t.replace(t.find(out), out.size(), "output: {dir: " + (dir_ / dir).string() + ", checkpoint_interval: 10}");
    const auto file = dir_ / (dir + ".yaml");
    std::ofstream(file) << t;
    return file.string();
  };
  const auto whole = run({binary("coupler"), "run", withOutput("whole"), "--no-progress"}, 120.0);
  ASSERT_EQ(whole.code, 0) << whole.out << whole.err;

  Subprocess coupler({binary("coupler"), "run", withOutput("moved"), "--no-progress"});
  // Past the first checkpoint (only the latest two are kept: any one will do).
  const auto checkpointed = [&] {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_ / "moved" / "checkpoints", ec))
      if (e.path().filename().string().rfind("exchange-", 0) == 0) return true;
    return false;
  };
  for (int i = 0; i < 1200 && !checkpointed(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  const pid_t victim = waitForWorkerB(1);
  ASSERT_GT(victim, 0) << "worker cells_b never started, or the run ended before its first checkpoint";
  ::kill(victim, SIGKILL);
  ASSERT_EQ(coupler.wait(120.0), 0) << coupler.err();
  EXPECT_NE(coupler.err().find("worker 'cells_b' lost"), std::string::npos) << coupler.err();
  EXPECT_NE(coupler.err().find("its 2 unit cells moved from the checkpoint of exchange"), std::string::npos)
      << coupler.err();
  expectSamePoolSeries(dir_ / "whole", dir_ / "moved");
  const auto moved = reportOf(dir_ / "moved"), reference = reportOf(dir_ / "whole");
  EXPECT_EQ(moved["figures"]["answered_cell_jobs"], reference["figures"]["answered_cell_jobs"]);
  EXPECT_EQ(moved["figures"]["moved_unit_cells"].get<double>(), 2.0);
  EXPECT_EQ(moved["figures"]["lost_workers"].get<double>(), 1.0);
  EXPECT_EQ(reference["figures"]["lost_workers"].get<double>(), 0.0);

  // Resumed from its last checkpoint, taken after the move: cells_b is not
  // started again, cells_a restores all four cells, and the results are still
  // the undisturbed run's.
  fs::path latest;
  for (const auto& e : fs::directory_iterator(dir_ / "moved" / "checkpoints"))
    if (e.path().filename().string().rfind("exchange-", 0) == 0 && (latest.empty() || e.path() > latest)) latest = e.path();
  ASSERT_TRUE(fs::exists(latest / "lost_solvers.txt")) << latest;
  const auto resumed = run({binary("coupler"), "run", withOutput("moved"), "--resume", "--no-progress"}, 120.0);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  EXPECT_EQ(resumed.err.find("cells_b"), std::string::npos) << resumed.err;
  expectSamePoolSeries(dir_ / "whole", dir_ / "moved");
}

TEST_F(GmhRun, ALostWorkerBeforeTheFirstCheckpointStopsTheRunSayingWhy) {
  Subprocess coupler({binary("coupler"), "run", scene(1000000, "1", ", on_worker_loss: move"), "--no-progress"});
  const pid_t victim = waitForWorkerB();
  ASSERT_GT(victim, 0) << "worker cells_b never started";
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ::kill(victim, SIGKILL);
  EXPECT_EQ(coupler.wait(60.0), 4) << coupler.err();
  EXPECT_NE(coupler.err().find("no checkpoint has been taken yet (output.checkpoint_interval)"), std::string::npos)
      << coupler.err();
}

}  // namespace
}  // namespace cosim::testing
