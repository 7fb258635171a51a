// Critical-stretch damage of the bond-based model: bonds break exactly where
// their stretch exceeds s0, stay broken, and carry no force.
#include <gtest/gtest.h>

#include <cstdio>
#include <numeric>

#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

double stretchOf(const Particles& p, std::size_t i, std::size_t j, double len) {
  double y2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double y = p.current(j, a) - p.current(i, a);
    y2 += y * y;
  }
  return (std::sqrt(y2) - len) / len;
}

// Test-side force of Hartmann Eq. 12 over the intact bonds only.
std::vector<double> intactBondForces(const PdSystem& sys) {
  const auto& p = sys.particles();
  const auto& body = sys.bodies()[0];
  const auto& b = body.bonds;
  const double c = 18.0 * body.spec.material.bulkModulus() / (M_PI * std::pow(body.horizon, 4));
  std::vector<double> f(3 * p.size(), 0.0);
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
      if (b.broken[k]) continue;
      const std::size_t j = b.neighbor[k];
      double y[3], len = 0.0;
      for (int a = 0; a < 3; ++a) {
        y[a] = p.current(j, a) - p.current(i, a);
        len += y[a] * y[a];
      }
      len = std::sqrt(len);
      const double s = (len - b.length[k]) / b.length[k];
      for (int a = 0; a < 3; ++a)
        f[3 * i + a] += c * s * b.volumeFraction[k] * p.volume[j] * p.volume[i] * y[a] / len;
    }
  return f;
}

TEST(PdDamage, BondsBreakExactlyWhereStretchExceedsCriticalAndCarryNoForce) {
  const double h = 1e-3, s0 = 1e-3;
  PdSystem sys;
  auto spec = test::box("bar", "pmb", 20, 4, 4, h, 3.0);
  spec.options.criticalStretch = s0;
  sys.addBody(spec);
  sys.finalise();
  auto& p = sys.particles();
  // Strain 3 s0 in the slab 9 h < X < 11 h, 0.2 s0 elsewhere (continuous u_x).
  auto ux = [&](double X) {
    const double a = 9 * h, b = 11 * h;
    if (X < a) return 0.2 * s0 * X;
    if (X < b) return 0.2 * s0 * a + 3.0 * s0 * (X - a);
    return 0.2 * s0 * a + 3.0 * s0 * (b - a) + 0.2 * s0 * (X - b);
  };
  for (std::size_t i = 0; i < p.size(); ++i) p.displacement[3 * i] = ux(p.reference[3 * i]);
  sys.computeForces();  // breaks bonds, then forces
  const auto& b = sys.bodies()[0].bonds;
  std::size_t broken = 0, mismatched = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
      const bool over = stretchOf(p, i, b.neighbor[k], b.length[k]) > s0;
      mismatched += (over != static_cast<bool>(b.broken[k]));
      broken += b.broken[k];
    }
  std::printf("[measured] static field: %zu of %zu bonds broken, %zu mismatches against s > s0\n", broken,
              b.count(), mismatched);
  EXPECT_GT(broken, 0u);
  EXPECT_LT(broken, b.count());
  EXPECT_EQ(mismatched, 0u);
  // Every broken bond crosses the strained slab.
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k)
      if (b.broken[k]) {
        const double x1 = p.reference[3 * i], x2 = p.reference[3 * b.neighbor[k]];
        EXPECT_TRUE(std::max(x1, x2) > 9 * h && std::min(x1, x2) < 11 * h);
      }
  // Forces equal the sum over intact bonds only; breaking is irreversible.
  auto check = [&](const char* what) {
    const auto ref = intactBondForces(sys);
    double err = 0.0, scale = 0.0;
    for (std::size_t q = 0; q < ref.size(); ++q) {
      err = std::max(err, std::abs(ref[q] - p.internalForce[q]));
      scale = std::max(scale, std::abs(ref[q]));
    }
    std::printf("[measured] %s: max |f - f_intact| / max |f| = %.2e\n", what, err / scale);
    EXPECT_LT(err, 1e-12 * scale);
  };
  check("stretched");
  for (std::size_t i = 0; i < p.size(); ++i) p.displacement[3 * i] = 2.0 * ux(p.reference[3 * i]) - 1e-4 * h;
  const std::size_t before = broken;
  sys.computeForces();
  check("stretched further");
  std::size_t after = std::accumulate(b.broken.begin(), b.broken.end(), std::size_t{0});
  EXPECT_GE(after, before);
}

TEST(PdDamage, BarPulledApartSeparatesWhereStretchExceedsCritical) {
  const double h = 1e-3, s0 = 2e-3;
  const int nx = 30;
  PdSystem sys;
  auto spec = test::box("bar", "pmb", nx, 3, 3, h, 3.0);
  spec.options.criticalStretch = s0;
  sys.addBody(spec);
  // Ends pulled apart at 0.75 s0 c each. The sudden start concentrates the
  // stretch next to the driven layers, so the bar separates near an end (the
  // location is printed); what is checked is the criterion at every step.
  const double c = std::sqrt(spec.material.youngsModulus / spec.material.density);
  const double v = 0.75 * s0 * c;
  for (int side = 0; side < 2; ++side) {
    BoundaryCondition bc;
    bc.where.hasBox = true;
    bc.where.min = {side ? (nx - 1) * h : -1.0, -1.0, -1.0};
    bc.where.max = {side ? 1.0 : h, 1.0, 1.0};
    bc.type = Constraint::Velocity;
    bc.velocity = {side ? v : -v, 0.0, 0.0};
    sys.addBoundaryCondition(bc);
  }
  sys.finalise();
  const auto& p = sys.particles();
  const auto& b = sys.bodies()[0].bonds;
  std::vector<std::uint8_t> was(b.broken);
  const double dt = 0.5 * sys.criticalTimeStep();
  std::size_t violations = 0;
  double firstBreakX = -1.0;
  for (int s = 0; s < 400; ++s) {
    sys.step(dt);
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        const double st = stretchOf(p, i, b.neighbor[k], b.length[k]);
        if (b.broken[k] && !was[k]) {
          violations += st <= s0;  // newly broken: must be over-stretched now
          if (firstBreakX < 0.0) firstBreakX = 0.5 * (p.reference[3 * i] + p.reference[3 * b.neighbor[k]]);
        }
        if (!b.broken[k]) violations += st > s0;  // intact: must not be
      }
    was = b.broken;
  }
  // Two pieces: no intact bond crosses some plane x = const.
  int cutLayer = -1;
  for (int layer = 1; layer < nx && cutLayer < 0; ++layer) {
    bool crossed = false;
    for (std::size_t i = 0; i < p.size() && !crossed; ++i)
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k)
        if (!b.broken[k] && p.reference[3 * i] < layer * h && p.reference[3 * b.neighbor[k]] > layer * h) {
          crossed = true;
          break;
        }
    if (!crossed) cutLayer = layer;
  }
  std::printf("[measured] pulled bar: first break at X = %.2f h, separated at plane x = %d h (of %d), %zu violations\n",
              firstBreakX / h, cutLayer, nx, violations);
  EXPECT_EQ(violations, 0u);
  EXPECT_GT(cutLayer, 0);  // separated into two pieces
}

}  // namespace
}  // namespace cosim::pd
