// Energy conservation of an elastic frictionless gas in a box of plane walls.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

TEST(DemEnergy, ElasticGasInWallBoxConservesEnergy) {
  DemSystem s;
  s.setContactLaw("hertz", "none", "none");
  Material m = glass();
  m.young = 1e7;  // soft: many collisions in 1e4 steps
  s.materials.add(m);
  const double r = 0.01, spacing = 0.03;
  const int side = 10;  // 1000 spheres
  std::mt19937_64 rng(11);
  std::normal_distribution<double> vel(0.0, 1.0);
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      for (int k = 0; k < side; ++k) {
        const std::size_t p = s.particles.add({spacing * (i + 0.5), spacing * (j + 0.5), spacing * (k + 0.5)}, r,
                                              m.density);
        s.particles.v[p] = {vel(rng), vel(rng), vel(rng)};
      }
  const double box = side * spacing;
  for (int d = 0; d < 3; ++d)
    for (int side2 = 0; side2 < 2; ++side2) {
      PlaneWall w;
      w.normal = {};
      w.normal[d] = side2 == 0 ? 1.0 : -1.0;
      w.point = {};
      w.point[d] = side2 == 0 ? 0.0 : box;
      s.planes.push_back(w);
    }
  s.neighbors.skin = 0.2 * r;
  s.initialize();
  const double mass = s.particles.mass[0];
  const double tc = hertzContactTime(0.5 * mass, 0.5 * r, m.young / (2 * (1 - m.poisson * m.poisson)), 3.0);
  const double dt = tc / 50;
  const double e0 = energies(s).balance();
  double worst = 0.0;
  for (int step = 0; step < 10000; ++step) {
    s.advance(dt);
    if (step % 100 == 99) worst = std::max(worst, std::fabs(energies(s).balance() - e0) / e0);
  }
  const Energies e = energies(s);
  const double drift = std::fabs(e.balance() - e0) / e0;
  std::printf("gas: dt=%.3e (t_c/50 at 3 m/s), %llu neighbour builds, coordination %.3f, "
              "final rel. drift %.3e, worst %.3e\n",
              dt, static_cast<unsigned long long>(s.neighbors.builds), coordinationNumber(s), drift, worst);
  EXPECT_LT(drift, 1e-4);
  EXPECT_LT(worst, 1e-4);
  EXPECT_EQ(e.dissipated, 0.0);
  EXPECT_GT(s.neighbors.builds, 10u);  // the gas really moved through the list
}

// One sphere of radius 1 cm, driven (its state set from outside), at height z
// above a floor wall, with the given contact law and material; initialised.
std::size_t drivenSphereOnFloor(DemSystem& s, const std::string& tangential, const Material& m, double z) {
  s.setContactLaw("linear", tangential, "none");
  s.materials.add(m);
  const std::size_t i = s.particles.add({0.0, 0.0, z}, 0.01, 2500.0);
  s.particles.driven[i] = 1;
  PlaneWall floor;
  floor.normal = {0.0, 0.0, 1.0};
  s.planes.push_back(floor);
  s.neighbors.skin = 0.002;
  s.initialize();
  return i;
}

// A driven particle (a hybrid PD particle) whose position is set from outside
// before every step, pressed into a fixed wall by a linear spring: the work of
// its prescribed motion must equal the elastic energy it stores. The jumps are
// counted in one trapezoid per step with the move the step's drift adds, exact
// for a linear force. Charging the force before each jump alone would leave
// the balance of 250 jumps of up to 1 mm against k = 1e5 N/m off by several
// times the energy stored (at most 0.11 J).
TEST(DemEnergy, WorkOfADrivenParticleSetFromOutsideBalancesItsContactEnergy) {
  DemSystem s;
  const std::size_t i = drivenSphereOnFloor(s, "none", glass(), 0.009);
  const double b0 = energies(s).balance();
  double stored = 0.0;
  for (int k = 1; k <= 250; ++k) {
    s.setDrivenState(i, {0.0, 0.0, 0.009 - 0.0005 * std::sin(0.7 * k)}, {0.0, 0.0, -1e-3});
    s.advance(1e-5);
    stored = std::max(stored, energies(s).elastic);
  }
  const Energies e = energies(s);
  std::printf("driven particle: elastic %.6e J (max %.3e), external work %.6e J, balance off by %.3e J\n", e.elastic,
              stored, e.externalWork, e.balance() - b0);
  EXPECT_GT(stored, 0.1);  // up to 1.5 mm deep into the wall, 1e5 N/m: 0.1125 J
  EXPECT_NEAR(e.balance(), b0, 1e-12);
}

// A driven particle following x(t) = A sin(w t) sideways on a frictional wall,
// its state set before each step like a PD hybrid's after Verlet: where DEM's
// drift v dt left it, the set position is off by about dt^2 a / 2, and the
// force causes a, so the friction force does work along those jumps, all of
// one sign. The tangential spring must take the jumps into its history
// (DemSystem::carryJumpIntoHistory), or that work is stored nowhere.
TEST(DemEnergy, TangentialJumpsOfADrivenParticleGoIntoItsFrictionSpring) {
  for (const double friction : {100.0, 0.05}) {  // sticking, then sliding
    DemSystem s;
    const double z = 0.0095, amplitude = 2e-4, dt = 1e-5, omega = 0.05 / dt;
    const std::size_t i = drivenSphereOnFloor(s, "linear", glass(1.0, friction), z);
    const double b0 = energies(s).balance();
    double stored = 0.0;
    for (int k = 1; k <= 250; ++k) {
      const double t = k * dt;
      s.setDrivenState(i, {amplitude * std::sin(omega * t), 0.0, z},
                       {amplitude * omega * std::cos(omega * t), 0.0, 0.0});
      s.advance(dt);
      stored = std::max(stored, 0.5 * glass().kt * norm2(s.planeShear[0][i]));
    }
    const Energies e = energies(s);
    std::printf("driven sideways, friction %g: tangential spring up to %.4e J, dissipated %.4e J, external work "
                "%.6e J, balance off by %.3e J\n",
                friction, stored, e.dissipated, e.externalWork, e.balance() - b0);
    if (friction > 1.0) {
      // Without the jumps in the history, and with the spring's work charged at
      // the step's end, the balance would be off by most of the stored energy.
      EXPECT_GT(stored, 5e-4);  // 1/2 k_t A^2 = 5.7e-4 J
      EXPECT_NEAR(e.dissipated, 0.0, 1e-15);
      EXPECT_NEAR(e.balance(), b0, 1e-15);
    } else {
      EXPECT_GT(e.dissipated, 10.0 * stored);  // mostly sliding
      EXPECT_LT(std::fabs(e.balance() - b0), 1e-3 * e.dissipated);
    }
  }
}

}  // namespace
}  // namespace cosim::dem::test
