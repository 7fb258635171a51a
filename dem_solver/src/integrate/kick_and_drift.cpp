#include "cosim/dem/integrate/integrator.hpp"
#include "cosim/dem/parallel.hpp"

namespace cosim::dem {

void kickAndDrift(Particles& p, double dtKick, double dt) {
  const std::size_t n = p.size();
  const std::uint8_t* driven = p.driven.data();
  const double *weight = p.weight.data(), *invMass = p.invMass.data(), *invInertia = p.invInertia.data();
  const Vec3 *f = p.f.data(), *torque = p.torque.data();
  Vec3 *x = p.x.data(), *v = p.v.data(), *omega = p.omega.data();
  Quat* q = p.q.data();
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (std::size_t i = 0; i < n; ++i) {
    if (driven[i]) continue;
    kick(weight[i], invMass[i], invInertia[i], f[i], torque[i], dtKick, v[i], omega[i]);
    x[i] += dt * v[i];
    // Most spheres of a dilute flow have never turned (no contact yet): their
    // orientations are neither read nor written (rotated() would return q).
    const Vec3 phi = dt * omega[i];
    if (norm2(phi) != 0.0) q[i] = rotated(q[i], phi);
  }
}

}  // namespace cosim::dem
