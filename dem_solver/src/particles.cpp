#include "cosim/dem/particles.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <numbers>

namespace cosim::dem {

std::size_t Particles::add(const Vec3& position, double r, double density, std::uint16_t materialId) {
  const double m = 4.0 / 3.0 * std::numbers::pi * r * r * r * density;
  const double inert = 0.4 * m * r * r;  // solid sphere: I = 2/5 m r^2
  x.push_back(position);
  v.push_back({});
  omega.push_back({});
  q.push_back({});
  f.push_back({});
  torque.push_back({});
  fExt.append();
  radius.push_back(r);
  mass.push_back(m);
  invMass.push_back(1.0 / m);
  inertia.push_back(inert);
  invInertia.push_back(1.0 / inert);
  weight.push_back(1.0);
  material.push_back(materialId);
  driven.push_back(0);
  id.push_back(static_cast<std::uint32_t>(id.size()));
  return radius.size() - 1;
}

std::string Particles::defectOf(std::size_t i) const {
  // Per component: the square of a large, finite coordinate would overflow.
  const auto finite = [](const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); };
  if (!finite(x[i]) || !finite(v[i]) || !finite(omega[i])) return "non-finite position or velocity";
  if (!(radius[i] > 0.0) || !std::isfinite(radius[i])) return "radius not positive and finite";
  if (!(mass[i] > 0.0) || !std::isfinite(mass[i]) || !(inertia[i] > 0.0) || !std::isfinite(inertia[i]))
    return "mass or inertia not positive and finite";
  return "";
}

void Particles::reserve(std::size_t n) {
  x.reserve(n); v.reserve(n); omega.reserve(n); q.reserve(n); f.reserve(n); torque.reserve(n);
  fExt.reserve(n); radius.reserve(n); mass.reserve(n); invMass.reserve(n); inertia.reserve(n);
  invInertia.reserve(n); weight.reserve(n); material.reserve(n); driven.reserve(n); id.reserve(n);
}

void ExternalForces::clear() {
  if (any_) std::fill(f_.begin(), f_.end(), Vec3{});
  any_ = false;
}

void ExternalForces::restore(std::vector<Vec3> values) {
  f_ = std::move(values);
  any_ = std::any_of(f_.begin(), f_.end(), [](const Vec3& f) { return f.x != 0.0 || f.y != 0.0 || f.z != 0.0; });
}

void Particles::clearForces() {
  for (auto& a : f) a = {};
  for (auto& a : torque) a = {};
}

}  // namespace cosim::dem
