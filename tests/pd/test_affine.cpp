// Homogeneous affine deformation (patch test): interior particles feel no net
// force, and the correspondence deformation gradient (Hartmann Eqs. 26-27)
// reproduces the applied F.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "cosim/pd/correspondence.hpp"
#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

const test::Mat3 kF{{{1.001, 2e-4, -3e-4}, {5e-4, 0.998, 1e-4}, {-1e-4, 3e-4, 1.0015}}};

struct AffineCase {
  const char* model;
  bool correction;
};

class PdAffine : public ::testing::TestWithParam<AffineCase> {};

TEST_P(PdAffine, InteriorForceVanishesAndCorrespondenceFIsExact) {
  const auto c = GetParam();
  const double h = 1e-3;
  PdSystem sys;
  auto spec = test::box("block", c.model, 18, 18, 18, h, 3.0);
  spec.options.surfaceCorrection = c.correction;
  sys.addBody(spec);
  sys.finalise();
  test::applyAffine(sys.particles(), kF);
  sys.computeForces();
  const auto& p = sys.particles();
  const double delta = 3.0 * h;
  // Scale: the largest (unbalanced) force on any particle, reached at the surface.
  double scale = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    scale = std::max(scale, std::hypot(p.internalForce[3 * i], p.internalForce[3 * i + 1], p.internalForce[3 * i + 2]));
  ASSERT_GT(scale, 0.0);
  // Interior: the family and every partner's family lie inside the body (2 delta + h/2).
  const auto inner = test::interior(p, spec, 2.0 * delta + 0.5 * h);
  ASSERT_GT(inner.size(), 0u);
  double worst = 0.0;
  for (const auto i : inner)
    worst = std::max(worst, std::hypot(p.internalForce[3 * i], p.internalForce[3 * i + 1], p.internalForce[3 * i + 2]));
  std::printf("[measured] %s correction=%d: interior |f|/max|f| = %.3e over %zu particles\n", c.model,
              c.correction, worst / scale, inner.size());
  EXPECT_LT(worst / scale, 1e-10);

  const auto corr = correspondence(sys.context(0));
  double errF = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        errF = std::max(errF, std::abs(corr.deformationGradient[9 * i + 3 * a + b] - kF[a][b]));
  std::printf("[measured] %s: max |F_corr - F| over all %zu particles = %.3e\n", c.model, p.size(), errF);
  EXPECT_LT(errF, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Pd, PdAffine,
                         ::testing::Values(AffineCase{"pmb", false}, AffineCase{"pmb", true},
                                           AffineCase{"lps", false}, AffineCase{"lps", true}),
                         [](const auto& param_info) {
                           return std::string(param_info.param.model) + (param_info.param.correction ? "Corrected" : "Plain");
                         });

TEST(PdCorrespondence, StressOfAffineStretchMatchesNeoHookean) {
  // Uniaxial stretch F = diag(1.01, 1, 1): Eq. 29-30 in closed form.
  PdSystem sys;
  auto spec = test::box("block", "lps", 8, 8, 8, 1e-3, 3.0, 0.3);
  sys.addBody(spec);
  sys.finalise();
  const test::Mat3 F{{{1.01, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  test::applyAffine(sys.particles(), F);
  const auto corr = correspondence(sys.context(0));
  const double G = spec.material.shearModulus(), lam = spec.material.lameLambda();
  const double J = 1.01, C11 = J * J;
  const double S11 = G * (1.0 - 1.0 / C11) + 0.5 * lam * (J * J - 1.0) / C11;
  const double S22 = 0.5 * lam * (J * J - 1.0);
  const double sig11 = J * S11 * J / J, sig22 = S22 / J;
  const double E11 = 0.5 * (C11 - 1.0);
  for (std::size_t i = 0; i < sys.particles().size(); ++i) {
    EXPECT_NEAR(corr.greenLagrange[6 * i], E11, 1e-12);
    EXPECT_NEAR(corr.cauchy[6 * i] / sig11, 1.0, 1e-10);
    EXPECT_NEAR(corr.cauchy[6 * i + 1] / sig22, 1.0, 1e-10);
    EXPECT_NEAR(corr.vonMises[i] / std::abs(sig11 - sig22), 1.0, 1e-10);
  }
}

}  // namespace
}  // namespace cosim::pd
