// The critical step pd_solver reports (0.45 delta / c_p, after Hartmann 2022
// Eqs. 41-42; PdSystem::criticalTimeStep) against the true stability limit of
// velocity Verlet on the body, dt = 2 / omega_max, with omega_max^2 the
// largest eigenvalue of M^-1 K found by power iteration on the force of a
// tiny displacement (the models are linear in it to round-off). The coupler
// refuses a dt above the reported step, so it must lie below the limit for
// every model, Poisson ratio, horizon and influence function, and for bodies
// whose surface particles have one-sided families (cube corners, a sphere's
// shell), which stiffen the highest modes. Eq. 42's h / sqrt(K / rho) fails
// the delta = 1-2 h cases here (5-84 % above the limit).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

struct StabilityCase {
  const char* model;
  double nu;
  double horizon;  // in spacings
  bool sphere;
  const char* influence = "constant";
  bool correction = false;
};

/// omega_max^2 of the body by power iteration, to a relative change below 1e-6.
double largestEigenvalue(PdSystem& sys) {
  auto& p = sys.particles();
  const std::size_t n = p.size();
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  std::vector<double> v(3 * n);
  for (auto& x : v) x = normal(rng);
  const double eps = 1e-9 * sys.bodies()[0].spacing;  // displacements far below the spacing: linear response
  double lambda = 0.0;
  for (int it = 0; it < 3000; ++it) {
    double norm = 0.0;
    for (const double x : v) norm += x * x;
    norm = std::sqrt(norm);
    for (std::size_t k = 0; k < 3 * n; ++k) p.displacement[k] = eps * v[k] / norm;
    sys.computeForces();
    double rayleigh = 0.0;
    for (std::size_t i = 0; i < n; ++i)
      for (int a = 0; a < 3; ++a) {
        const std::size_t k = 3 * i + static_cast<std::size_t>(a);
        const double w = -p.internalForce[k] / (eps * p.mass[i]);  // M^-1 K v
        rayleigh += w * v[k] / norm;
        v[k] = w;
      }
    if (it > 50 && std::abs(rayleigh - lambda) < 1e-6 * rayleigh) return rayleigh;
    lambda = rayleigh;
  }
  ADD_FAILURE() << "power iteration did not converge";
  return lambda;
}

class PdStability : public ::testing::TestWithParam<StabilityCase> {};

TEST_P(PdStability, ReportedStepIsBelowTheVerletLimitOfTheBody) {
  const auto c = GetParam();
  const double h = 0.015;
  auto spec = test::box("body", c.model, 8, 8, 8, h, c.horizon, c.nu);
  if (c.sphere) {
    spec.shape = Shape::Sphere;
    spec.center = {0.0, 0.0, 0.0};
    spec.radius = 5.0 * h;
  }
  spec.options.influence = c.influence;
  spec.options.surfaceCorrection = c.correction;
  spec.material.youngsModulus = 1.0e8;
  spec.material.density = 1100.0;
  PdSystem sys;
  sys.addBody(spec);
  sys.finalise();
  const double limit = 2.0 / std::sqrt(largestEigenvalue(sys));
  const double reported = sys.criticalTimeStep();
  const double cp = sys.bodies()[0].spec.material.cflWaveSpeed();
  std::printf("[measured] %s nu = %.2f, delta = %.1f h, %s, influence %s%s, %zu particles: Verlet limit %.4g s = "
              "%.3f delta / c_p, reported %.4g s (limit / reported %.3f)\n",
              c.model, c.nu, c.horizon, c.sphere ? "sphere" : "cube", c.influence, c.correction ? ", corrected" : "",
              sys.particles().size(), limit, limit * cp / (c.horizon * h), reported, limit / reported);
  EXPECT_LT(reported, limit);
  // Conservative, but not by so much that dt: auto wastes most of the steps.
  EXPECT_GT(reported, limit / 3.0);
}

INSTANTIATE_TEST_SUITE_P(Pd, PdStability,
                         ::testing::Values(StabilityCase{"lps", 0.25, 2.0, false}, StabilityCase{"lps", 0.48, 2.0, false},
                                           StabilityCase{"lps", 0.48, 2.0, true}, StabilityCase{"lps", 0.25, 3.0, true},
                                           StabilityCase{"pmb", 0.25, 3.0, false}, StabilityCase{"pmb", 0.25, 2.0, true},
                                           StabilityCase{"lps", 0.25, 3.0, false}, StabilityCase{"lps", 0.25, 1.5, false},
                                           StabilityCase{"lps", 0.25, 1.0, false}, StabilityCase{"pmb", 0.25, 1.5, false},
                                           StabilityCase{"lps", 0.35, 4.0, false}, StabilityCase{"lps", 0.0, 2.0, false},
                                           StabilityCase{"lps", -0.3, 2.0, false}, StabilityCase{"pmb", 0.25, 4.0, false},
                                           StabilityCase{"lps", 0.4, 2.5, false}, StabilityCase{"pmb", 0.25, 2.5, true},
                                           StabilityCase{"lps", 0.25, 2.0, false, "inverse", false},
                                           StabilityCase{"lps", 0.25, 1.5, false, "inverse", true},
                                           StabilityCase{"lps", 0.25, 2.0, false, "gaussian", true},
                                           StabilityCase{"lps", 0.0, 1.5, false, "constant", true},
                                           StabilityCase{"lps", 0.3, 3.0, false, "constant", true}),
                         [](const auto& param_info) {
                           const auto& c = param_info.param;
                           // Nu125 is nu = 0.25, Delta15 is delta = 1.5 h.
                           return std::string(c.model) + "Nu" + std::to_string(static_cast<int>(100 * c.nu + 100)) + "Delta" +
                                  std::to_string(static_cast<int>(10 * c.horizon)) + (c.sphere ? "Sphere" : "Cube") + c.influence + (c.correction ? "Corrected" : "");
                         });

}  // namespace
}  // namespace cosim::pd
