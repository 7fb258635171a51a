#pragma once
// Time integrators, keyed by the scene's name: "velocity-verlet" (Cheng 2022
// Sec. 2) and "leapfrog". A step is beforeForces(), force evaluation,
// afterForces(). Driven particles are skipped: their kinematics come from outside.
// Arlequin weights w scale the inertia (Cheng 2022 Eq. 26): a = f / (w m).
#include <memory>
#include <string>

#include "cosim/dem/particles.hpp"
#include "cosim/dem/registry.hpp"

namespace cosim::dem {

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual void beforeForces(Particles& p, double dt) const = 0;
  virtual void afterForces(Particles& p, double dt) const = 0;
  /// When afterForces() is only kick(p, i, fusedKick() dt) for every particle
  /// not driven: that fraction (else 0). The force loop then kicks each
  /// particle as soon as its force is complete and afterForces() is skipped,
  /// one pass over the particles fewer (a dilute step is bound by memory traffic).
  virtual double fusedKick() const { return 0.0; }
};

using IntegratorRegistry = Registry<Integrator>;

/// Kick of particle i over dtKick: v += dtKick f / (w m), omega += dtKick tau / (w I).
inline void kick(Particles& p, std::size_t i, double dtKick) {
  const double w = p.weight[i];
  const double h = w == 1.0 ? dtKick : dtKick / w;  // skip the division outside coupling zones
  p.v[i] += (h * p.invMass[i]) * p.f[i];
  p.omega[i] += (h * p.invInertia[i]) * p.torque[i];
}

/// Drift of particle i over dt: position moves with v, orientation turns by omega dt.
inline void drift(Particles& p, std::size_t i, double dt) {
  p.x[i] += dt * p.v[i];
  p.q[i] = rotated(p.q[i], dt * p.omega[i]);
}

}  // namespace cosim::dem
