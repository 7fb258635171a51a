#include "cosim/dem/material.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cosim::dem {

PairMaterial combine(const Material& a, const Material& b) {
  PairMaterial p;
  // Standard Hertz effective modulus 1/E* = (1-nu_a^2)/E_a + (1-nu_b^2)/E_b.
  // Hartmann 2022 Eq. 36 prints (1-nu)/E (no square): garbled extraction; we
  // use the form from Hertz theory (Johnson, Contact Mechanics, Eq. 4.22).
  p.eEff = 1.0 / ((1.0 - a.poisson * a.poisson) / a.young + (1.0 - b.poisson * b.poisson) / b.young);
  // Mindlin: 1/G* = (2-nu_a)/G_a + (2-nu_b)/G_b (Hartmann 2022 Eq. 36, symmetric form).
  p.gEff = 1.0 / ((2.0 - a.poisson) / a.shearModulus() + (2.0 - b.poisson) / b.shearModulus());
  p.mindlinDashpotRatio = std::sqrt(4.0 * p.gEff / p.eEff);
  p.friction = std::min(a.friction, b.friction);
  p.restitution = std::min(a.restitution, b.restitution);
  // Springs in series for the linear law (two equal materials give k/2 each side, k in total).
  p.kn = (a.kn > 0 && b.kn > 0) ? 2.0 * a.kn * b.kn / (a.kn + b.kn) : std::max(a.kn, b.kn);
  p.kt = (a.kt > 0 && b.kt > 0) ? 2.0 * a.kt * b.kt / (a.kt + b.kt) : std::max(a.kt, b.kt);
  return p;
}

std::uint16_t MaterialTable::add(const Material& m) {
  if (materials_.size() >= 65535) throw std::length_error("too many materials");
  materials_.push_back(m);
  return static_cast<std::uint16_t>(materials_.size() - 1);
}

std::uint16_t MaterialTable::find(const std::string& name) const {
  for (std::size_t i = 0; i < materials_.size(); ++i)
    if (materials_[i].name == name) return static_cast<std::uint16_t>(i);
  throw std::invalid_argument("unknown material '" + name + "'");
}

}  // namespace cosim::dem
