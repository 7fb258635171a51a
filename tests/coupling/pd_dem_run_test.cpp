// tests/coupling/pd_dem_short.yaml through the real coupler, pd_solver and
// dem_solver: a driven DEM sphere pressed 0.5 mm into a small LPS block.
// Action = reaction: at every exchange the hybrid forces DEM returns to PD sum
// to minus the (interval-mean) force on the sphere, to round-off, under
// lockstep and under multirate with either solver fine (Hartmann Alg. 2, both
// cases) and either staggering order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "cosim/io/h5_file.hpp"
#include "subprocess.hpp"

namespace cosim::testing {
namespace {

struct PdDemRun {
  std::filesystem::path dir = freshDirectory("pd_dem");
  /// Runs the scene with its schedule line replaced (empty: as written).
  Finished run(const std::string& schedule = "", const std::vector<std::string>& sets = {},
               const std::string& analysis = "") {
    std::ifstream in(sourcePath("tests/coupling/pd_dem_short.yaml"));
    std::stringstream text;
    text << in.rdbuf();
    std::string s = text.str();
    if (!schedule.empty()) {
      const auto at = s.find("schedule: {");
      s.replace(at, s.find('\n', at) - at, "schedule: " + schedule);
    }
    if (!analysis.empty()) {
      const auto at = s.find("analysis: {");
      if (analysis == "none") s.erase(at, s.find('\n', at) + 1 - at);  // no reference solution
      else s.replace(at, s.find('\n', at) - at, "analysis: " + analysis);
    }
    const auto scene = dir / "scene.yaml";
    std::ofstream(scene) << s;
    std::vector<std::string> argv{binary("coupler"), "run", scene.string(), "--out", (dir / "run").string(),
                                  "--no-progress"};
    for (const auto& set : sets) argv.insert(argv.end(), {"--set", set});
    return cosim::testing::run(argv, 50.0);
  }
  nlohmann::json report() const {
    std::ifstream in(dir / "run" / "run_report.json");
    return nlohmann::json::parse(in);
  }
  /// Rows of (depth, force on sphere, minus sum of hybrid forces, Hertz), z components.
  std::vector<double> series() const {
    auto h5 = io::H5File::openReadOnly(dir / "run" / "coupler.h5");
    return h5.readArray("/series/analysis/depth_force_pd_hertz");
  }
};

/// DEM's energies on the series rows: fresh in every schedule (a sequential
/// schedule's rows fall on the other solver's half; the coupler then asks
/// DEM one exchange ahead), and balanced: the driven sphere's and the hybrid
/// particles' prescribed motion does the work the contacts store.
void checkDemEnergies(const PdDemRun& r, const std::string& label) {
  auto h5 = io::H5File::openReadOnly(r.dir / "run" / "coupler.h5");
  auto at = [&](const char* name) { return h5.readArray(std::string("/series/spheres/energy/") + name); };
  const auto kinetic = at("kinetic"), elastic = at("elastic"), potential = at("potential"), lost = at("dissipated"),
             work = at("external_work");
  ASSERT_GT(work.size(), 10u) << label;
  double largest = 0.0, worst = 0.0;
  std::size_t changed = 0;
  for (std::size_t k = 0; k < work.size(); ++k) {
    const double stored = kinetic[k] + elastic[k] + potential[k] + lost[k];
    const double stored0 = kinetic[0] + elastic[0] + potential[0] + lost[0];
    largest = std::max({largest, std::abs(work[k]), std::abs(stored)});
    worst = std::max(worst, std::abs(stored - stored0 - (work[k] - work[0])));
    if (k > 0 && elastic[k] != elastic[k - 1]) ++changed;
  }
  EXPECT_GT(changed, work.size() / 4) << label << ": DEM's energies were not asked for on the rows";
  EXPECT_GT(work.back(), 0.0) << label;
  std::printf("[dem balance] %s: work %.4e J, worst gap %.2e of the largest energy\n", label.c_str(), work.back(),
              worst / largest);
  EXPECT_LT(worst, 0.05 * largest) << label;
}

/// Checks action = reaction on every row and returns the force at the deepest row.
double checkBalance(const PdDemRun& r) {
  const auto rows = r.series();
  EXPECT_GT(rows.size(), 4u * 50);
  double deepest = 0.0, force = 0.0;
  std::size_t loaded = 0;
  for (std::size_t k = 0; k + 3 < rows.size(); k += 4) {
    EXPECT_NEAR(rows[k + 1], rows[k + 2], 1e-9 * (1.0 + std::abs(rows[k + 1]))) << "row " << k / 4;
    if (rows[k + 1] > 0.0) ++loaded;
    if (rows[k] > deepest) deepest = rows[k], force = rows[k + 1];
  }
  EXPECT_GT(loaded, 20u);  // the sphere was in contact for a while
  EXPECT_GT(deepest, 4e-4);
  return force;
}

TEST(PdDemContactRun, SpherePressedIntoABlockGetsEqualAndOppositeForces) {
  PdDemRun r;
  const auto done = r.run();
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  const auto report = r.report();
  EXPECT_EQ(report["errors"][0]["name"], "max_relative_force_error");
  EXPECT_LT(report["figures"]["action_reaction_residual"].get<double>(), 1e-12);
  const double force = checkBalance(r);
  // Hertz at the deepest row (0.5 mm): 4/3 E* sqrt(0.02) d^1.5 = 226.6 N; a block of
  // 4 layers with a lattice surface is softer: ask only for the right order of magnitude.
  EXPECT_GT(force, 0.3 * 226.6);
  EXPECT_LT(force, 1.5 * 226.6);
  // The force at 0.4 mm against Hertz (measured -26 %, docs/pd_dem_coupling.md).
  EXPECT_LT(report["errors"][0]["value"].get<double>(), 0.4);
  // The three origins of d: the block's top face (z = 0.04), the highest hybrid
  // top (0.035 + R_h) and first contact, which lies between them on this lattice.
  const auto& fig = report["figures"];
  const double rh = std::cbrt(3.0 * 1e-6 / (4.0 * std::numbers::pi));
  EXPECT_NEAR(fig["body_surface_z_m"].get<double>(), 0.04, 1e-12);
  EXPECT_NEAR(fig["hybrid_top_z_m"].get<double>(), 0.035 + rh, 1e-9);
  EXPECT_GT(fig["first_contact_z_m"].get<double>(), 0.04);
  EXPECT_LT(fig["first_contact_z_m"].get<double>(), 0.035 + rh);
  // The same target depth from a lower origin puts the sphere deeper: more force
  // against the same Hertz value.
  const double fromSurface = fig["relative_error_at_0.4mm_from_surface"].get<double>();
  const double fromFirst = fig["relative_error_at_0.4mm_from_first-contact"].get<double>();
  EXPECT_EQ(fromFirst, fig["relative_error_at_0.4mm"].get<double>());  // the default origin
  EXPECT_GT(fromSurface, fromFirst);
  // The sphere starts 0.87 mm below the hybrid top: no exchange at 0.4 mm from it.
  EXPECT_FALSE(fig.contains("relative_error_at_0.4mm_from_hybrid-top"));
}

TEST(PdDemContactRun, TheSurfaceOriginDrivesTheMainFiguresAndAnUnknownOriginIsRefused) {
  const std::string analysis = "{reference: hertz-indentation, pd: block, dem: spheres, young: 1.0e8, "
                               "poisson: 0.25, depths: [0.0004], window: 0.0002, origin: ";
  {
    PdDemRun r;
    const auto done = r.run("", {}, analysis + "surface}");
    ASSERT_EQ(done.code, 0) << done.out << done.err;
    const auto report = r.report();
    const auto& fig = report["figures"];
    EXPECT_EQ(fig["relative_error_at_0.4mm"].get<double>(), fig["relative_error_at_0.4mm_from_surface"].get<double>());
    // The series' depth column is measured from the face: it starts above it, negative.
    EXPECT_LT(r.series()[0], 0.0);
  }
  PdDemRun r;
  const auto done = r.run("", {}, analysis + "middle}");
  EXPECT_EQ(done.code, 2);
  EXPECT_NE((done.out + done.err).find("origin"), std::string::npos) << done.out << done.err;
  EXPECT_NE((done.out + done.err).find("scene.yaml:"), std::string::npos) << done.out << done.err;
}

TEST(PdDemContactRun, MultirateBothWaysRoundAndStaggeredOrdersBalanceToo) {
  double lockstep = 0.0;
  {
    PdDemRun r;
    ASSERT_EQ(r.run().code, 0);
    lockstep = r.report()["figures"]["force_at_0.4mm_N"].get<double>();
  }
  // dt_PD >= dt_DEM (DEM fine) and dt_PD < dt_DEM (PD fine), fine-first and coarse-first.
  for (const std::string schedule :
       {"{kind: multirate, fine: spheres, dt: 1.0e-5, ratio: 2, order: fine-first, end_time: 8.0e-3}",
        "{kind: multirate, fine: block, dt: 1.0e-5, ratio: 4, order: coarse-first, end_time: 8.0e-3}",
        "{kind: multirate, fine: spheres, dt: 2.0e-5, ratio: 1, order: parallel, end_time: 8.0e-3}"}) {
    PdDemRun r;
    // Rows every 2 exchanges: in the sequential schedules all on one solver's half.
    const auto done = r.run(schedule, {"output.series_every=2"});
    ASSERT_EQ(done.code, 0) << schedule << "\n" << done.out << done.err;
    checkBalance(r);
    const double f = r.report()["figures"]["force_at_0.4mm_N"].get<double>();
    EXPECT_NEAR(f, lockstep, 0.1 * lockstep) << schedule;
    checkDemEnergies(r, schedule);
  }
}

// The hybrid watch (pddem.capnp): PD sends DEM the states of the hybrids
// near something only. It must leave every contact force as it was: the
// coupled series agree bit for bit with watch_margin: 0 (every state every
// exchange), in the monolithic Verlet schedule and with PD sub-cycling, and
// far fewer bytes reach DEM (measured: 0.39 MB against 3.65 MB, and 0.21
// against 1.83 MB sub-cycled).
TEST(PdDemContactRun, TheHybridWatchLeavesEveryForceAsItWasWithFewerBytes) {
  const std::vector<std::string> series{"/series/analysis/depth_force_pd_hertz", "/series/contact/hybrid_force",
                                        "/series/contact/loaded_particles",      "/series/block/energy/kinetic",
                                        "/series/block/energy/strain",           "/series/spheres/energy/elastic"};
  for (const std::string schedule :
       {"{kind: multirate, fine: block, dt: 2.0e-5, ratio: 1, order: coarse-first, end_time: 8.0e-3}",
        "{kind: multirate, fine: block, dt: 1.0e-5, ratio: 4, order: coarse-first, end_time: 8.0e-3}"}) {
    PdDemRun watched, every;
    const std::vector<std::string> verlet{"solvers.block.params.integrator=verlet"};
    auto done = watched.run(schedule, verlet);
    ASSERT_EQ(done.code, 0) << schedule << "\n" << done.out << done.err;
    auto all = verlet;
    all.push_back("solvers.spheres.params.hybrid.watch_margin=0");
    done = every.run(schedule, all);
    ASSERT_EQ(done.code, 0) << schedule << "\n" << done.out << done.err;
    auto a = io::H5File::openReadOnly(watched.dir / "run" / "coupler.h5");
    auto b = io::H5File::openReadOnly(every.dir / "run" / "coupler.h5");
    for (const auto& path : series) {
      const auto x = a.readArray(path), y = b.readArray(path);
      ASSERT_EQ(x.size(), y.size()) << path;
      ASSERT_GT(x.size(), 10u) << path;
      for (std::size_t k = 0; k < x.size(); ++k) ASSERT_EQ(x[k], y[k]) << schedule << " " << path << " row " << k;
    }
    checkBalance(watched);
    auto bytesToDem = [](const PdDemRun& r) {
      const auto report = r.report();
      for (const auto& p : report["peers"])
        if (p["name"] == "spheres") return p["bytes_sent"].get<double>();
      return 0.0;
    };
    std::printf("[hybrid watch] %s: %.0f bytes to DEM with the watch, %.0f without\n", schedule.c_str(),
                bytesToDem(watched), bytesToDem(every));
    EXPECT_LT(bytesToDem(watched), 0.5 * bytesToDem(every)) << schedule;
  }
}

// PD works ahead (Solver::workAhead: the next step's half kick, drift and
// bond forces while DEM evaluates the contact force) by default: every series
// of the run is bitwise that of a run with `work_ahead: false`.
TEST(PdDemContactRun, WorkingAheadLeavesEverySeriesAsItWas) {
  const std::string schedule =
      "{kind: multirate, fine: block, dt: 2.0e-5, ratio: 1, order: coarse-first, end_time: 8.0e-3}";
  PdDemRun ahead, plain;
  auto done = ahead.run(schedule, {"solvers.block.params.integrator=verlet"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  done = plain.run(schedule, {"solvers.block.params.integrator=verlet", "solvers.block.params.work_ahead=false"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  auto a = io::H5File::openReadOnly(ahead.dir / "run" / "coupler.h5");
  auto b = io::H5File::openReadOnly(plain.dir / "run" / "coupler.h5");
  for (const std::string path :
       {"/series/time", "/series/analysis/depth_force_pd_hertz", "/series/contact/hybrid_force",
        "/series/contact/loaded_particles", "/series/block/energy/strain", "/series/block/energy/kinetic",
        "/series/block/energy/external_work", "/series/spheres/energy/elastic", "/series/spheres/energy/kinetic"}) {
    const auto x = a.readArray(path), y = b.readArray(path);
    ASSERT_EQ(x.size(), y.size()) << path;
    ASSERT_GT(x.size(), 10u) << path;
    for (std::size_t k = 0; k < x.size(); ++k) ASSERT_EQ(x[k], y[k]) << path << " row " << k;
  }
  checkBalance(ahead);
  auto aheadOf = [](const PdDemRun& r) {
    const auto report = r.report();
    for (const auto& p : report["peers"])
      if (p["name"] == "block") return p["ahead_s"].get<double>();
    return -1.0;
  };
  EXPECT_GT(aheadOf(ahead), 0.0);
  EXPECT_EQ(aheadOf(plain), 0.0);
}

// Runs the short scene with `analysis` (empty: its Hertz one) and
// checkpoints, resumes a copy from the earlier of the two kept checkpoints,
// and compares the series (the analysis's own `series` among them) and the
// report's error and figures bit for bit;
// then removes the analysis state from another copy's checkpoint and expects
// the resume refused, naming the analysis `kind`.
void checkResume(const std::string& analysis, const std::string& kind, const std::string& series) {
  PdDemRun r;
  const std::string schedule =
      "{kind: multirate, fine: block, dt: 2.0e-5, ratio: 1, order: coarse-first, end_time: 8.0e-3}";
  const std::vector<std::string> sets{"solvers.block.params.integrator=verlet", "output.checkpoint_interval=100"};
  const auto done = r.run(schedule, sets, analysis);
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  namespace fs = std::filesystem;
  auto cutAt = [&](const fs::path& cut) { return cutBackToEarlierCheckpoint(r.dir / "run", cut); };
  auto resume = [&](const fs::path& cut) {
    std::vector<std::string> argv{binary("coupler"), "run", (r.dir / "scene.yaml").string(), "--resume", "--out",
                                  cut.string(), "--no-progress"};
    for (const auto& set : sets) argv.insert(argv.end(), {"--set", set});
    return run(argv, 50.0);
  };
  const auto cut = r.dir / "cut";
  const std::string from = cutAt(cut).filename().string().substr(9);
  const auto resumed = resume(cut);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  EXPECT_NE(resumed.err.find("resuming from exchange " + from), std::string::npos) << resumed.err;
  auto a = io::H5File::openReadOnly(r.dir / "run" / "coupler.h5");
  auto b = io::H5File::openReadOnly(cut / "coupler.h5");
  for (const std::string path : {"/series/time", "/series/contact/hybrid_force", "/series/contact/loaded_particles",
                                 "/series/block/energy/strain", "/series/block/energy/kinetic",
                                 "/series/spheres/energy/elastic", "/series/spheres/energy/kinetic", series.c_str()}) {
    const auto x = a.readArray(path), y = b.readArray(path);
    ASSERT_EQ(x.size(), y.size()) << path;
    for (std::size_t k = 0; k < x.size(); ++k) ASSERT_EQ(x[k], y[k]) << path << " row " << k;
  }
  // The error and every figure of the analysis, bit for bit.
  const auto whole = r.report();
  std::ifstream in(cut / "run_report.json");
  const auto part = nlohmann::json::parse(in);
  ASSERT_FALSE(whole["figures"].empty()) << kind;
  EXPECT_EQ(part["figures"], whole["figures"]) << kind;
  EXPECT_EQ(part["errors"], whole["errors"]) << kind;
  // A checkpoint without the analysis state is refused before anything starts.
  const auto old = r.dir / "old";
  fs::remove(cutAt(old) / "analysis.bin");
  const auto refused = resume(old);
  EXPECT_EQ(refused.code, 3) << refused.out << refused.err;
  EXPECT_NE(refused.err.find("holds no state of the analysis '" + kind + "'"), std::string::npos) << refused.err;
}

// A PD-DEM run resumed from a checkpoint continues bit for bit: DEM's
// checkpoint says which of its particles are PD's hybrids, so the set PD
// sends again drives them instead of being added a second time. The Hertz
// analysis continues from its checkpointed state (started afresh at the
// resume, it would lack PD's setup outputs).
TEST(PdDemContactRun, AResumedRunContinuesBitForBit) {
  checkResume("", "hertz-indentation", "/series/analysis/depth_force_pd_hertz");
}

// The force-displacement analysis (H2's) resumes with its record too.
TEST(PdDemContactRun, AResumedForceDisplacementRunReportsTheUninterruptedFigures) {
  checkResume("{reference: force-displacement, dem: spheres, zone: indenter, direction: [0, 0, -1]}",
              "force-displacement", "/series/analysis/force");
}

TEST(PdDemContactRun, LinearisedForcesRunAndAnUnknownTreatmentIsRefused) {
  double lockstep = 0.0;
  {
    PdDemRun r;
    ASSERT_EQ(r.run().code, 0);
    lockstep = r.report()["figures"]["force_at_0.4mm_N"].get<double>();
  }
  // PD sub-cycles 4 steps per DEM step, following each contact force with the
  // stiffness DEM sends (H2 at m = 6 needs this: held, it diverged).
  PdDemRun r;
  const auto done = r.run("{kind: multirate, fine: block, dt: 1.0e-5, ratio: 4, order: coarse-first, end_time: 8.0e-3}",
                          {"couplings.contact.forces=linearised"});
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  checkBalance(r);
  EXPECT_NEAR(r.report()["figures"]["force_at_0.4mm_N"].get<double>(), lockstep, 0.1 * lockstep);
  PdDemRun bad;
  const auto refused = bad.run("", {"couplings.contact.forces=interpolated"});
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE((refused.out + refused.err).find("forces"), std::string::npos) << refused.out << refused.err;
}

TEST(PdDemContactRun, CheckRefusesAMissingSolverName) {
  PdDemRun r;
  std::ifstream in(sourcePath("tests/coupling/pd_dem_short.yaml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  s.replace(s.find("pd: block, dem: spheres}"), 24, "pd: nobody, dem: spheres}");
  const auto scene = r.dir / "bad.yaml";
  std::ofstream(scene) << s;
  const auto done = run({binary("coupler"), "check", scene.string()}, 30.0);
  EXPECT_EQ(done.code, 2);
  EXPECT_NE((done.out + done.err).find("nobody"), std::string::npos) << done.out << done.err;
  EXPECT_NE((done.out + done.err).find("bad.yaml:"), std::string::npos) << done.out << done.err;
}

TEST(PdDemContactRun, HeldKinematicsRunsAndAnUnknownModeIsRefused) {
  PdDemRun r;
  std::ifstream in(sourcePath("tests/coupling/pd_dem_short.yaml"));
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  const auto at = s.find("dem: spheres}");
  std::string held = s, bad = s;
  held.replace(at, 13, "dem: spheres, kinematics: held}");
  bad.replace(at, 13, "dem: spheres, kinematics: frozen}");
  std::ofstream(r.dir / "held.yaml") << held;
  std::ofstream(r.dir / "bad.yaml") << bad;
  const auto refused = run({binary("coupler"), "check", (r.dir / "bad.yaml").string()}, 30.0);
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE((refused.out + refused.err).find("kinematics"), std::string::npos) << refused.out << refused.err;
  const auto done = run({binary("coupler"), "run", (r.dir / "held.yaml").string(), "--out", (r.dir / "run").string(),
                         "--no-progress"},
                        50.0);
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  // The sphere moves 0.1 m/s; hybrid particles barely move: the forces differ little from extrapolated ones.
  EXPECT_LT(r.report()["figures"]["action_reaction_residual"].get<double>(), 1e-12);
  checkBalance(r);
}

// Hartmann's extreme cases: each is refused at its first exchange with the
// limit it breaks, instead of running into a blast.
TEST(PdDemExtremeCases, ContactStiffnessTimes1e4IsRefusedNamingTheHybridStep) {
  PdDemRun r;
  const auto done = r.run("", {"solvers.spheres.params.materials[0].young=1.0e12",
                               "solvers.spheres.params.materials[1].young=1.0e12"});
  EXPECT_EQ(done.code, 4) << done.out << done.err;
  EXPECT_NE(done.err.find("above the critical step"), std::string::npos) << done.err;
  EXPECT_NE(done.err.find("hybrid PD particles' contacts"), std::string::npos) << done.err;
}

TEST(PdDemExtremeCases, FiftyPdStepsPerDemStepAreRefusedNamingTheHybridStep) {
  PdDemRun r;
  const auto done = r.run("{kind: multirate, fine: block, dt: 2.0e-5, ratio: 50, order: coarse-first, end_time: 8.0e-3}");
  EXPECT_EQ(done.code, 4) << done.out << done.err;
  EXPECT_NE(done.err.find("dt = 0.001 s is above the critical step"), std::string::npos) << done.err;
}

TEST(PdDemExtremeCases, ASphereStartingInsideThePdBodyIsRefusedNamingBoth) {
  PdDemRun r;
  const auto done = r.run("", {"solvers.spheres.params.particles[0].sphere.position=[0.04, 0.04, 0.05]",
                               "solvers.spheres.params.particles[0].sphere.driven=false"});
  EXPECT_EQ(done.code, 4) << done.out << done.err;
  EXPECT_NE(done.err.find("DEM particle 0 starts inside hybrid PD particle"), std::string::npos) << done.err;
}

// The load-displacement curve of driven spheres (H2's metric): recorded every
// exchange, and compared with a stored run of another schedule.
TEST(PdDemForceDisplacement, RecordsTheCurveAndComparesSchedulesWithAStoredRun) {
  PdDemRun reference;
  const std::string analysis = "{reference: force-displacement, dem: spheres, zone: indenter, direction: [0, 0, -1]";
  ASSERT_EQ(reference.run("", {}, analysis + "}").code, 0);
  const auto stored = reference.dir / "run" / "coupler.h5";
  {
    auto h5 = io::H5File::openReadOnly(stored);
    const auto d = h5.readArray("/series/analysis/displacement");
    const auto f = h5.readArray("/series/analysis/force");
    ASSERT_EQ(d.size(), f.size());
    ASSERT_GT(d.size(), 100u);
    EXPECT_NEAR(d.back(), 0.1 * 8.0e-3, 1e-9);  // driven at 0.1 m/s for 8 ms
    EXPECT_GT(f.back(), 10.0);                   // pressed about 0.5 mm into the block
    for (std::size_t k = 1; k < d.size(); ++k) EXPECT_GT(d[k], d[k - 1]);
  }
  EXPECT_GT(reference.report()["figures"]["max_force_N"].get<double>(), 10.0);

  PdDemRun staggered;
  const auto done = staggered.run("{kind: multirate, fine: block, dt: 1.0e-5, ratio: 2, order: coarse-first, end_time: 8.0e-3}",
                                  {}, analysis + ", reference_run: " + stored.string() + "}");
  ASSERT_EQ(done.code, 0) << done.out << done.err;
  const auto error = staggered.report()["errors"][0];
  EXPECT_EQ(error["name"], "force_rms_error");
  EXPECT_GT(error["value"].get<double>(), 0.0);   // another schedule: not the same curve
  EXPECT_LT(error["value"].get<double>(), 0.05);  // but close to it

  PdDemRun wrong;  // a stored run without this analysis
  const auto bad = wrong.run("", {}, analysis + ", reference_run: " + (reference.dir / "missing.h5").string() + "}");
  EXPECT_NE(bad.code, 0);
}

}  // namespace
}  // namespace cosim::testing
