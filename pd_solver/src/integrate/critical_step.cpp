// Critical step of velocity Verlet measured on the bodies themselves.
//
// Verlet is stable for dt < 2 / omega_max, omega_max^2 the largest eigenvalue
// of M^-1 K (Hartmann 2022 Eq. 41 states the limit as h / c, a rule). The rule
// PdSystem::criticalTimeStep uses by default, 0.45 delta / c_p, lies below the
// limit of every body tests/pd/test_stability.cpp measures, by 1.1-1.8x (1.8x
// for an LPS sphere at nu = 0.48, the H5 pack's PD spheres), so a scene whose
// cost is its step count can ask for the body's own limit instead
// (`critical_step: measured`): power iteration on the linear response to a
// displacement of 1e-6 spacings, times a safety factor that covers the
// Rayleigh quotient's approach from below and the stiffening of large strains.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "cosim/pd/system.hpp"

namespace cosim::pd {
namespace {

constexpr int kMinIterations = 200;
constexpr int kMaxIterations = 20000;
constexpr double kConverged = 1e-7;  // relative change of the Rayleigh quotient per iteration

/// Two bodies with the same model, material, horizon, options and particle
/// layout (one a translate of the other) have the same spectrum.
bool sameSpectrum(const Body& a, const Body& b, const Particles& p) {
  if (a.end - a.begin != b.end - b.begin || a.spec.model != b.spec.model || a.horizon != b.horizon ||
      a.spacing != b.spacing)
    return false;
  const auto& ma = a.spec.material;
  const auto& mb = b.spec.material;
  const auto& oa = a.spec.options;
  const auto& ob = b.spec.options;
  if (ma.youngsModulus != mb.youngsModulus || ma.poissonRatio != mb.poissonRatio || ma.density != mb.density ||
      oa.influence != ob.influence || oa.surfaceCorrection != ob.surfaceCorrection ||
      oa.micromodulus != ob.micromodulus || oa.partialVolume != ob.partialVolume)
    return false;
  const double tol = 1e-9 * a.spacing;
  for (std::size_t k = 0; k < a.end - a.begin; ++k) {
    const std::size_t i = a.begin + k, j = b.begin + k;
    if (p.volume[i] != p.volume[j]) return false;
    for (int d = 0; d < 3; ++d) {
      const double ri = p.reference[3 * i + d] - p.reference[3 * a.begin + d];
      const double rj = p.reference[3 * j + d] - p.reference[3 * b.begin + d];
      if (std::abs(ri - rj) > tol) return false;
    }
  }
  return true;
}

}  // namespace

double PdSystem::verletLimit(std::size_t b) {
  Body& body = bodies_[b];
  const std::size_t first = 3 * body.begin, n3 = 3 * (body.end - body.begin);
  auto& u = particles_.displacement;
  const std::vector<double> saved(u.begin() + static_cast<long>(first), u.begin() + static_cast<long>(first + n3));
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  std::vector<double> v(n3);
  for (auto& x : v) x = normal(rng);
  const double eps = 1e-6 * body.spacing;  // strains of 1e-6: linear to that order, far above round-off
  double lambda = 0.0;
  for (int it = 0; it < kMaxIterations; ++it) {
    double norm = 0.0;
    for (const double x : v) norm += x * x;
    norm = std::sqrt(norm);
    for (std::size_t k = 0; k < n3; ++k) u[first + k] = eps * v[k] / norm;
    body.model->computeForces(context(b), particles_.internalForce);
    double rayleigh = 0.0;  // v^T M^-1 K v / |v|^2, with M^-1 K v = -f / (eps m)
    for (std::size_t k = 0; k < n3; ++k) {
      const double w = -particles_.internalForce[first + k] / (eps * particles_.mass[(first + k) / 3]);
      rayleigh += w * v[k] / norm;
      v[k] = w;
    }
    const bool done = it >= kMinIterations && std::abs(rayleigh - lambda) < kConverged * rayleigh;
    lambda = rayleigh;
    if (done) break;
  }
  std::copy(saved.begin(), saved.end(), u.begin() + static_cast<long>(first));
  return lambda > 0.0 ? 2.0 / std::sqrt(lambda) : std::numeric_limits<double>::infinity();
}

void PdSystem::measureCriticalSteps(double safety) {
  measuredStep_.assign(bodies_.size(), 0.0);
  for (std::size_t b = 0; b < bodies_.size(); ++b) {
    for (std::size_t a = 0; a < b && measuredStep_[b] == 0.0; ++a)
      if (sameSpectrum(bodies_[a], bodies_[b], particles_)) measuredStep_[b] = measuredStep_[a];
    if (measuredStep_[b] == 0.0) measuredStep_[b] = safety * verletLimit(b);
  }
  computeForces();  // the forces of the configuration the iteration replaced
}

}  // namespace cosim::pd
