// Hertz normal law (class in builtin_laws.hpp): registration, contact time and
// the damping calibration for a requested restitution.
#include <cmath>
#include <map>
#include <mutex>
#include <numbers>

#include "cosim/dem/contact/builtin_laws.hpp"

namespace cosim::dem {
namespace {

const bool registered = NormalLawRegistry::add("hertz", [] { return std::make_unique<HertzNormal>(); });

// Restitution of the dimensionless damped Hertz impact. With u = u0 x,
// t = (u0/v0) tau, u0 = (m* v0^2 / K)^(2/5), K = 4/3 E* sqrt(R*), the law
// m* u'' = -K u^(3/2) - gamma sqrt(S_n m*) u', S_n = 3/2 K u^(1/2), becomes
// x'' = -x^(3/2) - gamma sqrt(3/2) x^(1/4) x', x(0) = 0, x'(0) = 1: the
// restitution depends on gamma only (Tsuji 1992), so one calibration serves
// every velocity. Contact ends when x returns to 0 (no force clamp).
double restitutionOf(double gamma) {
  const double c = gamma * std::sqrt(1.5);
  auto acc = [c](double x, double v) {
    const double xp = x > 0.0 ? x : 0.0;
    return -xp * std::sqrt(xp) - c * std::sqrt(std::sqrt(xp)) * v;
  };
  const double h = 2e-4;
  double x = 0.0, v = 1.0;
  for (int step = 0; step < 200000; ++step) {
    // Classical RK4 on (x, v).
    const double k1x = v, k1v = acc(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = acc(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const double vn = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (step > 0 && xn <= 0.0) {
      const double s = x / (x - xn);  // linear crossing
      return -(v + s * (vn - v));
    }
    x = xn;
    v = vn;
  }
  return 0.0;  // never separated: fully inelastic
}

}  // namespace

// Elastic Hertz impact (Johnson 1985, Sec. 11.4): u_max = (15 m* v^2 / (16 E* sqrt R*))^(2/5),
// t_c = 2 u_max / v * int_0^1 dx / sqrt(1 - x^(5/2)) = 2.9432 u_max / v.
double HertzNormal::contactTime(double mEff, double rEff, double v, const PairMaterial& pm) const {
  const double umax = std::pow(15.0 * mEff * v * v / (16.0 * pm.eEff * std::sqrt(rEff)), 0.4);
  static const double integral = 0.4 * std::tgamma(0.4) * std::tgamma(0.5) / std::tgamma(0.9);
  return 2.0 * umax / v * integral;
}

double hertzDampingCoefficient(double e) {
  if (e >= 1.0) return 0.0;
  static std::mutex mutex;
  static std::map<double, double> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  if (const auto it = cache.find(e); it != cache.end()) return it->second;
  // The LIGGGHTS closed form 2 sqrt(5/6) beta, beta = -ln e / sqrt(ln^2 e + pi^2), is only
  // approximate for Hertz; bisect on the exact restitution instead (monotone in gamma).
  double lo = 0.0, hi = 1.0;
  while (restitutionOf(hi) > e && hi < 1e3) hi *= 2.0;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (restitutionOf(mid) > e ? lo : hi) = mid;
    if (hi - lo < 1e-10 * hi) break;
  }
  const double gamma = 0.5 * (lo + hi);
  cache.emplace(e, gamma);
  return gamma;
}

}  // namespace cosim::dem
