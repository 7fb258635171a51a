#pragma once
// Contact laws composed at run time from three parts, each behind its own
// small interface and registry (keyed by the scene's names):
//   normal      "linear", "hertz"                 elastic normal force
//   tangential  "none", "linear", "mindlin"        history spring + Coulomb limit
//   damping     "none", "restitution"              viscous normal/tangential damping
// Sign conventions: n is the unit normal pointing from the partner (particle
// or wall) to particle i; vRel is the velocity of i relative to the partner
// at the contact point; forces are those acting on i.
#include <cmath>
#include <memory>
#include <string>

#include "cosim/dem/material.hpp"
#include "cosim/dem/registry.hpp"
#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

struct NormalResponse {
  double force = 0.0;      // elastic normal force magnitude (repulsive > 0)
  double stiffness = 0.0;  // tangent stiffness S_n = dF/d(overlap)
};

class NormalLaw {
 public:
  virtual ~NormalLaw() = default;
  virtual NormalResponse evaluate(double overlap, double rEff, const PairMaterial& pm) const = 0;
  /// Elastic energy stored at this overlap.
  virtual double energy(double overlap, double rEff, const PairMaterial& pm) const = 0;
  /// gamma such that F_d = -gamma sqrt(S_n m*) v_n gives restitution e for this law.
  virtual double dampingCoefficient(double e) const = 0;
  /// Duration of an elastic head-on collision at impact speed v (for the critical step).
  virtual double contactTime(double mEff, double rEff, double v, const PairMaterial& pm) const = 0;
  virtual bool isHertz() const { return false; }
};

struct TangentialInput {
  Vec3 n;             // current unit normal
  Vec3 vt;            // tangential relative velocity
  double overlap = 0.0, rEff = 0.0, mEff = 0.0, fnMag = 0.0, dt = 0.0;
  double overlapRate = 0.0;  // d(overlap)/dt = -v_n, for the energy bookkeeping of varying stiffness
  const PairMaterial* pm = nullptr;
};

class TangentialLaw {
 public:
  virtual ~TangentialLaw() = default;
  /// Advances the history spring `shear` and returns the tangential force on
  /// i; adds energy lost to sliding and tangential damping to `dissipated`.
  virtual Vec3 evaluate(const TangentialInput& in, Vec3& shear, double& dissipated) const = 0;
  /// Tangential spring stiffness (for energy and critical step); 0 when none.
  virtual double stiffness(double overlap, double rEff, const PairMaterial& pm) const = 0;
};

class DampingLaw {
 public:
  virtual ~DampingLaw() = default;
  /// The coefficient gamma for this material pair (0 when undamped).
  virtual double coefficient(const NormalLaw& normal, const PairMaterial& pm) const = 0;
};

using NormalLawRegistry = Registry<NormalLaw>;
using TangentialLawRegistry = Registry<TangentialLaw>;
using DampingLawRegistry = Registry<DampingLaw>;

/// The composed law the force loops call. Not virtual itself: one call per
/// contact dispatches to the normal and tangential parts.
class ContactLaw {
 public:
  ContactLaw(const std::string& normal, const std::string& tangential, const std::string& damping);
  /// Fills the damping coefficient of every pair in the table.
  void prepare(MaterialTable& table) const;
  const NormalLaw& normal() const { return *normal_; }
  const TangentialLaw& tangential() const { return *tangential_; }
  const std::string& name() const { return name_; }

  /// Total contact force on i; advances the tangential history.
  Vec3 force(const Vec3& n, double overlap, const Vec3& vRel, double rEff, double mEff,
             const PairMaterial& pm, double dt, Vec3& shear, double& dissipated) const;
  /// Elastic energy (normal + tangential spring) of one contact.
  double energy(double overlap, double rEff, const PairMaterial& pm, const Vec3& shear) const;

 private:
  std::unique_ptr<NormalLaw> normal_;
  std::unique_ptr<TangentialLaw> tangential_;
  std::unique_ptr<DampingLaw> damping_;
  std::string name_;
  bool hertzMindlin_ = false;  // the built-in pair: force() takes the fused path
};

/// What the tangential part sees of a contact: v_n = vRel . n, normal force fn.
inline TangentialInput tangentialInput(const Vec3& n, const Vec3& vRel, double vn, double overlap, double rEff,
                                       double mEff, double fn, double dt, const PairMaterial& pm) {
  return {.n = n, .vt = vRel - vn * n, .overlap = overlap, .rEff = rEff, .mEff = mEff, .fnMag = std::fabs(fn),
          .dt = dt, .overlapRate = -vn, .pm = &pm};
}

/// The composition normal x tangential x damping for one contact. A template
/// so the force loop can instantiate it for concrete (final) law classes and
/// have the calls inlined; ContactLaw::force uses it through the interfaces.
template <class Normal, class Tangential>
inline Vec3 composedForce(const Normal& normal, const Tangential& tangential, const Vec3& n, double overlap,
                          const Vec3& vRel, double rEff, double mEff, const PairMaterial& pm, double dt, Vec3& shear,
                          double& dissipated) {
  const NormalResponse nr = normal.evaluate(overlap, rEff, pm);
  const double vn = dot(vRel, n);
  // Tsuji-type viscous damping F_d = -gamma sqrt(S_n m*) v_n (the LIGGGHTS/
  // Antypov form); gamma from the damping law gives the requested restitution.
  const double damp = pm.gamma > 0.0 ? -pm.gamma * std::sqrt(nr.stiffness * mEff) * vn : 0.0;
  const double fn = nr.force + damp;
  dissipated += -damp * vn * dt;  // power of the dashpot, >= 0
  const TangentialInput in = tangentialInput(n, vRel, vn, overlap, rEff, mEff, fn, dt, pm);
  const Vec3 ft = tangential.evaluate(in, shear, dissipated);
  return fn * n + ft;
}

/// gamma for Hertz + Tsuji damping that yields restitution e exactly (numerical
/// calibration of the dimensionless collision ODE, see hertz_normal.cpp).
double hertzDampingCoefficient(double e);
/// gamma = 2 zeta for a linear spring-dashpot, zeta = -ln e / sqrt(pi^2 + ln^2 e).
double linearDampingCoefficient(double e);

}  // namespace cosim::dem
