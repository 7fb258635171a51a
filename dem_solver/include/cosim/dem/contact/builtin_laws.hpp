#pragma once
// The built-in contact law parts as concrete (final) classes, so the force
// loop can be instantiated for them and the calls inlined; each registers
// itself in its own .cpp file. Plug-in laws go through the virtual interface.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "cosim/dem/contact/contact_law.hpp"
#include "cosim/dem/contact/tangential_spring.hpp"

namespace cosim::dem {

/// Linear spring F_n = k_n u_n (Cheng 2022 Sec. 2; Hartmann 2022 Eq. 33).
class LinearSpring final : public NormalLaw {
 public:
  NormalResponse evaluate(double overlap, double, const PairMaterial& pm) const override {
    return {pm.kn * overlap, pm.kn};
  }
  double energy(double overlap, double, const PairMaterial& pm) const override {
    return 0.5 * pm.kn * overlap * overlap;
  }
  double dampingCoefficient(double e) const override { return linearDampingCoefficient(e); }
  // Half a period of the harmonic oscillator: t_c = pi sqrt(m*/k).
  double contactTime(double mEff, double, double, const PairMaterial& pm) const override {
    return std::numbers::pi * std::sqrt(mEff / pm.kn);
  }
};

/// Hertz: F_n = k_n u_n with k_n = 4/3 E* sqrt(R* u_n) (Hartmann 2022 Eqs. 33, 36),
/// i.e. F_n = 4/3 E* sqrt(R*) u_n^(3/2); tangent stiffness S_n = 2 E* sqrt(R* u_n).
class HertzNormal final : public NormalLaw {
 public:
  NormalResponse evaluate(double overlap, double rEff, const PairMaterial& pm) const override {
    const double a = std::sqrt(rEff * overlap);  // contact radius
    return {4.0 / 3.0 * pm.eEff * a * overlap, 2.0 * pm.eEff * a};
  }
  double energy(double overlap, double rEff, const PairMaterial& pm) const override {
    return 8.0 / 15.0 * pm.eEff * std::sqrt(rEff * overlap) * overlap * overlap;
  }
  double dampingCoefficient(double e) const override { return hertzDampingCoefficient(e); }
  double contactTime(double mEff, double rEff, double v, const PairMaterial& pm) const override;
  bool isHertz() const override { return true; }
};

/// Mindlin no-slip tangential spring k_s = 8 G* sqrt(R* u_n) with history and
/// Coulomb limit (Hartmann 2022 Eqs. 34-36).
class MindlinTangential final : public TangentialLaw {
 public:
  Vec3 evaluate(const TangentialInput& in, Vec3& shear, double& dissipated) const override {
    const double before = std::max(0.0, in.overlap - in.overlapRate * in.dt);  // overlap one step ago
    const double kt = stiffness(in.overlap, in.rEff, *in.pm);
    return tangentialSpring(in, kt, stiffness(before, in.rEff, *in.pm), tangentialDashpot(in, kt), shear, dissipated);
  }
  double stiffness(double overlap, double rEff, const PairMaterial& pm) const override {
    return 8.0 * pm.gEff * std::sqrt(rEff * overlap);
  }
};

/// Linear tangential spring with history and Coulomb limit (Hartmann 2022 Eqs. 34-35, constant k_s).
class LinearTangential final : public TangentialLaw {
 public:
  Vec3 evaluate(const TangentialInput& in, Vec3& shear, double& dissipated) const override {
    return tangentialSpring(in, in.pm->kt, in.pm->kt, tangentialDashpot(in, in.pm->kt), shear, dissipated);
  }
  double stiffness(double, double, const PairMaterial& pm) const override { return pm.kt; }
};

/// No tangential force.
class Frictionless final : public TangentialLaw {
 public:
  Vec3 evaluate(const TangentialInput&, Vec3& shear, double&) const override {
    shear = {};
    return {};
  }
  double stiffness(double, double, const PairMaterial&) const override { return 0.0; }
};

/// Hertz-Mindlin with Tsuji dashpots in one pass (the built-in law of the
/// settling benchmark): the contact radius a = sqrt(R* u) gives F_n, S_n = 2 E* a
/// and k_t = 8 G* a (Hartmann 2022 Eqs. 33-36), and the two dashpots share one
/// root, sqrt(k_t m*) = sqrt(S_n m*) sqrt(4 G*/E*). The same force as the
/// composition of the two parts, with two square roots fewer per contact.
inline Vec3 composedForce(const HertzNormal&, const MindlinTangential&, const Vec3& n, double overlap,
                          const Vec3& vRel, double rEff, double mEff, const PairMaterial& pm, double dt, Vec3& shear,
                          double& dissipated) {
  const double a = std::sqrt(rEff * overlap);
  const double stiffness = 2.0 * pm.eEff * a;
  const double vn = dot(vRel, n);
  // Undamped (gamma = 0) both dashpots vanish through the factor gamma: no branch.
  const double root = std::sqrt(stiffness * mEff);
  const double damp = -pm.gamma * root * vn;
  const double fn = 4.0 / 3.0 * pm.eEff * a * overlap + damp;
  dissipated += -damp * vn * dt;
  const double before = std::max(0.0, overlap + vn * dt);  // overlap one step ago
  const double kt = 8.0 * pm.gEff * a;
  // The spring on plain values, not a TangentialInput: that struct (it points
  // at pm) would keep GCC from vectorising the batched pair loop.
  const Vec3 ft = tangentialSpring(n, vRel - vn * n, pm.friction * std::fabs(fn), dt, kt,
                                   8.0 * pm.gEff * std::sqrt(rEff * before), pm.gamma * root * pm.mindlinDashpotRatio,
                                   shear, dissipated);
  return fn * n + ft;
}

}  // namespace cosim::dem
