#pragma once
// Shared set-ups for the DEM verification tests.
#include <cmath>
#include <numbers>

#include "cosim/dem/dem_system.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/packing/packing.hpp"

namespace cosim::dem::test {

inline Material glass(double restitution = 1.0, double friction = 0.0) {
  Material m;
  m.name = "glass";
  m.density = 2500.0;
  m.young = 7e10;
  m.poisson = 0.3;
  m.restitution = restitution;
  m.friction = friction;
  m.kn = 1e5;
  m.kt = 2.0 / 7.0 * 1e5;
  return m;
}

/// A loose random packing of soft frictional glass spheres (E = 5e7 Pa) in the box lo-hi.
inline DemSystem softGlassPacking(const Vec3& lo, const Vec3& hi, double rmin, double rmax, std::size_t count,
                                  std::uint64_t seed) {
  DemSystem s;
  Material m = glass(0.5, 0.4);
  m.young = 5e7;
  s.materials.add(m);
  const SphereSet set = randomPacking(lo, hi, rmin, rmax, count, seed);
  for (std::size_t i = 0; i < set.radii.size(); ++i) s.particles.add(set.centres[i], set.radii[i], m.density);
  return s;
}

/// Analytic elastic Hertz contact time (Johnson 1985 Sec. 11.4), written out
/// independently of the solver's own formula.
inline double hertzContactTime(double mEff, double rEff, double eEff, double v) {
  const double umax = std::pow(15.0 * mEff * v * v / (16.0 * eEff * std::sqrt(rEff)), 0.4);
  // int_0^1 (1 - x^(5/2))^(-1/2) dx = (2/5) B(2/5, 1/2)
  const double integral = 0.4 * std::tgamma(0.4) * std::sqrt(std::numbers::pi) / std::tgamma(0.9);
  return 2.0 * umax / v * integral;
}

struct CollisionResult {
  double contactTime = 0.0;
  double restitution = 0.0;
  double energyIn = 0.0, energyOut = 0.0;
  double balanceError = 0.0;  // relative change of kinetic + elastic + dissipated
};

}  // namespace cosim::dem::test
