// Arlequin weighting (Cheng 2022 Eq. 25): FEM element integrals carry 1 - w.
// With a linear profile over the whole bar, int (1 - w) dV = V / 2 exactly
// (2x2x2 Gauss integrates it exactly), so the weighted mass is half the
// mass and a homogeneous strain stores half its energy; a half-cosine zone
// gives the analytic weighted mass.
#include <gtest/gtest.h>

#include <numeric>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

class FemArlequin : public ::testing::TestWithParam<std::string> {};

TEST_P(FemArlequin, WeightsMassAndStrainEnergy) {
  const double rho = 1000.0, L = 4.0;
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {0.5, L, 0.5}, {2, 16, 2}), GetParam(), 1e8, 0.25, rho);
  std::vector<double> u(model->numDofs(), 0.0), f;
  for (Index n = 0; n < model->numNodes(); ++n) u[3 * n + 1] = 1e-4 * model->mesh().node(n)[1];
  ElementEnergy full;
  model->internalForce(u, f, full);
  const double mass0 = std::accumulate(model->lumpedMass().begin(), model->lumpedMass().end(), 0.0);
  model->setArlequinWeight({"linear", 1, -1e-9 * L, L * (1 + 1e-9)});  // w from 1 at y = 0 to 0 at y = L
  ElementEnergy weighted;
  model->internalForce(u, f, weighted);
  const double mass1 = std::accumulate(model->lumpedMass().begin(), model->lumpedMass().end(), 0.0);
  std::printf("[arlequin %s] mass ratio %.12f, strain energy ratio %.12f (exact 0.5)\n", GetParam().c_str(),
              mass1 / mass0, weighted.strain / full.strain);
  EXPECT_NEAR(mass0, rho * 0.25 * L, 1e-9 * mass0);
  EXPECT_NEAR(mass1 / mass0, 0.5, 1e-8);
  if (GetParam() == "incompatible-modes") {
    // The enhanced modes minimise the weighted energy: with 1 - w varying
    // inside an element they relax the homogeneous state a little (never
    // above the compatible value 0.5).
    EXPECT_LE(weighted.strain / full.strain, 0.5 + 1e-12);
    EXPECT_NEAR(weighted.strain / full.strain, 0.5, 0.005);
  } else {
    EXPECT_NEAR(weighted.strain / full.strain, 0.5, 1e-8);
  }
}

INSTANTIATE_TEST_SUITE_P(Fem, FemArlequin, ::testing::Values("full", "incompatible-modes", "one-point"),
                         [](const auto& param) {
                           std::string s = param.param;
                           std::erase(s, '-');
                           return s;
                         });

TEST(FemArlequinProfile, HalfCosineZoneMass) {
  // FEM on y in [8, 20], zone [8, 12]: int (1 - w) dy = 4 / 2 + 8 = 10 m.
  auto model = test::makeModel(makeBoxMesh({0, 8, 0}, {0.8, 20, 0.8}, {2, 60, 2}), "full", 1e8, 0.0, 1000.0);
  model->setArlequinWeight({"half-cosine", 1, 8.0, 12.0});
  const double m = std::accumulate(model->lumpedMass().begin(), model->lumpedMass().end(), 0.0);
  const double exact = 1000.0 * 0.64 * 10.0;
  std::printf("[arlequin half-cosine] weighted mass %.6f kg, exact %.6f kg, error %.2e\n", m, exact,
              std::abs(m - exact) / exact);
  EXPECT_NEAR(m / exact, 1.0, 1e-4);
  // A node where 1 - w vanishes all around would have no mass: named error.
  auto bad = test::makeModel(makeBoxMesh({0, 0, 0}, {1, 4, 1}, {1, 4, 1}), "full", 1e8, 0.0, 1000.0);
  try {
    bad->setArlequinWeight({"linear", 1, 2.0, 3.0});
    ADD_FAILURE() << "expected an error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::fem
