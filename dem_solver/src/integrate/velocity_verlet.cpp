// Velocity Verlet with rotation (Cheng 2022 Eqs. 1-2): half kick, drift,
// forces, half kick. Spheres have isotropic inertia, so Euler's equations
// reduce to I dw/dt = tau and the quaternion turns by w dt each step.
#include "cosim/dem/parallel.hpp"
#include "cosim/dem/integrate/integrator.hpp"

namespace cosim::dem {
namespace {

class VelocityVerlet final : public Integrator {
 public:
  void beforeForces(Particles& p, double dt) const override {
    const std::size_t n = p.size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (std::size_t i = 0; i < n; ++i) {
      if (p.driven[i]) continue;
      const double w = p.weight[i];
      const double h = w == 1.0 ? 0.5 * dt : 0.5 * dt / w;  // skip the division outside coupling zones
      p.v[i] += (h * p.invMass[i]) * p.f[i];
      p.omega[i] += (h * p.invInertia[i]) * p.torque[i];
      p.x[i] += dt * p.v[i];
      p.q[i] = rotated(p.q[i], dt * p.omega[i]);
    }
  }
  void afterForces(Particles& p, double dt) const override {
    const std::size_t n = p.size();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (std::size_t i = 0; i < n; ++i) {
      if (p.driven[i]) continue;
      const double w = p.weight[i];
      const double h = w == 1.0 ? 0.5 * dt : 0.5 * dt / w;
      p.v[i] += (h * p.invMass[i]) * p.f[i];
      p.omega[i] += (h * p.invInertia[i]) * p.torque[i];
    }
  }
};

const bool registered =
    IntegratorRegistry::add("velocity-verlet", [] { return std::make_unique<VelocityVerlet>(); });

}  // namespace
}  // namespace cosim::dem
