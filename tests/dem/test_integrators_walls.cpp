// Leapfrog integration and servo / velocity-driven plane walls.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "cosim/dem/packing/packing.hpp"
#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

constexpr double kR = 0.01;

TEST(DemIntegrators, LeapfrogHertzCollision) {
  const Material m = glass(0.8);
  for (const char* integrator : {"leapfrog", "velocity-verlet"}) {
    DemSystem s;
    s.setIntegrator(integrator);
    s.materials.add(m);
    s.particles.add({0, 0, kR + 1e-6}, kR, m.density);
    s.particles.v[0] = {0, 0, -1.0};
    s.planes.push_back(PlaneWall{});
    s.neighbors.skin = 0.1 * kR;
    s.initialize();
    const double mass = s.particles.mass[0];
    const double tc = hertzContactTime(mass, kR, m.young / (2 * (1 - m.poisson * m.poisson)), 1.0);
    const double dt = tc / 2000;
    double start = -1, end = -1;
    for (int k = 0; k < 4000 && end < 0; ++k) {
      const double before = s.particles.x[0].z - kR;
      s.advance(dt);
      const double now = s.particles.x[0].z - kR;
      if (before > 0 && now <= 0) start = s.time - dt + dt * before / (before - now);
      if (start >= 0 && before <= 0 && now > 0) end = s.time - dt + dt * (-before) / (now - before);
    }
    const double e = s.particles.v[0].z / 1.0;
    std::printf("%-16s: restitution %.6f (requested 0.8), contact time %.6e s (elastic Hertz %.6e s)\n", integrator,
                e, end - start, tc);
    EXPECT_NEAR(e, 0.8, 0.008);
    EXPECT_GT(end - start, tc);  // damping lengthens the contact a little
    EXPECT_LT(end - start, 1.1 * tc);
  }
}

TEST(DemWalls, ServoWallReachesTargetStress) {
  DemSystem s;
  Material m = glass(0.3, 0.3);
  m.young = 1e8;
  s.materials.add(m);
  const double L = 0.02;
  const SphereSet set = randomPacking({0, 0, 0}, {L, L, L}, 0.0009, 0.0011, 300, 5);
  for (std::size_t i = 0; i < set.radii.size(); ++i) s.particles.add(set.centres[i], set.radii[i], m.density);
  auto plane = [](Vec3 point, Vec3 normal) {
    PlaneWall w;
    w.point = point;
    w.normal = normal;
    return w;
  };
  s.planes = {plane({0, 0, 0}, {1, 0, 0}), plane({L, 0, 0}, {-1, 0, 0}), plane({0, 0, 0}, {0, 1, 0}),
              plane({0, L, 0}, {0, -1, 0}), plane({0, 0, 0}, {0, 0, 1})};
  PlaneWall lid = plane({0, 0, L}, {0, 0, -1});
  lid.mode = PlaneWall::Mode::servo;
  lid.servoStress = 5e3;
  lid.servoArea = L * L;
  lid.servoGain = 0.5;  // m/s per N of force error
  s.planes.push_back(lid);
  s.massDamping = 100;
  s.neighbors.skin = 1e-4;
  s.initialize();
  const double dt = 5e-6;
  for (int k = 0; k < 40000; ++k) s.advance(dt);
  const double target = lid.servoStress * lid.servoArea;
  double load = 0.0;
  for (int k = 0; k < 2000; ++k) {  // average over the last steps
    s.advance(dt);
    load += -dot(s.planes.back().force, s.planes.back().normal) / 2000;
  }
  std::printf("servo lid: mean load %.4f N, target %.4f N (%.2f %%), lid at z = %.5f m, floor load %.4f N\n", load,
              target, 100 * std::fabs(load - target) / target, s.planes.back().point.z, -s.planes[4].force.z);
  EXPECT_NEAR(load, target, 0.02 * target);
  EXPECT_LT(s.planes.back().point.z, L);  // it moved in to compress the packing
}

TEST(DemWalls, VelocityDrivenWallDoesWork) {
  DemSystem s;
  s.setContactLaw("hertz", "none", "none");
  s.materials.add(glass());
  s.particles.add({0, 0, kR}, kR, 2500);
  PlaneWall piston;
  piston.point = {0, 0, 2 * kR + 1e-5};
  piston.normal = {0, 0, -1};
  piston.velocity = {0, 0, -0.05};
  piston.mode = PlaneWall::Mode::velocity;
  s.planes = {PlaneWall{}, piston};
  s.neighbors.skin = 0.1 * kR;
  s.initialize();
  for (int k = 0; k < 6000; ++k) s.advance(1e-7);  // 30 um of piston travel, 20 um into the sphere
  const Energies e = energies(s);
  std::printf("piston: work %.6e J, elastic + kinetic %.6e J, balance error %.2e J\n", e.externalWork,
              e.elastic + e.kinetic(), e.balance());
  EXPECT_GT(e.externalWork, 0.0);
  EXPECT_NEAR(e.balance(), 0.0, 1e-2 * e.externalWork);  // work done = energy stored (elastic, no damping)
  EXPECT_NEAR(s.planes[1].point.z, 2 * kR + 1e-5 - 0.05 * 6000 * 1e-7, 1e-12);
}


// Liu 2016 Eqs. 63-64 on a sphere squeezed between a floor and a piston by
// linear springs: the per-particle stiffness is 2 k_n (2 k_t), so omega_n =
// sqrt(2 k_n / m), omega_theta = sqrt(5 k_t / m); and velocity Verlet is
// stable just below 2 / omega_max and not just above it.
TEST(DemCriticalStep, LiuFineStepFromThePerParticleStiffness) {
  const auto squeezed = [] {
    DemSystem s;
    s.setContactLaw("linear", "linear", "none");
    s.materials.add(glass());
    s.particles.add({0, 0, kR - 1e-5}, kR, 2500);
    PlaneWall piston;
    piston.point = {0, 0, 2 * kR - 2e-5};
    piston.normal = {0, 0, -1};
    s.planes = {PlaneWall{}, piston};
    s.neighbors.skin = 0.1 * kR;
    s.initialize();
    return s;
  };
  DemSystem s = squeezed();
  const double m = s.particles.mass[0], kn = glass().kn, kt = glass().kt;
  FineTimeStep f = fineTimeStep(s);
  EXPECT_NEAR(f.omegaN, std::sqrt(2 * kn / m), 1e-12 * f.omegaN);
  EXPECT_NEAR(f.omegaTheta, std::sqrt(5 * kt / m), 1e-12 * f.omegaTheta);
  EXPECT_EQ(f.omegaMax, f.omegaN);
  EXPECT_EQ(f.dampingFraction, 0.0);
  EXPECT_NEAR(f.criticalDt, 2.0 / f.omegaN, 1e-15);
  s.massDamping = 0.2 * f.omegaMax;  // xi = 0.1
  f = fineTimeStep(s);
  EXPECT_NEAR(f.dampingFraction, 0.1, 1e-12);
  EXPECT_NEAR(f.criticalDt, 2.0 / f.omegaMax * (std::sqrt(1.01) - 0.1), 1e-15);
  for (const double factor : {0.95, 1.05}) {
    DemSystem run = squeezed();
    const double z0 = run.particles.x[0].z;
    run.particles.v[0] = {0, 0, 1e-8 * std::sqrt(2 * kn / m)};  // amplitude 1e-8 m, overlaps 1e-5 m
    const double dt = factor * fineTimeStep(run).criticalDt;
    double amplitude = 0.0;
    for (int k = 0; k < 20; ++k) {
      run.advance(dt);
      amplitude = std::max(amplitude, std::abs(run.particles.x[0].z - z0));
    }
    if (factor < 1.0) EXPECT_LT(amplitude, 1e-7) << "dt = " << factor << " dt_cr";
    else EXPECT_GT(amplitude, 1e-6) << "dt = " << factor << " dt_cr";
  }
}

}  // namespace
}  // namespace cosim::dem::test
