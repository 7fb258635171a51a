// A short C2-like run (Cheng 2022 Sec. 6.2, tests/coupling/arlequin_c2_short.yaml):
// the real coupler with real dem_solver and fem_solver processes. The
// weighted mass (Eqs. 25-26) must stay constant to round-off, the weighted
// energy must stay bounded, and the wave must reach the FE beam.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cosim/io/h5_file.hpp"
#include "subprocess.hpp"

namespace cosim::testing {
namespace {
namespace fs = std::filesystem;

std::string sceneWith(const std::string& from, const std::string& to) {
  std::ifstream in(sourcePath("tests/coupling/arlequin_c2_short.yaml"));
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (!from.empty()) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  return text;
}

class ArlequinRun : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = freshDirectory("cosim-arlequin"); }
  void TearDown() override {
    EXPECT_TRUE(processesMentioning(dir_.string()).empty()) << "processes left behind for " << dir_;
    if (!HasFailure()) fs::remove_all(dir_);
  }
  Finished run(const std::string& scene) {
    const auto path = dir_ / "scene.yaml";
    std::ofstream(path) << scene;
    auto f = testing::run({binary("coupler"), "run", path.string(), "--out", (dir_ / "run").string(), "--no-progress"}, 50);
    EXPECT_FALSE(f.timedOut) << f.err;
    return f;
  }
  fs::path dir_;
};

TEST_F(ArlequinRun, ShortC2SceneConservesWeightedMassAndBoundsEnergy) {
  const Finished f = run(sceneWith("", ""));
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  auto h5 = io::H5File::openReadOnly(dir_ / "run" / "coupler.h5");
  const auto mass = h5.readArray("/series/volume/mass");
  const auto energy = h5.readArray("/series/volume/energy");
  const auto femEnergy = h5.readArray("/series/volume/fem_energy");
  const auto balance = h5.readArray("/series/volume/force_balance");
  ASSERT_EQ(mass.size(), 401u);
  double drift = 0.0;
  for (double m : mass) drift = std::max(drift, std::abs(m - mass[0]) / mass[0]);
  const double e0 = energy[0], emax = *std::max_element(energy.begin(), energy.end());
  double worstBalance = 0.0;
  for (double b : balance) worstBalance = std::max(worstBalance, std::abs(b));
  std::printf("[C2 short] weighted mass %.6f kg, max relative drift %.1e; energy E0 = %.6f J, max %.6f J, end %.6f J;"
              " FEM share at the end %.6f J; max |sum of penalty forces| %.1e N\n",
              mass[0], drift, e0, emax, energy.back(), femEnergy.back(), worstBalance);
  EXPECT_LT(drift, 1e-12);
  // Initial kinetic energy of the loaded layer: 4 particles, v = 0.1 m/s, w = 1.
  const double m = 2500 * 4.0 / 3.0 * std::numbers::pi * 0.2 * 0.2 * 0.2;
  EXPECT_NEAR(e0, 0.5 * 4 * m * 0.01, 1e-9);
  EXPECT_LT(emax, 1.05 * e0);  // bounded: the coupling adds no energy
  EXPECT_GT(femEnergy.back(), 0.01 * e0);  // the wave crossed into the continuum
  EXPECT_LT(worstBalance, 1e-6);
}

// Every series of coupler.h5 but the wall-clock timings, as the run wrote them.
std::map<std::string, std::vector<double>> physicsSeries(const fs::path& file) {
  auto h5 = io::H5File::openReadOnly(file);
  std::map<std::string, std::vector<double>> out;
  std::vector<std::string> todo{"/series"};
  while (!todo.empty()) {
    const std::string g = todo.back();
    todo.pop_back();
    for (const auto& c : h5.children(g)) {
      const std::string path = g + "/" + c;
      try {
        auto values = h5.readArray(path);
        if (c != "compute_s" && c != "communication_s") out[path] = std::move(values);
      } catch (const std::runtime_error&) {  // not a dataset: a group of series
        todo.push_back(path);
      }
    }
  }
  return out;
}

// A run resumed from a checkpoint taken while the wave crosses the zone
// continues the uninterrupted run bit for bit: the increment penalty (Cheng
// Sec. 5.2.3) and the time-centred prediction depend on the exchange before
// the checkpoint, which the coupling keeps in it.
TEST_F(ArlequinRun, AResumedRunContinuesTheUninterruptedRunBitForBit) {
  std::string scene = sceneWith("exchanges: 400", "exchanges: 600");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"    width: 0.0\n", "    width: 0.0\n    constraint: increment\n"},
                                 {"output:\n", "output:\n  checkpoint_interval: 200\n"}}) {
    const auto at = scene.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    scene.replace(at, from.size(), to);
  }
  const Finished whole = run(scene);
  ASSERT_EQ(whole.code, 0) << whole.out << whole.err;
  const fs::path point = cutBackToEarlierCheckpoint(dir_ / "run", dir_ / "cut");
  ASSERT_EQ(point.filename().string(), "exchange-400");  // the wave entered the zone near exchange 250
  const auto resumed = testing::run({binary("coupler"), "run", (dir_ / "scene.yaml").string(), "--resume", "--out",
                                     (dir_ / "cut").string(), "--no-progress"}, 50);
  ASSERT_EQ(resumed.code, 0) << resumed.out << resumed.err;
  const auto a = physicsSeries(dir_ / "run" / "coupler.h5"), b = physicsSeries(dir_ / "cut" / "coupler.h5");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_TRUE(a.count("/series/volume/penalty_energy"));
  for (const auto& [name, values] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    const auto& other = b.at(name);
    ASSERT_EQ(values.size(), other.size()) << name;
    const auto diff = std::mismatch(values.begin(), values.end(), other.begin());
    EXPECT_TRUE(diff.first == values.end()) << name << " differs from row " << (diff.first - values.begin()) << ": "
                                            << *diff.first << " against " << *diff.second;
  }
}

TEST_F(ArlequinRun, RefusesACgWidthBeyondTheZone) {
  const Finished f = run(sceneWith("width: 0.0", "width: 2.0"));
  EXPECT_NE(f.code, 0);
  EXPECT_NE((f.out + f.err).find("exceeds the coupling zone"), std::string::npos) << f.out << f.err;
}

TEST_F(ArlequinRun, StopsADivergingCouplingWithTheNumbers) {
  // A penalty 1e4 times too stiff for dt: the penalty springs are unstable.
  // The coupler's check of the coupled energy stops it, with dem_solver's own
  // balance check (which sees the penalty forces' work fall behind its stored
  // energy) off and on.
  const std::string scene = sceneWith("penalty: 1.0e10", "penalty: 1.0e14");
  std::string quiet = scene;
  quiet.replace(quiet.find("      dt: 3.2e-5\n"), 16, "      dt: 3.2e-5\n      energy_tolerance: 0\n");
  for (const std::string& text : {quiet, scene}) {
    const Finished f = run(text);
    EXPECT_EQ(f.code, 4) << f.out << f.err;
    const std::string all = f.out + f.err;
    EXPECT_NE(all.find("coupling 'volume' (exchange"), std::string::npos) << all;
    EXPECT_NE(all.find("diverged"), std::string::npos) << all;
  }
  // With the coupler's check turned off instead, dem_solver's stops it (two
  // checks in a row above the tolerance), naming the coupling's forces.
  std::string demOnly = scene;
  demOnly.replace(demOnly.find("penalty: 1.0e14"), 15, "penalty: 1.0e14\n    max_energy_growth: 1.0e300");
  const Finished g = run(demOnly);
  EXPECT_EQ(g.code, 4) << g.out << g.err;
  const std::string dem = g.out + g.err;
  EXPECT_NE(dem.find("peer 'dem'"), std::string::npos) << dem;
  EXPECT_NE(dem.find("energy balance broken"), std::string::npos) << dem;
  EXPECT_NE(dem.find("external forces from a coupling"), std::string::npos) << dem;
}

TEST_F(ArlequinRun, DtAutoRespectsThePenaltyStiffness) {
  // The penalty 1e4 times too stiff for the given dt (the test above): with
  // dt: auto the step shrinks by the penalty's frequency and the run is stable.
  std::string scene = sceneWith("penalty: 1.0e10", "penalty: 1.0e14");
  const std::string given = "schedule: {kind: lockstep, dt: 3.2e-5, steps_per_exchange: 1, exchanges: 400}";
  scene.replace(scene.find(given), given.size(), "schedule: {kind: lockstep, dt: auto, safety: 0.5, exchanges: 200}");
  const Finished f = run(scene);
  ASSERT_EQ(f.code, 0) << f.out << f.err;
  std::ifstream in(dir_ / "run" / "run_report.json");
  const auto report = nlohmann::json::parse(in);
  const double omegaNodes = report["figures"]["penalty_omega_nodes_rad_s"];
  const double omegaParticles = report["figures"]["penalty_omega_particles_rad_s"];
  ASSERT_GT(omegaNodes, 0.0);
  ASSERT_GT(omegaParticles, 0.0);
  // The chosen step: half the tightest of the penalty-stiffened steps, so at
  // most 2 / omega of either side.
  const double dt = report["simulated_time_s"].get<double>() / 200.0;
  EXPECT_LE(dt, 0.5 * 2.0 / std::max(omegaNodes, omegaParticles) * (1.0 + 1e-9));
  EXPECT_LT(dt, 0.05 * 3.2e-5);  // far below the penalty-blind step
}

}  // namespace
}  // namespace cosim::testing
