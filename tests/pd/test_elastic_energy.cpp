// Interior strain energy density under homogeneous uniaxial strain and simple
// shear against classical linear elasticity: W = (lambda + 2G) eps^2 / 2 and
// W = G gamma^2 / 2 (LPS, Hartmann Eq. 24; bond-based with nu = 0.25, Eq. 10).
//
// Horizon 4 h: at 3 h the cubic lattice's fourth moment is anisotropic by
// about 1 % (printed below for reference), which is a property of the
// one-point quadrature, not of the models. The bond-based model uses the
// discrete micromodulus (pi delta^4 replaced by its lattice quadrature); the
// paper's continuum c is printed for reference (it overshoots by the
// quadrature error of the partial-volume rule).
#include <gtest/gtest.h>

#include <cstdio>

#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

struct EnergyCase {
  const char* model;
  double nu;
  bool shear;
};

double interiorEnergyError(const EnergyCase& c, double factor, const std::string& micromodulus) {
  const double h = 1e-3, strain = 1e-5;
  PdSystem sys;
  auto spec = test::box("block", c.model, 14, 14, 14, h, factor, c.nu);
  spec.options.micromodulus = micromodulus;
  sys.addBody(spec);
  sys.finalise();
  test::Mat3 F{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  if (c.shear) F[0][1] = strain;  // u_x = gamma y
  else F[0][0] += strain;         // uniaxial strain along x
  test::applyAffine(sys.particles(), F);
  const auto W = sys.bodies()[0].model->energyDensity(sys.context(0));
  const auto inner = test::interior(sys.particles(), spec, factor * h + 0.5 * h);
  if (inner.empty()) return 1e9;
  double mean = 0.0;
  for (const auto i : inner) mean += W[i];
  mean /= static_cast<double>(inner.size());
  const auto& m = spec.material;
  const double expected = c.shear ? 0.5 * m.shearModulus() * strain * strain
                                  : 0.5 * (m.lameLambda() + 2.0 * m.shearModulus()) * strain * strain;
  return mean / expected - 1.0;
}

class PdElasticEnergy : public ::testing::TestWithParam<EnergyCase> {};

TEST_P(PdElasticEnergy, InteriorDensityMatchesClassicalWithinOnePercent) {
  const auto c = GetParam();
  const bool pmb = std::string(c.model) == "pmb";
  const double err = interiorEnergyError(c, 4.0, pmb ? "discrete" : "continuum");
  std::printf("[measured] %s nu=%.2f %s, delta=4h%s: W_pd/W_classical - 1 = %+.4f %%\n", c.model, c.nu,
              c.shear ? "shear" : "uniaxial", pmb ? " (discrete c)" : "", 100.0 * err);
  std::printf("[measured]   for reference, delta=3h: %+.4f %%, delta=2h: %+.4f %%\n",
              100.0 * interiorEnergyError(c, 3.0, pmb ? "discrete" : "continuum"),
              100.0 * interiorEnergyError(c, 2.0, pmb ? "discrete" : "continuum"));
  if (pmb)
    std::printf("[measured]   for reference, continuum c = 18K/(pi delta^4): delta=4h %+.4f %%, delta=3h %+.4f %%\n",
                100.0 * interiorEnergyError(c, 4.0, "continuum"), 100.0 * interiorEnergyError(c, 3.0, "continuum"));
  EXPECT_LT(std::abs(err), 0.01);
}

INSTANTIATE_TEST_SUITE_P(Pd, PdElasticEnergy,
                         ::testing::Values(EnergyCase{"pmb", 0.25, false}, EnergyCase{"pmb", 0.25, true},
                                           EnergyCase{"lps", 0.25, false}, EnergyCase{"lps", 0.25, true},
                                           EnergyCase{"lps", 0.35, false}, EnergyCase{"lps", 0.35, true}),
                         [](const auto& param_info) {
                           return std::string(param_info.param.model) + (param_info.param.nu > 0.3 ? "Nu035" : "Nu025") +
                                  (param_info.param.shear ? "Shear" : "Uniaxial");
                         });

}  // namespace
}  // namespace cosim::pd
