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
};

using IntegratorRegistry = Registry<Integrator>;

}  // namespace cosim::dem
