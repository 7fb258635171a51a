// Longitudinal wave speed in a slender LPS bar against the 1-D bar speed
// c = sqrt(E / rho). The bar is released with the velocity field of its first
// free-free mode, v_x = v0 cos(pi X / L); its modal coordinate
// a(t) = sum m u_x cos(pi X / L) first returns to zero at t = L / c.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

double measuredBarSpeed(int nx, int ny, double factor, bool correction, std::size_t* stepsOut = nullptr) {
  const double h = 1e-3;
  PdSystem sys;
  auto spec = test::box("bar", "lps", nx, ny, ny, h, factor, 0.25);
  spec.options.surfaceCorrection = correction;
  sys.addBody(spec);
  sys.finalise();
  auto& p = sys.particles();
  const double L = nx * h, v0 = 1e-3;
  std::vector<double> shape(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    shape[i] = std::cos(std::numbers::pi * p.reference[3 * i] / L);
    p.velocity[3 * i] = v0 * shape[i];
  }
  auto modal = [&] {
    double a = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) a += p.mass[i] * p.displacement[3 * i] * shape[i];
    return a;
  };
  const double c0 = std::sqrt(spec.material.youngsModulus / spec.material.density);
  const double dt = 0.5 * sys.criticalTimeStep();
  double prev = modal();
  std::size_t step = 0;
  const auto maxSteps = static_cast<std::size_t>(2.0 * L / c0 / dt);
  while (step < maxSteps) {
    sys.step(dt);
    ++step;
    const double a = modal();
    if (step > 2 && prev > 0.0 && a <= 0.0) {
      const double tCross = sys.time() - dt * a / (a - prev);  // linear interpolation
      if (stepsOut) *stepsOut = step;
      return L / tCross;
    }
    prev = a;
  }
  return 0.0;
}

TEST(PdWaveSpeed, SlenderLpsBarWithinTwoPercentOfBarSpeed) {
  // 60 x 5 x 5 particles, horizon 3 h: every particle is within the
  // horizon of a lateral surface, so the surface correction is what makes
  // the bar respond with E (the plain model is printed for reference).
  const int nx = 60, ny = 5;
  const double factor = 3.0;
  const double c0 = std::sqrt(1.0e9 / 1000.0);
  std::size_t steps = 0;
  const double cOn = measuredBarSpeed(nx, ny, factor, true, &steps);
  const double cOff = measuredBarSpeed(nx, ny, factor, false);
  std::printf("[measured] LPS bar %dx%dx%d, delta=%.1fh: c/sqrt(E/rho) - 1 = %+.3f %% with surface correction "
              "(%zu steps), %+.3f %% without\n", nx, ny, ny, factor, 100.0 * (cOn / c0 - 1.0), steps,
              100.0 * (cOff / c0 - 1.0));
  EXPECT_LT(std::abs(cOn / c0 - 1.0), 0.02);
}

}  // namespace
}  // namespace cosim::pd
