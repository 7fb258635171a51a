// Verification of the contact laws against analytic collisions.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

constexpr double kR = 0.01;

// Steps until the gap opens again; the contact start and end are located
// between steps by linear interpolation of the gap, so the measured duration
// is not quantised to dt.
template <class Gap>
double contactDuration(DemSystem& s, double dt, Gap gap, int maxSteps) {
  double before = gap(), start = -1.0;
  for (int step = 0; step < maxSteps; ++step) {
    s.advance(dt);
    const double now = gap();
    if (before > 0 && now <= 0) start = s.time - dt + dt * before / (before - now);
    if (start >= 0 && before <= 0 && now > 0) return s.time - dt + dt * (-before) / (now - before) - start;
    before = now;
  }
  return -1.0;
}

// Two equal spheres approaching head-on along x at +-v/2.
CollisionResult headOn(const std::string& normal, const std::string& damping, const Material& mat, double v,
                       double stepsPerContact, double expectedTime) {
  DemSystem s;
  s.setContactLaw(normal, "none", damping);
  s.materials.add(mat);
  s.particles.add({-kR - 1e-6, 0, 0}, kR, mat.density);
  s.particles.add({kR + 1e-6, 0, 0}, kR, mat.density);
  s.particles.v[0] = {0.5 * v, 0, 0};
  s.particles.v[1] = {-0.5 * v, 0, 0};
  s.neighbors.skin = 0.2 * kR;
  s.initialize();
  const double dt = expectedTime / stepsPerContact;
  CollisionResult r;
  auto gap = [&s] { return norm(s.particles.x[1] - s.particles.x[0]) - 2 * kR; };
  r.contactTime = contactDuration(s, dt, gap, 20 * static_cast<int>(stepsPerContact));
  r.restitution = (s.particles.v[1].x - s.particles.v[0].x) / v;
  return r;
}

// A sphere falling onto a plane wall along -z at speed v (no gravity), or obliquely.
CollisionResult onWall(const std::string& normal, const std::string& tangential, const std::string& damping,
                       const Material& mat, const Vec3& velocity, double dt, Vec3* spin = nullptr) {
  DemSystem s;
  s.setContactLaw(normal, tangential, damping);
  s.materials.add(mat);
  s.particles.add({0, 0, kR + 1e-6}, kR, mat.density);
  s.particles.v[0] = velocity;
  PlaneWall wall;
  wall.normal = {0, 0, 1};
  s.planes.push_back(wall);
  s.neighbors.skin = 0.2 * kR;
  s.initialize();
  CollisionResult r;
  r.energyIn = energies(s).kinetic();
  const double balance0 = energies(s).balance();
  r.contactTime = contactDuration(s, dt, [&s] { return s.particles.x[0].z - kR; }, 10000000);
  r.restitution = -s.particles.v[0].z / velocity.z;
  r.energyOut = energies(s).kinetic();
  r.balanceError = (energies(s).balance() - balance0) / balance0;
  if (spin) *spin = s.particles.omega[0];
  return r;
}

double eEffSame(const Material& m) { return m.young / (2.0 * (1.0 - m.poisson * m.poisson)); }
double sphereMass(const Material& m) { return 4.0 / 3.0 * std::numbers::pi * kR * kR * kR * m.density; }

TEST(DemContact, HertzHeadOnContactTimeSphereSphere) {
  const Material m = glass();
  for (double v : {0.1, 1.0, 5.0}) {
    const double tc = hertzContactTime(0.5 * sphereMass(m), 0.5 * kR, eEffSame(m), v);
    const CollisionResult r = headOn("hertz", "none", m, v, 1000, tc);
    const double err = std::fabs(r.contactTime - tc) / tc;
    RecordProperty("rel_error_v" + std::to_string(v), std::to_string(err));
    std::printf("Hertz sphere-sphere v=%g: t_c=%.6e analytic=%.6e rel.err=%.2e, e=%.6f\n", v, r.contactTime, tc,
                err, r.restitution);
    EXPECT_LT(err, 0.01);
    EXPECT_NEAR(r.restitution, 1.0, 1e-3);
  }
}

TEST(DemContact, HertzSphereWallContactTime) {
  const Material m = glass();
  for (double v : {0.1, 1.0, 5.0}) {
    // Wall of the same material: E* = E / (2 (1 - nu^2)), R* = R, m* = m.
    const double tc = hertzContactTime(sphereMass(m), kR, eEffSame(m), v);
    const CollisionResult r = onWall("hertz", "none", "none", m, {0, 0, -v}, tc / 1000);
    const double err = std::fabs(r.contactTime - tc) / tc;
    std::printf("Hertz sphere-wall v=%g: t_c=%.6e analytic=%.6e rel.err=%.2e\n", v, r.contactTime, tc, err);
    EXPECT_LT(err, 0.01);
    EXPECT_NEAR(r.restitution, 1.0, 1e-3);
  }
}

TEST(DemContact, HertzRestitutionMatchesRequest) {
  for (double e : {0.3, 0.5, 0.8, 0.95}) {
    const Material m = glass(e);
    for (double v : {0.1, 2.0}) {
      const double tc = hertzContactTime(0.5 * sphereMass(m), 0.5 * kR, eEffSame(m), v);
      const CollisionResult pp = headOn("hertz", "restitution", m, v, 2000, tc);
      const CollisionResult pw = onWall("hertz", "none", "restitution", m, {0, 0, -v},
                                        hertzContactTime(sphereMass(m), kR, eEffSame(m), v) / 2000);
      std::printf("Hertz e=%.2f v=%g: sphere-sphere e=%.6f (%.2e), sphere-wall e=%.6f (%.2e)\n", e, v,
                  pp.restitution, std::fabs(pp.restitution - e) / e, pw.restitution,
                  std::fabs(pw.restitution - e) / e);
      EXPECT_LT(std::fabs(pp.restitution - e) / e, 0.01);
      EXPECT_LT(std::fabs(pw.restitution - e) / e, 0.01);
    }
  }
}

TEST(DemContact, LinearSpringContactTime) {
  const Material m = glass();
  const double mEff = 0.5 * sphereMass(m);
  // Equal materials: the pair stiffness is the material's kn.
  const double tc = std::numbers::pi * std::sqrt(mEff / m.kn);
  const CollisionResult r = headOn("linear", "none", m, 1.0, 2000, tc);
  const double err = std::fabs(r.contactTime - tc) / tc;
  std::printf("linear spring: t_c=%.6e analytic=%.6e rel.err=%.2e e=%.6f\n", r.contactTime, tc, err,
              r.restitution);
  EXPECT_LT(err, 0.005);
  EXPECT_NEAR(r.restitution, 1.0, 1e-4);
}

TEST(DemContact, LinearSpringRestitution) {
  for (double e : {0.2, 0.6, 0.9}) {
    const Material m = glass(e);
    const double tc = std::numbers::pi * std::sqrt(0.5 * sphereMass(m) / m.kn);
    const CollisionResult r = headOn("linear", "restitution", m, 1.0, 2000, tc);
    std::printf("linear e=%.2f: measured %.6f\n", e, r.restitution);
    EXPECT_LT(std::fabs(r.restitution - e) / e, 0.01);
  }
}

TEST(DemContact, ObliqueFrictionalImpactsNeverGainEnergy) {
  const Material m = glass(0.9, 0.3);
  const double v = 1.0;
  const double dt = hertzContactTime(sphereMass(m), kR, eEffSame(m), v) / 300;
  for (int a = 0; a < 10; ++a) {
    const double angle = (5.0 + 8.5 * a) * std::numbers::pi / 180.0;  // from the normal, 5..81.5 deg
    for (const char* damping : {"none", "restitution"}) {
      Vec3 spin;
      const CollisionResult r =
          onWall("hertz", "mindlin", damping, m, {v * std::sin(angle), 0, -v * std::cos(angle)}, dt, &spin);
      std::printf("oblique %5.1f deg damping=%-11s: E_out/E_in = %.9f, spin_y = %.3f rad/s, energy balance %.1e\n",
                  angle * 180.0 / std::numbers::pi, damping, r.energyOut / r.energyIn, spin.y, r.balanceError);
      // Kinetic out + dissipated (dashpots, sliding) = kinetic in; the bookkeeping
      // is first order in dt (2e-3 at t_c/300, 2e-4 at t_c/3400).
      EXPECT_LT(std::fabs(r.balanceError), 5e-3);
      EXPECT_LE(r.energyOut, r.energyIn * (1.0 + 1e-9));
      EXPECT_GT(spin.y, 0.0);  // friction rolls the sphere forward (about +y for motion along +x)
    }
  }
}

TEST(DemContact, HertzDampingCalibrationIsMonotone) {
  double last = 0.0;
  for (double e : {0.99, 0.9, 0.7, 0.5, 0.3, 0.1}) {
    const double g = hertzDampingCoefficient(e);
    EXPECT_GT(g, last);
    last = g;
  }
  EXPECT_EQ(hertzDampingCoefficient(1.0), 0.0);
}

}  // namespace
}  // namespace cosim::dem::test
