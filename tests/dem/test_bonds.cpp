// Bonded linear springs (Cheng 2022 Sec. 6.2): tension and compression alike,
// bonded pairs excluded from the contact law.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

TEST(DemBonds, BondedPairOscillatesWithLinearSpringPeriod) {
  DemSystem s;  // Hertz-Mindlin contacts are active for unbonded pairs
  s.materials.add(glass(0.5, 0.3));
  const double r = 0.01, k = 1e4;
  s.particles.add({0, 0, 0}, r, 2500);
  s.particles.add({2 * r, 0, 0}, r, 2500);
  s.particles.v[0] = {0.05, 0, 0};  // first compress (overlap), then stretch
  s.particles.v[1] = {-0.05, 0, 0};
  s.bonds.stiffness = k;
  ASSERT_EQ(s.bonds.bondNeighbours(s.particles, s.cell, 1.01), 1u);
  s.neighbors.skin = 0.1 * r;
  s.initialize();
  const double mEff = 0.5 * s.particles.mass[0];
  const double period = 2 * std::numbers::pi * std::sqrt(mEff / k);
  const double dt = period / 4000;
  const double e0 = energies(s).balance();
  std::vector<double> crossings;
  double before = norm(s.particles.x[1] - s.particles.x[0]) - 2 * r, minLen = 0, maxLen = 0, drift = 0;
  for (int step = 0; step < 12000; ++step) {
    s.advance(dt);
    const double now = norm(s.particles.x[1] - s.particles.x[0]) - 2 * r;
    minLen = std::min(minLen, now);
    maxLen = std::max(maxLen, now);
    if ((before < 0) != (now < 0)) crossings.push_back(s.time - dt + dt * before / (before - now));
    before = now;
    drift = std::max(drift, std::fabs(energies(s).balance() - e0) / e0);
  }
  ASSERT_GE(crossings.size(), 4u);
  const double measured = crossings[3] - crossings[1];
  std::printf("bonded pair: period %.6e s, analytic 2 pi sqrt(m*/k) = %.6e s (rel. err %.2e); stretch %.3e..%.3e m; "
              "energy drift %.2e\n",
              measured, period, std::fabs(measured - period) / period, minLen, maxLen, drift);
  EXPECT_LT(std::fabs(measured - period) / period, 1e-3);
  EXPECT_NEAR(minLen, -maxLen, 1e-3 * maxLen);  // symmetric: no Hertz force in compression
  EXPECT_LT(drift, 1e-4);
  EXPECT_EQ(s.neighbors.pairs(), 0u);  // the bonded pair is not a contact candidate
}

}  // namespace
}  // namespace cosim::dem::test
