// Explicit dynamics: energy and momentum conservation of velocity Verlet at
// the reported critical step (Hartmann Eqs. 41-42, 44), body forces, and the
// staggered update (Eq. 47).
#include <gtest/gtest.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

void randomVelocities(Particles& p, double v0) {
  std::uint64_t state = 12345;
  for (auto& v : p.velocity) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    v = v0 * (static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5);
  }
}

double momentum(const Particles& p, int a) {
  double m = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) m += p.mass[i] * p.velocity[3 * i + a];
  return m;
}

struct DynCase {
  const char* model;
  bool correction;
};

class PdDynamics : public ::testing::TestWithParam<DynCase> {};

PdSystem block(const DynCase& c) {
  PdSystem sys;
  auto spec = test::box("block", c.model, 10, 8, 6, 1e-3, 3.0);
  spec.options.surfaceCorrection = c.correction;
  sys.addBody(spec);
  sys.finalise();
  return sys;
}

TEST_P(PdDynamics, StableAtCriticalStepWithWhiteNoise) {
  // Every mode excited; at dt = dt_crit the leapfrog energy error of the
  // highest modes is large but must stay bounded (no growth).
  const auto c = GetParam();
  PdSystem sys = block(c);
  randomVelocities(sys.particles(), 1e-3);
  const double p0 = momentum(sys.particles(), 0);
  const double e0 = sys.energies().kinetic;
  const double dt = sys.criticalTimeStep();
  double worst = 0.0, last = 0.0;
  for (int s = 0; s < 1000; ++s) {
    sys.step(dt);
    if (s % 20 == 0 || s == 999) {
      const auto e = sys.energies();
      last = (e.kinetic + e.strain) / e0;
      worst = std::max(worst, last);
    }
  }
  const double dp = std::abs(momentum(sys.particles(), 0) - p0) /
                    (sys.particles().mass[0] * 1e-3 * static_cast<double>(sys.particles().size()));
  std::printf("[measured] %s correction=%d, white noise at dt_crit, 1000 steps: max E/E0 = %.3f, final %.3f, "
              "momentum drift %.1e\n", c.model, c.correction, worst, last, dp);
  EXPECT_LT(worst, 2.0);
  EXPECT_LT(dp, 1e-12);
}

TEST_P(PdDynamics, EnergyErrorConvergesAsDtSquared) {
  // Forces that are the exact gradient of the strain energy make the leapfrog
  // energy error O(dt^2): halving dt must quarter it.
  const auto c = GetParam();
  auto run = [&](double fraction) {
    PdSystem sys = block(c);
    auto& p = sys.particles();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double x = p.reference[3 * i] / 10e-3, y = p.reference[3 * i + 1] / 8e-3;
      p.velocity[3 * i] = 1e-3 * std::cos(M_PI * x);
      p.velocity[3 * i + 1] = 1e-3 * std::cos(M_PI * y);
    }
    const double e0 = sys.energies().kinetic;
    const double dt = fraction * sys.criticalTimeStep();
    const int steps = static_cast<int>(std::lround(150.0 / fraction));
    double worst = 0.0;
    for (int s = 0; s < steps; ++s) {
      sys.step(dt);
      const auto e = sys.energies();
      worst = std::max(worst, std::abs(e.kinetic + e.strain - e0) / e0);
    }
    return worst;
  };
  const double e1 = run(0.5), e2 = run(0.25);
  std::printf("[measured] %s correction=%d, same physical time: max |E - E0| / E0 = %.2e at dt_crit/2, %.2e at "
              "dt_crit/4 (ratio %.3f)\n", c.model, c.correction, e1, e2, e2 / e1);
  EXPECT_LT(e1, 0.05);
  EXPECT_GT(e2 / e1, 0.2);
  EXPECT_LT(e2 / e1, 0.3);
}

INSTANTIATE_TEST_SUITE_P(Pd, PdDynamics,
                         ::testing::Values(DynCase{"pmb", false}, DynCase{"pmb", true}, DynCase{"lps", false},
                                           DynCase{"lps", true}),
                         [](const auto& param_info) {
                           return std::string(param_info.param.model) + (param_info.param.correction ? "Corrected" : "Plain");
                         });

TEST(PdDynamicsBodyForce, GravityAcceleratesFreeBodyAndWorkIsCounted) {
  PdSystem sys;
  auto spec = test::box("block", "lps", 6, 6, 6, 1e-3, 3.0);
  sys.addBody(spec);
  sys.setBodyForce({0.0, 0.0, -9.81});
  sys.finalise();
  const double dt = 0.5 * sys.criticalTimeStep();
  for (int s = 0; s < 50; ++s) sys.step(dt);
  double M = 0.0;
  for (const double m : sys.particles().mass) M += m;
  const double vz = momentum(sys.particles(), 2) / M;
  EXPECT_NEAR(vz / (-9.81 * 50 * dt), 1.0, 1e-12);
  // Work of gravity = M g * drop = kinetic energy (no strain for a uniform field).
  const auto e = sys.energies();
  EXPECT_NEAR(e.externalWork / e.kinetic, 1.0, 1e-9);
  EXPECT_LT(e.strain, 1e-12 * e.kinetic);
}

TEST(PdDynamicsStaggered, WithoutCouplingItIsLeapfrogAndCouplingImpulseIsExact) {
  auto make = [] {
    PdSystem sys;
    sys.addBody(test::box("block", "lps", 8, 6, 6, 1e-3, 3.0));
    sys.finalise();
    auto& p = sys.particles();
    for (std::size_t i = 0; i < p.size(); ++i) p.velocity[3 * i] = 1e-3 * std::cos(M_PI * p.reference[3 * i] / 8e-3);
    return sys;
  };
  PdSystem a = make(), b = make();
  const double dt = 0.5 * a.criticalTimeStep();
  // Leapfrog reference: velocity Verlet's positions with v_{-1/2} set so that
  // both start from the same (x_0, v_{1/2}).
  for (std::size_t q = 0; q < b.particles().velocity.size(); ++q)
    b.particles().velocity[q] -= 0.5 * dt * b.particles().internalForce[q] / b.particles().mass[q / 3];
  double diff = 0.0, scale = 0.0;
  for (int s = 0; s < 100; ++s) {
    a.step(dt);
    b.stepStaggered(dt);
  }
  for (std::size_t q = 0; q < a.particles().displacement.size(); ++q) {
    diff = std::max(diff, std::abs(a.particles().displacement[q] - b.particles().displacement[q]));
    scale = std::max(scale, std::abs(a.particles().displacement[q]));
  }
  std::printf("[measured] staggered (no coupling force) vs velocity Verlet, 100 steps: max |du| / max |u| = %.2e\n",
              diff / scale);
  EXPECT_LT(diff / scale, 1e-8);
  // A coupling force on one particle: total momentum grows by exactly F t.
  PdSystem c = make();
  const double p0 = momentum(c.particles(), 1);
  c.couplingForce()[3 * 5 + 1] = 2.0e-3;
  for (int s = 0; s < 40; ++s) c.stepStaggered(dt);
  EXPECT_NEAR((momentum(c.particles(), 1) - p0) / (2.0e-3 * 40 * dt), 1.0, 1e-9);
}

/// Strain energy and its densities, twice at one state: first where the
/// extensions are stale (one sweep that also sums w V e^2, Eq. 24 as
/// S - m theta^2 / 9), then after a force evaluation (the deviatoric
/// extensions summed in a second pass, Eq. 22).
void expectOneSweepEnergyIsTheTwoPassEnergy(PdSystem& sys, const std::string& label) {
  const double oneSweep = sys.energies().strain;
  const auto oneSweepDensity = sys.bodies()[0].model->energyDensity(sys.context(0));
  sys.computeForces();
  const double twoPass = sys.energies().strain;
  const auto twoPassDensity = sys.bodies()[0].model->energyDensity(sys.context(0));
  EXPECT_GT(twoPass, 0.0) << label;
  EXPECT_NEAR(oneSweep, twoPass, 1e-12 * twoPass) << label;
  ASSERT_EQ(oneSweepDensity.size(), twoPassDensity.size()) << label;
  const double largest = *std::max_element(twoPassDensity.begin(), twoPassDensity.end());
  for (std::size_t i = 0; i < twoPassDensity.size(); ++i) {
    EXPECT_GE(oneSweepDensity[i], 0.0) << label << ", particle " << i;
    EXPECT_NEAR(oneSweepDensity[i], twoPassDensity[i], 1e-12 * largest) << label << ", particle " << i;
  }
}

TEST(PdStaggeredEnergy, OneSweepEnergyIsTheTwoPassEnergy) {
  // Uncorrected LPS: the staggered update moves after its force evaluation,
  // so the energies sum the extensions again, in one sweep.
  PdSystem sys = block({"lps", false});
  randomVelocities(sys.particles(), 1.0);
  const double dt = 0.5 * sys.criticalTimeStep();
  for (int s = 0; s < 5; ++s) sys.stepStaggered(dt);
  expectOneSweepEnergyIsTheTwoPassEnergy(sys, "after staggered steps");
  // A pure dilatation: the deviatoric sum S - m theta^2 / 9 is round-off of
  // two nearly equal terms, kept from going below zero.
  auto& p = sys.particles();
  for (std::size_t q = 0; q < p.displacement.size(); ++q) p.displacement[q] = 1e-4 * p.reference[q];
  expectOneSweepEnergyIsTheTwoPassEnergy(sys, "pure dilatation");
}

#ifdef _OPENMP
/// A run's displacements and strain energy at its end.
struct RunEnd {
  std::vector<double> displacement;
  double strain = 0.0;
};

RunEnd endOf(const PdSystem& sys) { return {sys.particles().displacement, sys.energies().strain}; }

/// Random velocities, five steps of half the critical step (Verlet or
/// staggered), and the end.
RunEnd moveFiveSteps(PdSystem& sys, bool staggered) {
  randomVelocities(sys.particles(), 1.0);
  for (int s = 0; s < 5; ++s) {
    if (staggered) sys.stepStaggered(0.5 * sys.criticalTimeStep());
    else sys.step(0.5 * sys.criticalTimeStep());
  }
  return endOf(sys);
}

/// Two runs' displacements and strain energies are bitwise equal, and the
/// particles moved.
void expectSameBitsAfterMotion(const RunEnd& a, const RunEnd& b, const std::string& label) {
  ASSERT_EQ(a.displacement.size(), b.displacement.size()) << label;
  EXPECT_EQ(std::memcmp(a.displacement.data(), b.displacement.data(), a.displacement.size() * sizeof(double)), 0)
      << label;
  EXPECT_EQ(std::memcmp(&a.strain, &b.strain, sizeof(double)), 0) << label << ": " << a.strain << " vs " << b.strain;
  double moved = 0.0;
  for (const double u : a.displacement) moved = std::max(moved, std::abs(u));
  EXPECT_GT(moved, 0.0) << label;
  EXPECT_GT(a.strain, 0.0) << label;
}

TEST(PdDynamicsThreads, ResultsIndependentOfThreadCount) {
  // 18^3 = 5832 particles: above the OpenMP threshold, so with 2 threads the
  // loops run in parallel, row by row; every particle sums its own row, so
  // the result is bitwise equal. With 1 thread, LPS without surface
  // correction visits each pair once instead (its pairwise loops), which
  // must give the same bits as the row loops, and so must the strain energy
  // it sums from the pair loops' extensions. The staggered update moves after
  // its force evaluation, so there the energy recomputes the extensions: with
  // the pair loops on 1 thread, the row loops on 2.
  auto run = [](int threads, const char* model, bool corrected, bool staggered) {
    omp_set_num_threads(threads);
    PdSystem sys;
    auto spec = test::box("block", model, 18, 18, 18, 1e-3, 3.0);
    spec.options.surfaceCorrection = corrected;
    spec.options.criticalStretch = std::string(model) == "pmb" ? 1e-3 : 0.0;
    sys.addBody(spec);
    sys.finalise();
    return moveFiveSteps(sys, staggered);
  };
  const int saved = omp_get_max_threads();
  for (const char* model : {"pmb", "lps"})
    for (const bool corrected : {true, false})
      expectSameBitsAfterMotion(run(1, model, corrected, false), run(2, model, corrected, false),
                                std::string(model) + (corrected ? " corrected" : " uncorrected"));
  expectSameBitsAfterMotion(run(1, "lps", false, true), run(2, "lps", false, true), "lps uncorrected staggered");
  omp_set_num_threads(saved);
}

TEST(PdDynamicsThreads, UnequalVolumesGiveTheRowLoopsBits) {
  // The lattice above has one volume, so its pair loops take each pair's
  // theta term and force factor once for both ends. A point cloud whose
  // volumes differ (+-10 %) takes the general pair loops, which must give
  // the row loops' bits too.
  const double h = 1e-3;
  std::ostringstream text;
  text.precision(17);
  for (int i = 0; i < 18; ++i)
    for (int j = 0; j < 18; ++j)
      for (int k = 0; k < 18; ++k)
        text << (i + 0.5) * h << ' ' << (j + 0.5) * h << ' ' << (k + 0.5) * h << ' '
             << h * h * h * (1.0 + 0.1 * std::sin(1.7 * i + 2.3 * j + 0.9 * k)) << '\n';
  const auto file = test::tempFile("unequal_volumes.txt", text.str());
  auto run = [&file, h](int threads, bool staggered) {
    omp_set_num_threads(threads);
    auto spec = test::box("cloud", "lps", 18, 18, 18, h, 3.0);
    spec.shape = Shape::Points;
    spec.pointsFile = file.string();
    spec.spacing = h;
    PdSystem sys;
    sys.addBody(spec);
    sys.finalise();
    const auto& V = sys.particles().volume;
    EXPECT_NE(*std::min_element(V.begin(), V.end()), *std::max_element(V.begin(), V.end()));
    return moveFiveSteps(sys, staggered);
  };
  const int saved = omp_get_max_threads();
  expectSameBitsAfterMotion(run(1, false), run(2, false), "lps, unequal volumes");
  expectSameBitsAfterMotion(run(1, true), run(2, true), "lps, unequal volumes, staggered");
  omp_set_num_threads(saved);
  std::filesystem::remove(file);
}

TEST(PdDynamicsThreads, ManySmallBodiesShareThreadsBodyByBody) {
  // Six 7^3 bodies (below the per-body OpenMP threshold): with 2 threads the
  // system hands whole bodies to threads, for the forces and the strain
  // energies; the result must be bitwise the serial one, for both models and
  // both integrators.
  auto run = [](int threads, const char* model, bool staggered) {
    omp_set_num_threads(threads);
    PdSystem sys;
    for (int k = 0; k < 6; ++k) {
      const char name[] = {'b', static_cast<char>('0' + k), '\0'};
      auto spec = test::box(name, model, 7, 7, 7, 1e-3, 2.0, 0.3);
      if (std::string(model) == "pmb") spec.material.poissonRatio = 0.25;
      spec.min[0] = 0.01 * k;
      spec.max[0] += 0.01 * k;
      sys.addBody(spec);
    }
    sys.finalise();
    return moveFiveSteps(sys, staggered);
  };
  const int saved = omp_get_max_threads();
  for (const char* model : {"pmb", "lps"})
    for (const bool staggered : {false, true})
      expectSameBitsAfterMotion(run(1, model, staggered), run(2, model, staggered),
                                std::string(model) + (staggered ? " staggered" : " verlet"));
  omp_set_num_threads(saved);
}
#endif

}  // namespace
}  // namespace cosim::pd
