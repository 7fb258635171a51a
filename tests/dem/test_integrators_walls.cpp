// Leapfrog integration and servo / velocity-driven plane walls.
#include <gtest/gtest.h>

#include <omp.h>

#include <cmath>
#include <cstring>
#include <numbers>

#include "cosim/dem/integrate/integrator.hpp"
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

// The opening pass turns its spheres in a vectorised batch; each orientation
// must be the bits rotated() gives, for small turns, large ones (exact sine and
// cosine), none (omega = 0), driven spheres (not turned) and weighted ones,
// on 1 and 2 threads, and over more spheres than one batch holds.
TEST(DemIntegrators, OpeningPassTurnsEverySphereAsRotated) {
  const int before = omp_get_max_threads();
  for (const int threads : {1, 2}) {
    Particles p;
    const std::size_t n = 3000;  // above kParallelMin, many batches
    std::uint64_t state = 12345;
    const auto uniform = [&] {  // in [-1, 1)
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<double>(state >> 11) / 4503599627370496.0 - 1.0;
    };
    for (std::size_t i = 0; i < n; ++i) {
      p.add({uniform(), uniform(), uniform()}, 0.01 * (1.5 + uniform()), 2500.0);
      // Orientation: a random unit quaternion; angular velocities from 0 to
      // large turns per step (|omega dt| up to about 0.1, kSmallTurn2 = 1e-6).
      Quat q{uniform(), uniform(), uniform(), uniform()};
      const double len = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
      p.q[i] = {q.w / len, q.x / len, q.y / len, q.z / len};
      // Not quite unit (as set from outside) where unturned: a turn would renormalise it.
      if (i % 7 == 0) p.q[i] = {p.q[i].w * 1.001, p.q[i].x * 1.001, p.q[i].y * 1.001, p.q[i].z * 1.001};
      const double scale = i % 7 == 0 ? 0.0 : std::pow(10.0, 3.0 * uniform() + 1.0);
      p.omega[i] = Vec3{uniform(), uniform(), uniform()} * scale;
      p.torque[i] = scale > 0.0 ? Vec3{uniform(), uniform(), uniform()} * 1e-6 : Vec3{};
      p.f[i] = Vec3{uniform(), uniform(), uniform()} * 1e-3;
      if (i % 11 == 0) p.driven[i] = 1;
      if (i % 13 == 0) p.weight[i] = 0.5;
    }
    const double dt = 1e-5, dtKick = 0.5e-5;
    Particles expected = p;
    std::size_t large = 0, small = 0, unturned = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (expected.driven[i]) continue;
      kick(expected, i, dtKick);
      expected.x[i] += dt * expected.v[i];
      const Vec3 phi = dt * expected.omega[i];
      expected.q[i] = rotated(expected.q[i], phi);
      ++(norm2(phi) == 0.0 ? unturned : norm2(phi) < kSmallTurn2 ? small : large);
    }
    ASSERT_GT(large, 100u);
    ASSERT_GT(unturned, 100u);
    ASSERT_GT(small, 100u);
    omp_set_num_threads(threads);
    kickAndDrift(p, dtKick, dt);
    EXPECT_EQ(std::memcmp(p.q.data(), expected.q.data(), n * sizeof(Quat)), 0) << threads << " threads";
    EXPECT_EQ(std::memcmp(p.x.data(), expected.x.data(), n * sizeof(Vec3)), 0);
    EXPECT_EQ(std::memcmp(p.omega.data(), expected.omega.data(), n * sizeof(Vec3)), 0);
  }
  omp_set_num_threads(before);
}

// The opening pass answers the neighbour list's rebuild test (DriftWatch).
// Positions set from outside between steps count too: a free sphere put by
// hand, and a driven one put by setDrivenState(), next to a sphere they were
// far from at the last build must feel it in the next step, under either integrator.
TEST(DemIntegrators, ASphereMovedBetweenStepsGetsItsNewContact) {
  for (const char* integrator : {"leapfrog", "velocity-verlet"})
    for (const bool driven : {false, true}) {
      DemSystem s;
      s.setIntegrator(integrator);
      s.setContactLaw("hertz", "none", "none");
      s.materials.add(glass());
      s.particles.add({0, 0, 0}, kR, 2500.0);
      s.particles.add({10 * kR, 0, 0}, kR, 2500.0);
      if (driven) s.particles.driven[1] = 1;
      s.neighbors.skin = 0.1 * kR;
      s.initialize();
      const double dt = 1e-7;
      s.advance(dt);
      const auto builds = s.neighbors.builds;
      const Vec3 next{1.99 * kR, 0, 0};  // overlapping sphere 0 by 0.01 r
      if (driven) s.setDrivenState(1, next, {});
      else s.particles.x[1] = next;
      s.advance(dt);
      EXPECT_EQ(s.neighbors.builds, builds + 1) << integrator << (driven ? ", driven" : ", free");
      EXPECT_LT(s.particles.f[0].x, 0.0) << integrator << (driven ? ", driven" : ", free") << ": no contact force";
    }
}

// External forces are read only where one was added (ExternalForces::any):
// one added moves its sphere by f/m, clear() stops it, and a restored set
// that holds one counts as set.
TEST(DemIntegrators, AnExternalForceActsUntilCleared) {
  DemSystem s;
  s.materials.add(glass());
  s.particles.add({0, 0, 0}, kR, 2500.0);
  s.particles.add({10 * kR, 0, 0}, kR, 2500.0);
  s.initialize();
  EXPECT_FALSE(s.particles.fExt.any());
  const double dt = 1e-6, m = s.particles.mass[1];
  s.particles.fExt.add(1, {0, 2.0, 0});
  ASSERT_TRUE(s.particles.fExt.any());
  for (int k = 0; k < 10; ++k) s.advance(dt);
  // Velocity Verlet: the first opening half-kick used the force evaluated before the add.
  EXPECT_NEAR(s.particles.v[1].y, 9.5 * dt * 2.0 / m, 1e-12 * 2.0 / m);
  EXPECT_EQ(s.particles.v[0].y, 0.0);
  s.particles.fExt.clear();
  EXPECT_FALSE(s.particles.fExt.any());
  EXPECT_EQ(s.particles.fExt[1].y, 0.0);
  const double before = s.particles.v[1].y;
  for (int k = 0; k < 10; ++k) s.advance(dt);
  // ... and the first opening half-kick after the clear the force evaluated before it.
  EXPECT_NEAR(s.particles.v[1].y, before + 0.5 * dt * 2.0 / m, 1e-12 * 2.0 / m);
  s.particles.fExt.restore({{0, 0, 0}, {0, 0, 1.0}});
  EXPECT_TRUE(s.particles.fExt.any());
  s.particles.fExt.restore({{0, 0, 0}, {0, 0, 0}});
  EXPECT_FALSE(s.particles.fExt.any());
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
