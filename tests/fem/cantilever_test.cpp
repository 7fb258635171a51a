// Cantilever 0.8 x 0.8 x 12 m, E = 1e8 Pa, nu = 0, clamped at y = 0, tip load
// in z: static tip deflection against Timoshenko beam theory (Cheng 2022
// Sec. 6 cantilever). The load is small enough for the response to be linear.
#include <gtest/gtest.h>

#include <cmath>

#include "cosim/fem/analysis/modal.hpp"
#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

constexpr double kLoad = 100.0;  // N

TEST(FemCantilever, IncompatibleModesMatchTimoshenko) {
  const auto r = test::solveCantilever("incompatible-modes", 2, 30, 2, kLoad);
  const double ref = test::timoshenkoTip(kLoad, 12.0, 0.8, 0.8, 1e8, 0.0);
  std::printf("[cantilever incompatible-modes 2x30x2] tip %.6e m, Timoshenko %.6e m, error %.3f %%\n",
              r.tipDeflection, ref, 100.0 * (r.tipDeflection - ref) / ref);
  EXPECT_LT(std::abs(r.tipDeflection - ref) / ref, 0.02);
}

TEST(FemCantilever, FullIntegrationLocks) {
  const auto r = test::solveCantilever("full", 2, 30, 2, kLoad);
  const double ref = test::timoshenkoTip(kLoad, 12.0, 0.8, 0.8, 1e8, 0.0);
  std::printf("[cantilever full 2x30x2] tip %.6e m = %.3f of Timoshenko\n", r.tipDeflection, r.tipDeflection / ref);
  EXPECT_LT(r.tipDeflection / ref, 0.9);  // shear locking: visibly too stiff
}

TEST(FemCantilever, OnePointHourglassEnergySmall) {
  const auto r = test::solveCantilever("one-point", 4, 60, 4, kLoad);
  const double ref = test::timoshenkoTip(kLoad, 12.0, 0.8, 0.8, 1e8, 0.0);
  const double internal = r.strainEnergy + r.hourglassEnergy;
  std::printf("[cantilever one-point 4x60x4] tip %.6e m (%.3f of Timoshenko), hourglass / internal = %.3f %%\n",
              r.tipDeflection, r.tipDeflection / ref, 100.0 * r.hourglassEnergy / internal);
  EXPECT_LT(r.hourglassEnergy / internal, 0.05);
  EXPECT_LT(std::abs(r.tipDeflection - ref) / ref, 0.10);
}

}  // namespace
}  // namespace cosim::fem

// First bending frequency of the cantilever (rho = 1309 kg/m^3) on the
// refined 4 x 60 x 4 incompatible-modes mesh against Euler-Bernoulli
// f1 = 1.875104^2 / (2 pi) sqrt(E I / (rho A L^4)), within 2 %.
#include "cosim/fem/linalg/sparse_system.hpp"

namespace cosim::fem {
namespace {

TEST(FemCantilever, FirstBendingFrequency) {
  const double rho = 1309.0, E = 1e8, b = 0.8, L = 12.0, I = b * b * b * b / 12, A = b * b;
  const double fEB = 1.875104 * 1.875104 / (2 * M_PI) * std::sqrt(E * I / (rho * A * L * L * L * L));
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {b, L, b}, {4, 60, 4}), "incompatible-modes", E, 0.0, rho);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  const double f1 = lowestNaturalFrequency(*model);
  std::printf("[frequency incompatible-modes 4x60x4] f1 = %.5f Hz, Euler-Bernoulli %.5f Hz, error %.3f %%\n", f1, fEB,
              100.0 * (f1 - fEB) / fEB);
  EXPECT_LT(std::abs(f1 - fEB) / fEB, 0.02);
}

}  // namespace
}  // namespace cosim::fem
