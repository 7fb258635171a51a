// Velocity Verlet with rotation (Cheng 2022 Eqs. 1-2): half kick, drift,
// forces, half kick. Spheres have isotropic inertia, so Euler's equations
// reduce to I dw/dt = tau and the quaternion turns by w dt each step.
#include "cosim/dem/parallel.hpp"
#include "cosim/dem/integrate/integrator.hpp"

namespace cosim::dem {
namespace {

class VelocityVerlet final : public Integrator {
 public:
  void beforeForces(Particles& p, double dt, DriftWatch* watch) const override { kickAndDrift(p, 0.5 * dt, dt, watch); }
  double fusedKick() const override { return 0.5; }
  void afterForces(Particles& p, double dt) const override {
    const std::size_t n = p.size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (std::size_t i = 0; i < n; ++i) {
      if (p.driven[i]) continue;
      kick(p, i, 0.5 * dt);
    }
  }
};

const bool registered =
    IntegratorRegistry::add("velocity-verlet", [] { return std::make_unique<VelocityVerlet>(); });

}  // namespace
}  // namespace cosim::dem
