// Adaptive dynamic relaxation (Kilic & Madenci 2010, Theor. Appl. Fract.
// Mech. 53): a fictitious diagonal density from a stiffness bound and a
// damping coefficient from Rayleigh's quotient of the local stiffness, with
// unit fictitious time step, drive the system to static equilibrium.
#include <cmath>

#include "cosim/pd/system.hpp"

namespace cosim::pd {

std::size_t PdSystem::relax(double tolerance, std::size_t maxIterations) {
  Particles& p = particles_;
  const std::size_t n = p.size();
  // Fictitious density lambda_ii >= (1/4) dt^2 sum_j |K_ij| with dt = 1.
  std::vector<double> lambda(n, 0.0);
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    const auto ctx = context(b);
    for (std::size_t i = bodies_[b].begin; i < bodies_[b].end; ++i)
      lambda[i] = 0.25 * 4.0 * p.volume[i] * bodies_[b].model->stiffnessBound(ctx, i - bodies_[b].begin);
  }
  std::vector<double> fOld(3 * n), vHalf(3 * n, 0.0);
  computeForces();
  auto residual = [&](std::vector<double>& f) {
    for (std::size_t q = 0; q < 3 * n; ++q) f[q] = p.internalForce[q] + p.externalForce[q];
  };
  // Fixed and prescribed particles do not take part in relaxation.
  std::vector<std::uint8_t> locked(n, 0);
  for (const auto& bc : bcs_)
    if (bc.type != Constraint::NormalOnly)
      for (const auto i : bc.particles) locked[i] = 1;
  auto project = [&](std::vector<double>& v) {
    std::swap(v, p.velocity);
    applyConstraints();
    std::swap(v, p.velocity);
    for (std::size_t i = 0; i < n; ++i)
      if (locked[i])
        for (int a = 0; a < 3; ++a) v[3 * i + a] = 0.0;
  };
  std::vector<double> f(3 * n);
  residual(f);
  double cDamp = 0.0;
  for (std::size_t it = 0; it < maxIterations; ++it) {
    double fNorm = 0.0, extNorm = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (locked[i]) continue;
      for (int a = 0; a < 3; ++a) {
        fNorm += f[3 * i + a] * f[3 * i + a];
        extNorm += p.externalForce[3 * i + a] * p.externalForce[3 * i + a];
      }
    }
    if (it > 0 && std::sqrt(fNorm) <= tolerance * std::sqrt(extNorm)) {
      p.velocity.assign(3 * n, 0.0);
      return it;
    }
    for (std::size_t q = 0; q < 3 * n; ++q) {
      const double a = f[q] / lambda[q / 3];
      vHalf[q] = it == 0 ? 0.5 * a : ((2.0 - cDamp) * vHalf[q] + 2.0 * a) / (2.0 + cDamp);
    }
    project(vHalf);
    for (std::size_t q = 0; q < 3 * n; ++q) p.displacement[q] += vHalf[q];
    fOld = f;
    computeForces();
    residual(f);
    // Rayleigh quotient of the diagonal "local" stiffness (Kilic Eq. 14-15).
    double num = 0.0, den = 0.0;
    for (std::size_t q = 0; q < 3 * n; ++q) {
      if (vHalf[q] == 0.0) continue;
      const double k = -(f[q] - fOld[q]) / (lambda[q / 3] * vHalf[q]);
      const double du = vHalf[q];
      num += du * k * du;
      den += du * du;
    }
    cDamp = (den > 0.0 && num > 0.0) ? 2.0 * std::sqrt(num / den) : 0.0;
    if (cDamp > 2.0) cDamp = 1.9;
  }
  p.velocity.assign(3 * n, 0.0);
  return maxIterations;
}

}  // namespace cosim::pd
