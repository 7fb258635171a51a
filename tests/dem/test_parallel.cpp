// Results do not depend on the thread count: pair forces are gathered per
// particle in a fixed order, and wall forces and energy sums are added per
// fixed chunk of particles, so 1 and 2 threads give the same bits (also
// under a servo lid, which moves with the summed wall force).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <random>

#include "cosim/dem/packing/packing.hpp"
#include "dem_test_util.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace cosim::dem::test {
namespace {

DemSystem pile() {
  DemSystem s = softGlassPacking({0, 0, 0}, {0.03, 0.03, 0.03}, 0.0007, 0.001, 3000, 9);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (Vec3& v : s.particles.v) v = {u(rng), u(rng), u(rng)};  // collisions from the first steps
  PlaneWall floor;
  s.planes.push_back(floor);
  // A servo lid just above the pile: its motion follows the wall force summed
  // over all particles, so it feeds any thread-count dependence of that sum back
  // into the particles.
  PlaneWall lid;
  lid.point = {0, 0, 0.0305};
  lid.normal = {0, 0, -1};
  lid.mode = PlaneWall::Mode::servo;
  lid.servoStress = 2e3;
  lid.servoArea = 0.03 * 0.03;
  lid.servoGain = 0.05;
  s.planes.push_back(lid);
  s.gravity = {0, 0, -9.81};
  s.neighbors.skin = 1e-4;
  s.initialize();
  return s;
}

TEST(DemParallel, OneAndTwoThreadsGiveIdenticalBits) {
#ifdef _OPENMP
  const int before = omp_get_max_threads();
  std::vector<DemSystem> runs;
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    DemSystem s = pile();
    ASSERT_GT(s.particles.size(), 2000u);
    for (int k = 0; k < 200; ++k) s.advance(1e-5);
    runs.push_back(std::move(s));
  }
  omp_set_num_threads(before);
  const Particles &a = runs[0].particles, &b = runs[1].particles;
  EXPECT_GT(coordinationNumber(runs[0]), 0.1);
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.omega.data(), b.omega.data(), a.size() * sizeof(Vec3)), 0);
  // The lid moved and pushed, and every sum agrees to the bit.
  EXPECT_GT(std::fabs(runs[0].planes[1].force.z), 0.0);
  EXPECT_NE(runs[0].planes[1].point.z, 0.0305);
  EXPECT_EQ(runs[0].planes[1].point.z, runs[1].planes[1].point.z);
  EXPECT_EQ(runs[0].planes[0].force.z, runs[1].planes[0].force.z);
  EXPECT_GT(runs[0].dissipated, 0.0);
  EXPECT_EQ(runs[0].dissipated, runs[1].dissipated);
  EXPECT_EQ(runs[0].externalWork, runs[1].externalWork);
#else
  GTEST_SKIP() << "built without OpenMP";
#endif
}

// Phase timing is bookkeeping only: the same bits with it on, every phase of a
// step with contacts takes time, and the phases fit inside the steps' wall time.
TEST(DemParallel, PhaseTimingChangesNothingAndAddsUp) {
  DemSystem plain = pile(), timed = pile();
  timed.timing = true;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < 50; ++k) timed.advance(1e-5);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (int k = 0; k < 50; ++k) plain.advance(1e-5);
  const Particles &a = plain.particles, &b = timed.particles;
  EXPECT_EQ(std::memcmp(a.x.data(), b.x.data(), a.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.v.data(), b.v.data(), a.size() * sizeof(Vec3)), 0);
  const DemSystem::PhaseTimes& t = timed.phaseTimes;
  EXPECT_EQ(t.particleSteps, 50u * b.size());
  EXPECT_GT(t.open, 0.0);
  EXPECT_GT(t.neighbors, 0.0);
  EXPECT_GT(t.pairs, 0.0);
  EXPECT_GT(t.gather, 0.0);
  EXPECT_GE(t.close, 0.0);
  EXPECT_LE(t.open + t.neighbors + t.pairs + t.gather + t.close, wall);
  EXPECT_EQ(plain.phaseTimes.particleSteps, 0u);  // off: nothing is summed
  EXPECT_EQ(plain.phaseTimes.pairs, 0.0);
}

}  // namespace
}  // namespace cosim::dem::test
