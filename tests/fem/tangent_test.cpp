// The element tangent is the derivative of the internal force (consistent
// tangent for Newton): central finite differences at a finitely deformed
// state, for every formulation and material, agree to 1e-6 relative.
#include <gtest/gtest.h>

#include <random>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

class FemTangent : public ::testing::TestWithParam<std::tuple<std::string, std::string>> {};

TEST_P(FemTangent, MatchesFiniteDifferences) {
  const auto& [formulation, material] = GetParam();
  Mesh mesh = makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1});
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> shift(-0.1, 0.1);
  for (double& x : mesh.X) x += shift(rng);
  auto model = test::makeModel(std::move(mesh), formulation, 1e8, 0.3, 1000.0, material);
  Mat83 ue;
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = 0.1 * shift(rng);  // strains of a few percent
  Vec24 f0;
  Mat24 K;
  ElementEnergy en;
  model->formulation().evaluate(0, ue, f0, &K, en);
  const double h = 1e-7;
  double err = 0.0;
  for (int c = 0; c < 24; ++c) {
    Mat83 up = ue, um = ue;
    up(c / 3, c % 3) += h;
    um(c / 3, c % 3) -= h;
    Vec24 fp, fm;
    ElementEnergy e1, e2;
    model->formulation().evaluate(0, up, fp, nullptr, e1);
    model->formulation().evaluate(0, um, fm, nullptr, e2);
    err = std::max(err, ((fp - fm) / (2 * h) - K.col(c)).cwiseAbs().maxCoeff());
  }
  const double rel = err / K.cwiseAbs().maxCoeff();
  std::printf("[tangent %s %s] max |K - dF/du| / max |K| = %.3e\n", formulation.c_str(), material.c_str(), rel);
  EXPECT_LT(rel, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Fem, FemTangent,
                         ::testing::Combine(::testing::Values("full", "incompatible-modes", "one-point"),
                                            ::testing::Values("st-venant-kirchhoff", "neo-hookean")),
                         [](const auto& param) {
                           std::string s = std::get<0>(param.param) + "_" + std::get<1>(param.param);
                           std::erase(s, '-');
                           return s;
                         });

}  // namespace
}  // namespace cosim::fem
