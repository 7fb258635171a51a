// GMH unit cells (Liu, Sun, Fish 2016 Sec. 2.3): preparation to an isotropic
// pressure, unit-cell jobs (zero and compressive increments), a cell that
// cannot relax within its budget, and a worker with two cells restored from a
// checkpoint. One small cell is prepared once for the whole suite.
#include <capnp/message.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cosim/dem/cell/unit_cell.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/solver/dem_solver.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::dem {
namespace {

namespace fs = std::filesystem;

constexpr double kPressure = 416e3;

class DemUnitCell : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    CellPreparation prep;
    prep.count = 150;
    prep.seed = 3;
    prep.pressure = kPressure;
    prep.progressEvery = 20000;
    prep.progress = [](long steps, double pressure, double index) {
      progress_.push_back({static_cast<double>(steps), pressure, index});
    };
    cell_ = std::make_unique<DemSystem>(prepareUnitCell(prep, &log_));
    dir_ = fs::temp_directory_path() / ("cosim_unit_cell_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    saveUnitCell(*cell_, (dir_ / "cell").string(), log_.dt);
  }
  static void TearDownTestSuite() {
    cell_.reset();
    fs::remove_all(dir_);
  }
  static RelaxSettings relaxSettings() {
    RelaxSettings r;
    r.dt = log_.dt;
    r.tolerance = 0.01;
    r.maxSteps = 200000;
    return r;
  }
  static std::unique_ptr<DemSystem> cell_;
  static PreparationLog log_;
  static std::vector<std::array<double, 3>> progress_;  // steps, mean stress, I_uf as the servo reported them
  static fs::path dir_;
};
std::unique_ptr<DemSystem> DemUnitCell::cell_;
PreparationLog DemUnitCell::log_;
std::vector<std::array<double, 3>> DemUnitCell::progress_;
fs::path DemUnitCell::dir_;

std::string workerScene(const std::string& file, const std::string& extra) {
  return "scene: {name: t}\nsolvers:\n  - name: cells\n    kind: dem\n    params:\n      unit_cells: {file: " + file +
         ", count: 2" + extra + "}\n";
}

// Runs one advance carrying one UnitCellJobs list; returns the reply's results.
struct Exchange {
  capnp::MallocMessageBuilder inMsg, outMsg;
  proto::UnitCellResults::Reader run(DemSolver& s, const std::vector<std::uint32_t>& ids,
                                     const std::vector<double>& increments) {
    auto inputs = inMsg.initRoot<proto::CouplingData>();
    auto jobs = inputs.initUnitCellJobs(1)[0];
    jobs.setDt(1e-6);
    auto i = wire::view(jobs.initCellIds(static_cast<unsigned>(ids.size())));
    auto e = wire::view(jobs.initStrainIncrements(static_cast<unsigned>(increments.size())));
    std::copy(ids.begin(), ids.end(), i.begin());
    std::copy(increments.begin(), increments.end(), e.begin());
    wire::AdvanceRequest r;
    r.steps = 1;
    r.dt = 1e-6;
    r.inputs = inputs.asReader();
    auto out = outMsg.initRoot<proto::CouplingData>();
    s.advance(r, out);
    return out.asReader().getUnitCellResults()[0];
  }
};

void setupWorker(DemSolver& s, const std::string& yaml) {
  capnp::MallocMessageBuilder in, out;
  wire::SetupContext c{"cells.yaml", yaml, "cells", "", in.initRoot<proto::CouplingData>().asReader()};
  s.setup(c, out.initRoot<proto::CouplingData>());
}

std::vector<double> isotropic(double e) { return {e, 0, 0, 0, e, 0, 0, 0, e}; }

TEST_F(DemUnitCell, PreparationReachesTargetPressureWithin2Percent) {
  const CellMeasures m = measureCell(*cell_);
  std::printf("prepared 150 spheres: dt %.3e s, %ld + %ld steps, porosity %.4f, Z %.3f, I_uf %.2e, "
              "sigma diag [%.5g %.5g %.5g], off-diag [%.3g %.3g %.3g] Pa\n",
              log_.dt, log_.compressionSteps, log_.frictionSteps, m.porosity, m.coordination, m.unbalancedForceIndex,
              m.stress[0], m.stress[4], m.stress[8], m.stress[1], m.stress[2], m.stress[5]);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const double target = a == b ? -kPressure : 0.0;
      EXPECT_NEAR(m.stress[static_cast<std::size_t>(3 * a + b)], target, 0.02 * kPressure) << a << b;
    }
  EXPECT_LT(m.unbalancedForceIndex, 0.01);
  EXPECT_GT(m.coordination, 4.0);                          // jammed frictional skeleton
  EXPECT_TRUE(m.porosity > 0.30 && m.porosity < 0.42) << m.porosity;  // dense random packing
  // Friction is switched on at the end: the material carries mu = 0.5.
  EXPECT_EQ(cell_->materials.pair(0, 0).friction, 0.5);
  // The servo reported its progress about every 20000 steps of the compression.
  ASSERT_GE(progress_.size(), static_cast<std::size_t>(log_.compressionSteps / 20000 - 1)) << log_.compressionSteps;
  ASSERT_GE(progress_.size(), 2u);
  for (std::size_t k = 1; k < progress_.size(); ++k) {
    if (progress_[k][0] > progress_[k - 1][0]) {
      EXPECT_GE(progress_[k][0] - progress_[k - 1][0], 20000.0);
    }
  }
  for (const auto& r : progress_) EXPECT_TRUE(std::isfinite(r[1]) && r[1] >= 0.0 && r[1] < 10.0 * kPressure) << r[1];
}

TEST_F(DemUnitCell, ZeroIncrementReturnsPreparedStress) {
  DemSystem c = cloneCell(*cell_);
  const CellMeasures before = measureCell(c);
  const JobOutcome o = runUnitCellJob(c, {}, relaxSettings());
  std::printf("zero increment: %ld steps, I_uf %.2e, max |d sigma| / p = ", o.steps, o.measures.unbalancedForceIndex);
  double worst = 0.0;
  for (std::size_t k = 0; k < 9; ++k) worst = std::max(worst, std::fabs(o.measures.stress[k] - before.stress[k]));
  std::printf("%.2e\n", worst / kPressure);
  EXPECT_TRUE(o.problem().empty()) << o.problem();
  EXPECT_LT(worst, 0.005 * kPressure);
  EXPECT_EQ(o.measures.porosity, before.porosity);  // the cell did not move
}

TEST_F(DemUnitCell, IsotropicCompressionRaisesMeanStress) {
  DemSystem c = cloneCell(*cell_);
  const CellMeasures before = measureCell(c);
  const auto inc = isotropic(-1e-4);
  std::array<double, 9> d{};
  std::copy(inc.begin(), inc.end(), d.begin());
  const JobOutcome o = runUnitCellJob(c, d, relaxSettings());
  const double dp = o.measures.pressure - before.pressure;
  std::printf("volumetric strain -3e-4: mean stress %.5g -> %.5g Pa, secant K = %.4g MPa, %ld steps\n",
              -before.pressure, -o.measures.pressure, dp / 3e-4 / 1e6, o.steps);
  EXPECT_TRUE(o.problem().empty()) << o.problem();
  // Hertz contacts: K of order 100 MPa..1 GPa at 416 kPa, so dp of order 30..300 kPa.
  EXPECT_GT(dp, 0.05 * kPressure);
  EXPECT_LT(dp, 1.0 * kPressure);
  EXPECT_LT(o.measures.porosity, before.porosity);
}

TEST_F(DemUnitCell, ServoTakesOverWhenTheCellLosesItsPressure) {
  // Stretch the prepared cell by 3 % so every contact opens, as when a
  // packing at the edge of jamming collapses at fixed volume.
  DemSystem c = cloneCell(*cell_);
  RelaxSettings stretch = relaxSettings();
  stretch.maxSteps = 10;
  runUnitCellJob(c, [] {
    std::array<double, 9> d{};
    d[0] = d[4] = d[8] = 0.03;
    return d;
  }(), stretch);
  ASSERT_LT(measureCell(c).pressure, 0.01 * kPressure);
  CellPreparation prep;
  prep.pressure = kPressure;
  // The relaxation hands back after one slice instead of spending the budget.
  const long relaxed = relaxWhileLoaded(c, log_.dt, prep, 200000);
  EXPECT_LE(relaxed, 5000);
  // And the servo brings the unloaded cell back to the target.
  prep.maxSteps = 400000;
  const long steps = servoToPressure(c, log_.dt, prep);
  const CellMeasures m = measureCell(c);
  std::printf("stretched cell back to %.5g Pa in %ld steps (relaxation handed back after %ld)\n", m.pressure, steps,
              relaxed);
  EXPECT_NEAR(m.pressure, kPressure, 0.02 * kPressure);
  EXPECT_LT(m.unbalancedForceIndex, 0.01);
}

TEST(DemUnitCellPreparation, ProgressIntervalMustBePositive) {
  // With a callback, a zero interval would report forever at one step count.
  CellPreparation prep;
  prep.count = 20;
  prep.progressEvery = 0;
  prep.progress = [](long, double, double) {};
  try {
    prepareUnitCell(prep);
    FAIL() << "a zero progress interval was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("progress interval must be positive"), std::string::npos) << e.what();
  }
}

TEST_F(DemUnitCell, CellThatCannotRelaxIsReportedWithItsId) {
  DemSolver s;
  setupWorker(s, workerScene((dir_ / "cell.ckpt").string(), ", max_steps: 10, load_steps: 10, tolerance: 1.0e-6"));
  ASSERT_NE(s.unitCells(), nullptr);
  EXPECT_EQ(s.unitCells()->size(), 2u);
  Exchange x;
  try {
    x.run(s, {1}, isotropic(-1e-3));
    FAIL() << "a cell over its relaxation budget was accepted";
  } catch (const wire::SolverError& e) {
    const std::string msg = e.what();
    std::printf("reported: %s\n", msg.c_str());
    EXPECT_EQ(e.code(), proto::Error::Code::SOLVER_FAILURE);
    EXPECT_NE(msg.find("cell 1:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("I_uf"), std::string::npos) << msg;
    EXPECT_EQ(msg.find("cell 0"), std::string::npos) << msg;  // only the failing cell
  }
  // An id the worker does not hold is bad input naming the id.
  try {
    x.run(s, {7}, isotropic(0.0));
    FAIL() << "unknown cell id accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
    EXPECT_NE(std::string(e.what()).find("cell 7"), std::string::npos) << e.what();
  }
}

TEST_F(DemUnitCell, OnFailureContinueReturnsTheFailedCellFlagged) {
  // The same failing job as above, with on_failure: continue: the advance
  // answers, cell 1's result is flagged failed with its unrelaxed I_uf and
  // its stress as it stands, cell 0 (no load, relaxed) is not flagged; the
  // setting survives a checkpoint; any other value is refused naming the key.
  const std::string file = (dir_ / "cell.ckpt").string();
  const std::string extra = ", max_steps: 10, load_steps: 10, tolerance: 0.01, on_failure: continue";
  DemSolver s;
  setupWorker(s, workerScene(file, extra));
  const std::string ckpt = (dir_ / "continue.ckpt").string();
  ASSERT_GT(s.checkpoint(ckpt), 0u);
  std::vector<double> inc = isotropic(0.0);
  const std::vector<double> squeeze = isotropic(-1e-3);
  inc.insert(inc.end(), squeeze.begin(), squeeze.end());
  auto check = [&](DemSolver& solver, const char* which) {
    Exchange x;
    const auto r = x.run(solver, {0, 1}, inc);
    ASSERT_EQ(r.getFailed().size(), 2u) << which;
    EXPECT_FALSE(r.getFailed()[0]) << which;
    EXPECT_TRUE(r.getFailed()[1]) << which;
    EXPECT_GT(r.getUnbalancedForceIndices()[1], 0.01) << which;
    EXPECT_EQ(r.getRelaxationSteps()[1], 20u) << which;  // 10 load steps + the budget
    const auto sig = wire::view(r.getStresses());
    EXPECT_LT((sig[9] + sig[13] + sig[17]) / 3, -1.2 * kPressure) << which;  // compressed: the stress as it stands
  };
  check(s, "as set up");
  DemSolver restored;
  restored.restore(ckpt);
  check(restored, "restored");
  // A job that succeeds carries no flags (an empty list: none failed).
  DemSolver ok;
  setupWorker(ok, workerScene(file, ", on_failure: continue"));
  Exchange x;
  EXPECT_EQ(x.run(ok, {0}, isotropic(0.0)).getFailed().size(), 0u);
  DemSolver bad;
  try {
    setupWorker(bad, workerScene(file, ", on_failure: ignore"));
    ADD_FAILURE() << "on_failure: ignore accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
    EXPECT_NE(std::string(e.what()).find("unit_cells.on_failure: expected stop"), std::string::npos) << e.what();
  }
}

TEST_F(DemUnitCell, StressFreeExitEndsTheJobOfAnUnloadedCellOnly) {
  // Cell 0 expanded by 2 % per axis: every contact opens, it carries no
  // stress and can never relax (no contacts, no I_uf). With the exit its job
  // ends at the probe (45 steps, rounded up to the I_uf checks of 10), failed;
  // without, it spends the budget. Cell 1, compressed, keeps its load: the
  // exit leaves its job bitwise as it was. The setting survives a checkpoint.
  const std::string file = (dir_ / "cell.ckpt").string();
  const std::string base = ", max_steps: 3000, load_steps: 10, on_failure: continue";
  DemSolver with, without;
  setupWorker(with, workerScene(file, base + ", stress_free_exit: {pressure: 400, after: 45}"));
  setupWorker(without, workerScene(file, base));
  const std::string ckpt = (dir_ / "stress_free.ckpt").string();
  ASSERT_GT(with.checkpoint(ckpt), 0u);
  DemSolver restored;
  restored.restore(ckpt);
  std::vector<double> inc = isotropic(2e-2);
  const std::vector<double> squeeze = isotropic(-1e-3);
  inc.insert(inc.end(), squeeze.begin(), squeeze.end());
  Exchange b;
  const auto full = b.run(without, {0, 1}, inc);
  ASSERT_EQ(full.getFailed().size(), 2u);
  EXPECT_TRUE(full.getFailed()[0]);
  EXPECT_EQ(full.getRelaxationSteps()[0], 3010u);
  for (DemSolver* s : {&with, &restored}) {
    Exchange a;
    const auto r = a.run(*s, {0, 1}, inc);
    ASSERT_EQ(r.getFailed().size(), 2u);
    EXPECT_TRUE(r.getFailed()[0]);
    EXPECT_FALSE(r.getFailed()[1]);
    EXPECT_EQ(r.getRelaxationSteps()[0], 60u);  // 10 load steps + 50
    const auto sig = wire::view(r.getStresses()), ref = wire::view(full.getStresses());
    EXPECT_LT(std::abs(sig[0] + sig[4] + sig[8]) / 3, 400.0);
    EXPECT_GT(r.getRelaxationSteps()[1], 60u);  // cell 1 relaxed past the probe
    EXPECT_EQ(r.getRelaxationSteps()[1], full.getRelaxationSteps()[1]);
    EXPECT_EQ(0, std::memcmp(&sig[9], &ref[9], 9 * sizeof(double)));
  }
  // The job's report says why it ended early.
  DemSystem lone = cloneCell(*cell_);
  RelaxSettings set = relaxSettings();
  set.maxSteps = 3000;
  set.loadSteps = 10;
  set.stressFreePressure = 400.0;
  set.stressFreeAfter = 200;
  const JobOutcome o = runUnitCellJob(lone, {2e-2, 0, 0, 0, 2e-2, 0, 0, 0, 2e-2}, set);
  EXPECT_TRUE(o.endedStressFree);
  EXPECT_NE(o.problem().find("ended early, stress-free"), std::string::npos) << o.problem();
  // Bad settings name the key.
  auto refused = [&](const std::string& extra) {
    DemSolver bad;
    try {
      setupWorker(bad, workerScene(file, extra));
    } catch (const wire::SolverError& e) {
      EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused(", stress_free_exit: {pressure: 0}").find("stress_free_exit.pressure"), std::string::npos);
  EXPECT_NE(refused(", stress_free_exit: {pressure: 400, after: 0}").find("stress_free_exit.after: must be at least 1"),
            std::string::npos);
  EXPECT_NE(refused(", stress_free_exit: {pressure: 400, when: 3}").find("unknown key 'when'"), std::string::npos);
}

TEST_F(DemUnitCell, WorkerLoadsWeakenedCellAndRefusesBadParams) {
  const DemSystem weak = weakenedCell(*cell_, 5, 11, log_.dt, 0.01, 200000);
  saveUnitCell(weak, (dir_ / "weak").string(), log_.dt);
  DemSolver s;
  setupWorker(s, workerScene((dir_ / "cell.ckpt").string(),
                             ", weakened: {file: " + (dir_ / "weak.ckpt").string() + ", ids: [1]}"));
  EXPECT_EQ(s.unitCells()->cell(0).particles.size(), 150u);
  EXPECT_EQ(s.unitCells()->cell(1).particles.size(), 145u);
  Exchange x;
  const auto r = x.run(s, {0, 1}, std::vector<double>(18, 0.0));
  const auto sig = wire::view(r.getStresses());
  std::printf("weakened cell (5 of 150 removed): porosity %.4f vs %.4f, mean stress %.4g vs %.4g Pa\n",
              r.getPorosities()[1], r.getPorosities()[0], (sig[9] + sig[13] + sig[17]) / 3, (sig[0] + sig[4] + sig[8]) / 3);
  EXPECT_GT(r.getPorosities()[1], r.getPorosities()[0]);
  // Bad params name the scene file, line and key.
  auto refused = [](const std::string& yaml) {
    DemSolver bad;
    try {
      setupWorker(bad, yaml);
    } catch (const wire::SolverError& e) {
      EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string file = (dir_ / "cell.ckpt").string();
  EXPECT_NE(refused(workerScene(file, ", tolerence: 0.01")).find("cells.yaml:6: params.unit_cells: unknown key 'tolerence'"),
            std::string::npos);
  EXPECT_NE(refused(workerScene(file, ", max_steps: 0")).find("unit_cells.max_steps: must be at least 1"), std::string::npos);
  EXPECT_NE(refused(workerScene((dir_ / "missing.ckpt").string(), "")).find("unit_cells.file"), std::string::npos);
  EXPECT_NE(refused(workerScene(file, ", weakened: {file: " + file + ", ids: [9]}")).find("cell id 9"), std::string::npos);
  // A worker holds only cells: other params keys are refused.
  EXPECT_NE(refused(workerScene(file, "}\n      gravity: [0, 0, 0]\n      x: {a: 1")).find("unknown key 'gravity'"),
            std::string::npos);
}

TEST_F(DemUnitCell, VariantsAreChosenByCellIdAlone) {
  // variants: [weak] (145 of the 150 spheres): each cell starts from one of
  // the two files, picked by its id, so both occur among 8 cells and a worker
  // holding the odd ids (stride 2) starts each from the same file as a worker
  // holding all 8; a bad entry is refused naming its index.
  const DemSystem weak = weakenedCell(*cell_, 5, 11, log_.dt, 0.01, 200000);
  saveUnitCell(weak, (dir_ / "variant").string(), log_.dt);
  const std::string file = (dir_ / "cell.ckpt").string(), variant = (dir_ / "variant.ckpt").string();
  auto scene = [&](const std::string& extra, const std::string& variants) {
    return "scene: {name: t}\nsolvers:\n  - name: cells\n    kind: dem\n    params:\n      unit_cells: {file: " + file +
           ", variants: [" + variants + "]" + extra + "}\n";
  };
  DemSolver all, odd;
  setupWorker(all, scene(", count: 8", variant));
  setupWorker(odd, scene(", first_id: 1, stride: 2, count: 4", variant));
  std::size_t fromVariant = 0;
  for (std::uint32_t id = 0; id < 8; ++id) {
    const std::size_t n = all.unitCells()->cell(id).particles.size();
    EXPECT_TRUE(n == 150u || n == 145u) << "cell " << id << ": " << n;
    fromVariant += n == 145u;
    if (id % 2 == 1) {
      EXPECT_EQ(odd.unitCells()->cell(id).particles.size(), n) << "cell " << id;
    }
  }
  std::printf("cells from the variant: %zu of 8\n", fromVariant);
  EXPECT_GT(fromVariant, 0u);
  EXPECT_LT(fromVariant, 8u);
  DemSolver bad;
  try {
    setupWorker(bad, scene("", variant + ", " + (dir_ / "none.ckpt").string()));
    ADD_FAILURE() << "a missing variant file was accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
    EXPECT_NE(std::string(e.what()).find("params.unit_cells.variants[1]: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("none.ckpt"), std::string::npos) << e.what();
  }
}

TEST_F(DemUnitCell, StrideInterleavesTheCellsOfTwoWorkers) {
  // first_id 1, stride 2, count 2: this worker holds the odd cells 1 and 3
  // (its partner first_id 0 the even ones), so a band over a row of ids loads both.
  const std::string file = (dir_ / "cell.ckpt").string();
  DemSolver s;
  setupWorker(s, workerScene(file, ", first_id: 1, stride: 2, weakened: {file: " + file + ", ids: [3]}"));
  ASSERT_EQ(s.unitCells()->size(), 2u);
  EXPECT_EQ(s.unitCells()->cell(1).particles.size(), 150u);
  EXPECT_EQ(s.unitCells()->cell(3).particles.size(), 150u);
  EXPECT_THROW(s.unitCells()->cell(2), wire::SolverError);
  for (const std::string& bad : {std::string(", stride: 0"), ", first_id: 1, stride: 2, weakened: {file: " + file + ", ids: [2]}"}) {
    DemSolver refused;
    try {
      setupWorker(refused, workerScene(file, bad));
      ADD_FAILURE() << "accepted " << bad;
    } catch (const wire::SolverError& e) {
      EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
      const std::string msg = e.what();
      EXPECT_TRUE(msg.find("unit_cells.stride: must be at least 1") != std::string::npos ||
                  msg.find("cell id 2 is not among this worker's cells") != std::string::npos)
          << msg;
    }
  }
}

/// Sets up `s` as worker `index` of a pool of `size` workers of entry "cells" in `yaml`.
void setupPoolWorker(DemSolver& s, const std::string& yaml, std::uint32_t index, std::uint32_t size) {
  capnp::MallocMessageBuilder in, out;
  wire::SetupContext c{"cells.yaml", yaml, "cells-" + std::to_string(index), "", in.initRoot<proto::CouplingData>().asReader()};
  c.poolEntry = "cells";
  c.poolIndex = index;
  c.poolSize = size;
  s.setup(c, out.initRoot<proto::CouplingData>());
}

TEST_F(DemUnitCell, APoolsWorkersShareTheEntrysCellsEachOnce) {
  // The entry's 7 cells 1, 3, .., 13 (first_id 1, stride 2) over 3 workers:
  // worker k takes the entry's cells k, k + 3, k + 6.
  const std::string file = (dir_ / "cell.ckpt").string();
  const std::string yaml = "scene: {name: t}\nsolvers:\n  - name: cells\n    kind: dem\n    pool: {workers: 3}\n"
                           "    params:\n      unit_cells: {file: " + file + ", count: 7, first_id: 1, stride: 2, "
                           "weakened: {file: " + file + ", ids: [11]}}\n";
  const std::vector<std::vector<std::uint32_t>> expected{{1, 7, 13}, {3, 9}, {5, 11}};
  for (std::uint32_t k = 0; k < 3; ++k) {
    DemSolver w;
    setupPoolWorker(w, yaml, k, 3);
    EXPECT_EQ(w.unitCells()->ids(), expected[k]) << "worker " << k;
  }
  // More workers than cells: refused, naming the count.
  DemSolver refused;
  try {
    setupPoolWorker(refused, yaml, 0, 8);
    ADD_FAILURE() << "8 workers for 7 cells accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("unit_cells.count: the pool's 8 workers share 7 cells"), std::string::npos)
        << e.what();
  }
}

TEST_F(DemUnitCell, WorkerWithTwoCellsRestoresBitForBit) {
  const std::string yaml = workerScene((dir_ / "cell.ckpt").string(), ", max_steps: 50000");
  DemSolver a;
  setupWorker(a, yaml);
  Exchange first;
  // Different histories per cell: compression in cell 0, shear in cell 1.
  std::vector<double> inc = isotropic(-5e-5);
  const std::vector<double> shear{0, 2e-4, 0, 2e-4, 0, 0, 0, 0, 0};
  inc.insert(inc.end(), shear.begin(), shear.end());
  first.run(a, {0, 1}, inc);
  const std::string ckpt = (dir_ / "worker.ckpt").string();
  ASSERT_GT(a.checkpoint(ckpt), 0u);
  const std::vector<double> next{0, 0, 1e-4, 0, 0, 0, 1e-4, 0, -5e-5, 1e-4, 0, 0, 0, -1e-4, 0, 0, 0, 0};
  Exchange ra, rb;
  const auto expected = ra.run(a, {0, 1}, next);
  DemSolver b;
  b.restore(ckpt);
  ASSERT_NE(b.unitCells(), nullptr);
  EXPECT_EQ(b.time(), a.time() - 1e-6);
  const auto got = rb.run(b, {0, 1}, next);
  const auto se = wire::view(expected.getStresses()), sg = wire::view(got.getStresses());
  ASSERT_EQ(se.size(), 18u);
  ASSERT_EQ(sg.size(), 18u);
  for (std::size_t k = 0; k < 18; ++k) EXPECT_EQ(se[k], sg[k]) << k;
  for (unsigned c = 0; c < 2; ++c) {
    EXPECT_EQ(expected.getRelaxationSteps()[c], got.getRelaxationSteps()[c]);
    EXPECT_EQ(expected.getPorosities()[c], got.getPorosities()[c]);
    EXPECT_EQ(expected.getCoordinationNumbers()[c], got.getCoordinationNumbers()[c]);
  }
  // The two cells were driven differently, so their states differ.
  EXPECT_NE(se[1], sg[10]);
  std::printf("restored worker: cell 0 sigma_33 %.6g Pa (%u steps), cell 1 sigma_12 %.6g Pa (%u steps)\n", sg[8],
              got.getRelaxationSteps()[0], sg[10], got.getRelaxationSteps()[1]);
}

/// An AdoptCells request: cells from `path`, with one jobs list per entry of `jobs`.
struct Adoption {
  capnp::MallocMessageBuilder msg, out;
  proto::CouplingData::Reader adopt(DemSolver& s, const std::string& path, const std::vector<std::uint32_t>& ids,
                                    const std::vector<std::pair<std::vector<std::uint32_t>, std::vector<double>>>& jobs) {
    auto r = msg.initRoot<proto::AdoptCells>();
    r.setPath(path);
    auto i = wire::view(r.initCellIds(static_cast<unsigned>(ids.size())));
    std::copy(ids.begin(), ids.end(), i.begin());
    auto lists = r.initJobs(static_cast<unsigned>(jobs.size()));
    for (unsigned k = 0; k < jobs.size(); ++k) {
      lists[k].setDt(1e-6);
      auto c = wire::view(lists[k].initCellIds(static_cast<unsigned>(jobs[k].first.size())));
      auto e = wire::view(lists[k].initStrainIncrements(static_cast<unsigned>(jobs[k].second.size())));
      std::copy(jobs[k].first.begin(), jobs[k].first.end(), c.begin());
      std::copy(jobs[k].second.begin(), jobs[k].second.end(), e.begin());
    }
    auto outputs = out.initRoot<proto::CouplingData>();
    s.adoptCells(r.asReader(), outputs);
    return outputs.asReader();
  }
};

TEST_F(DemUnitCell, AdoptedCellsAnswerAsTheirLostWorkerWould) {
  // Worker a holds cells 0 and 1 and checkpoints; two more jobs follow. Worker
  // b (cells 2 and 3, the same settings) adopts cell 1 from a's checkpoint
  // with those two jobs: its answer to the second is a's, to the bit, and
  // from then on b answers cell 1 as a does.
  const std::string cell = (dir_ / "cell.ckpt").string();
  DemSolver a, b;
  setupWorker(a, workerScene(cell, ", max_steps: 50000"));
  setupWorker(b, workerScene(cell, ", first_id: 2, max_steps: 50000"));
  const std::string ckpt = (dir_ / "a.ckpt").string();
  ASSERT_GT(a.checkpoint(ckpt), 0u);
  const std::vector<double> first = isotropic(-5e-5), second{0, 2e-4, 0, 2e-4, 0, 0, 0, 0, 0}, third = isotropic(3e-5);
  Exchange x1, x2, x3, y3;
  x1.run(a, {1}, first);
  const auto expected = x2.run(a, {1}, second);
  Adoption adoption;
  const auto got = adoption.adopt(b, ckpt, {1}, {{{1}, first}, {{1}, second}}).getUnitCellResults()[0];
  ASSERT_EQ(got.getCellIds().size(), 1u);
  EXPECT_EQ(got.getCellIds()[0], 1u);
  const auto se = wire::view(expected.getStresses()), sg = wire::view(got.getStresses());
  for (std::size_t k = 0; k < 9; ++k) EXPECT_EQ(se[k], sg[k]) << k;
  EXPECT_EQ(expected.getRelaxationSteps()[0], got.getRelaxationSteps()[0]);
  EXPECT_EQ(expected.getPorosities()[0], got.getPorosities()[0]);
  ASSERT_EQ(b.unitCells()->size(), 3u);
  const auto next = x3.run(a, {1}, third), nextOnB = y3.run(b, {1}, third);
  for (std::size_t k = 0; k < 9; ++k) EXPECT_EQ(next.getStresses()[static_cast<unsigned>(k)], nextOnB.getStresses()[static_cast<unsigned>(k)]);
  // b's checkpoint holds the adopted cell: a worker restored from it answers it too.
  const std::string bckpt = (dir_ / "b.ckpt").string();
  ASSERT_GT(b.checkpoint(bckpt), 0u);
  DemSolver c;
  c.restore(bckpt);
  EXPECT_EQ(c.unitCells()->size(), 3u);
}

TEST_F(DemUnitCell, AdoptionIsRefusedNamingWhatIsWrong) {
  const std::string cell = (dir_ / "cell.ckpt").string();
  DemSolver a, b, other;
  setupWorker(a, workerScene(cell, ""));
  setupWorker(b, workerScene(cell, ", first_id: 2"));
  setupWorker(other, workerScene(cell, ", first_id: 4, tolerance: 0.02"));
  const std::string ckpt = (dir_ / "a.ckpt").string();
  ASSERT_GT(a.checkpoint(ckpt), 0u);
  const auto refused = [&](DemSolver& s, const std::string& path, const std::vector<std::uint32_t>& ids,
                           const std::vector<std::pair<std::vector<std::uint32_t>, std::vector<double>>>& jobs,
                           const std::string& expected) {
    Adoption x;
    try {
      x.adopt(s, path, ids, jobs);
      ADD_FAILURE() << "accepted: " << expected;
    } catch (const wire::SolverError& e) {
      EXPECT_EQ(e.code(), proto::Error::Code::BAD_INPUT);
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  refused(other, ckpt, {0}, {}, "other unit_cells settings");
  refused(b, ckpt, {2}, {}, "holds unit cell 2 already");
  refused(b, ckpt, {5}, {}, "the checkpoint holds no unit cell 5");
  refused(b, ckpt, {0}, {{{1}, isotropic(0.0)}}, "a replayed job names unit cell 1");
  refused(b, (dir_ / "missing.ckpt").string(), {0}, {}, "missing.ckpt");
  EXPECT_EQ(b.unitCells()->size(), 2u);  // nothing half adopted
}

}  // namespace
}  // namespace cosim::dem
