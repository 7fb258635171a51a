// wave-stations against a stored run: scene C2's full-DEM reference is run
// first, then the Arlequin-coupled scene compares its station velocities with
// it. Both cut to 0.03 s (the wave has passed the first two stations).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "subprocess.hpp"

namespace cosim::testing {
namespace {
namespace fs = std::filesystem;

nlohmann::json report(const fs::path& dir) {
  std::ifstream in(dir / "run_report.json");
  return nlohmann::json::parse(in);
}

TEST(WaveStations, CoupledRunIsComparedWithTheStoredFullDemRun) {
  const auto dir = freshDirectory("c2-stations");
  const auto reference = dir / "reference";
  auto f = run({binary("coupler"), "run", sourcePath("configs/c2/wave_full_dem_1p.yaml"), "--out", reference.string(),
                "--no-progress", "--set", "schedule.end_time=0.03"},
               60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto full = report(reference);
  EXPECT_TRUE(full["errors"].empty()) << "without reference_run there is nothing to compare with";
  EXPECT_NEAR(full["figures"]["dissipation_ratio"].get<double>(), 0.0, 1e-3) << "a bonded lattice conserves energy";
  EXPECT_GT(full["figures"]["station_0_peak_velocity"].get<double>(), 0.02);

  f = run({binary("coupler"), "run", sourcePath("configs/c2/wave_volume_1p.yaml"), "--out", (dir / "coupled").string(),
           "--no-progress", "--set", "schedule.end_time=0.03", "--set",
           "analysis.reference_run=" + (reference / "coupler.h5").string()},
          60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto coupled = report(dir / "coupled");
  ASSERT_FALSE(coupled["errors"].empty()) << f.err;
  EXPECT_EQ(coupled["errors"][0]["name"], "station_velocity_rms_error");
  // Before the wave reaches the coupling zone both runs are the same lattice.
  EXPECT_LT(coupled["errors"][0]["value"].get<double>(), 0.02);

  // A stored run with other stations fails the run with a message.
  f = run({binary("coupler"), "run", sourcePath("configs/c2/wave_volume_1p.yaml"), "--out", (dir / "bad").string(),
           "--no-progress", "--set", "schedule.end_time=0.002", "--set", "analysis.stations=[[0.2, 2.2, 0.2]]", "--set",
           "analysis.reference_run=" + (reference / "coupler.h5").string()},
          60.0);
  EXPECT_EQ(f.code, 1) << f.err;  // the run went through, its error figure could not be computed
  EXPECT_NE(f.err.find("this run records 1 per time (run the reference with the same analysis)"), std::string::npos)
      << f.err;
  fs::remove_all(dir);
}

// Loading (b): the leftmost layer driven by one cosine cycle (dem_solver
// drives). The energy put in is the drive's work: the full-DEM lattice holds
// all of it (dE/E = 0), and the coupled run's Arlequin energy guard counts it
// as input instead of calling the growth from zero a divergence.
TEST(WaveStations, DrivenPulseTheWorkIsTheInputEnergy) {
  const auto dir = freshDirectory("c2-pulse");
  const auto reference = dir / "reference";
  auto f = run({binary("coupler"), "run", sourcePath("configs/c2/wave_full_dem_1p_pulse.yaml"), "--out",
                reference.string(), "--no-progress", "--set", "schedule.end_time=0.03"},
               60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto full = report(reference);
  const double input = full["figures"]["input_energy_J"].get<double>();
  // 4 particles of 83.8 kg pushed through one cycle: about 1.78 J (docs/arlequin.md).
  EXPECT_GT(input, 1.5);
  EXPECT_LT(input, 2.1);
  EXPECT_NEAR(full["figures"]["dissipation_ratio"].get<double>(), 0.0, 1e-4) << "the lattice holds the drive's work";
  EXPECT_NEAR(full["final_energies_J"]["dem.drive_work"].get<double>(), input, 1e-12);

  f = run({binary("coupler"), "run", sourcePath("configs/c2/wave_volume_1p_pulse.yaml"), "--out",
           (dir / "coupled").string(), "--no-progress", "--set", "schedule.end_time=0.03", "--set",
           "analysis.reference_run=" + (reference / "coupler.h5").string()},
          60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  const auto coupled = report(dir / "coupled");
  EXPECT_NEAR(coupled["figures"]["input_energy_J"].get<double>(), input, 1e-9 * input);  // same drive, same lattice
  EXPECT_LT(coupled["errors"][0]["value"].get<double>(), 0.02);
  fs::remove_all(dir);
}

// Resumed from its earlier checkpoint, the full-DEM run reports the
// uninterrupted run's figures: the stations' record, initial energy and
// drive work come back from the checkpoint's analysis state.
TEST(WaveStations, AResumedRunReportsTheUninterruptedFigures) {
  const auto dir = freshDirectory("c2-resume");
  const std::vector<std::string> sets{"--set", "schedule.end_time=0.03", "--set", "output.checkpoint_interval=60"};
  auto argv = [&](const fs::path& out, bool resume) {
    std::vector<std::string> a{binary("coupler"), "run", sourcePath("configs/c2/wave_full_dem_1p_pulse.yaml"),
                               "--out", out.string(), "--no-progress"};
    if (resume) a.push_back("--resume");
    a.insert(a.end(), sets.begin(), sets.end());
    return a;
  };
  auto f = run(argv(dir / "whole", false), 60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_EQ(cutBackToEarlierCheckpoint(dir / "whole", dir / "cut").filename(), "exchange-120");
  f = run(argv(dir / "cut", true), 60.0);
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_NE(f.err.find("resuming from exchange 120"), std::string::npos) << f.err;
  const auto whole = report(dir / "whole"), part = report(dir / "cut");
  EXPECT_GT(whole["figures"]["input_energy_J"].get<double>(), 1.5);
  EXPECT_EQ(part["figures"], whole["figures"]);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cosim::testing
