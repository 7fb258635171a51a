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

/// The neighbour list's rebuild test asked of the opening pass, which has each
/// new position at hand: did a particle end its drift farther than
/// sqrt(limit2) from its reference xRef? A dilute step is bound by memory
/// traffic, and a pass of its own reads every position again. An integrator
/// that does not answer leaves `checked` false, and the test runs on its own.
struct DriftWatch {
  const Vec3* xRef = nullptr;
  double limit2 = 0.0;
  bool checked = false;
  bool beyond = false;
  /// Whether particle i at x is farther than sqrt(limit2) from its reference.
  bool exceededBy(std::size_t i, const Vec3& x) const { return norm2(x - xRef[i]) > limit2; }
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  /// The update before the forces; answers `watch` if given (may be null).
  virtual void beforeForces(Particles& p, double dt, DriftWatch* watch) const = 0;
  virtual void afterForces(Particles& p, double dt) const = 0;
  /// When afterForces() is only kick(p, i, fusedKick() dt) for every particle
  /// not driven: that fraction (else 0). The force loop then kicks each
  /// particle as soon as its force is complete and afterForces() is skipped,
  /// one pass over the particles fewer (a dilute step is bound by memory traffic).
  virtual double fusedKick() const { return 0.0; }
};

using IntegratorRegistry = Registry<Integrator>;

/// Kick over dtKick of a sphere of weight w, inverse mass and inverse inertia
/// under force f and torque tau: v += dtKick f / (w m), omega += dtKick tau / (w I).
inline void kick(double w, double invMass, double invInertia, const Vec3& f, const Vec3& tau, double dtKick, Vec3& v,
                 Vec3& omega) {
  const double h = w == 1.0 ? dtKick : dtKick / w;  // skip the division outside coupling zones
  v += (h * invMass) * f;
  omega += (h * invInertia) * tau;
}

/// Kick of particle i over dtKick with its stored force and torque.
inline void kick(Particles& p, std::size_t i, double dtKick) {
  kick(p.weight[i], p.invMass[i], p.invInertia[i], p.f[i], p.torque[i], dtKick, p.v[i], p.omega[i]);
}

/// The opening pass of both integrators: every particle not driven is kicked
/// over dtKick with its stored force and torque, then drifts over dt. The
/// arrays are read through pointers taken once: through the vectors, every
/// store could alias their members as far as the compiler knows, and it
/// reloaded their data pointers for each particle.
/// With a watch, also its test over the particles drifted (not the driven ones).
void kickAndDrift(Particles& p, double dtKick, double dt, DriftWatch* watch = nullptr);

}  // namespace cosim::dem
