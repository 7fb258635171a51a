// Patch test: a linear displacement field on the boundary of a distorted
// mesh must be reproduced exactly inside, with uniform stress, by every
// formulation (constant strain; finite strain F = I + A is also an exact
// equilibrium state of the total Lagrangian problem).
#include <gtest/gtest.h>

#include <random>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

class FemPatch : public ::testing::TestWithParam<std::string> {};

TEST_P(FemPatch, DistortedMeshIsExact) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {1, 1, 1}, {3, 3, 3});
  // Move the interior nodes by up to 15 % of the element size.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> shift(-0.05, 0.05);
  std::vector<char> boundary(mesh.numNodes(), 0);
  for (const char* s : {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"})
    for (Index n : mesh.nodeSet(s)) boundary[n] = 1;
  int interior = 0;
  for (Index n = 0; n < mesh.numNodes(); ++n)
    if (!boundary[n]) {
      ++interior;
      for (int d = 0; d < 3; ++d) mesh.X[3 * n + static_cast<std::size_t>(d)] += shift(rng);
    }
  ASSERT_EQ(interior, 8);
  auto model = test::makeModel(std::move(mesh), GetParam(), 2.0e8, 0.3, 1000.0);
  Mat3 A;
  A << 2e-3, 1e-3, -5e-4, 3e-4, -1e-3, 7e-4, 6e-4, -2e-4, 1.5e-3;
  const Mesh& m = model->mesh();
  for (Index n = 0; n < m.numNodes(); ++n)
    if (boundary[n]) {
      const Vec3 u = A * m.node(n);
      for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, u[d]);
    }
  State state;
  state.resize(model->numDofs());
  solveStatic(*model, state, NewtonOptions{1e-13, 25, "direct"});
  double err = 0.0;
  for (Index n = 0; n < m.numNodes(); ++n) {
    const Vec3 exact = A * m.node(n);
    for (int d = 0; d < 3; ++d) err = std::max(err, std::abs(state.u[3 * n + static_cast<std::size_t>(d)] - exact[d]));
  }
  // Stress at every material point equals S(I + A).
  Mat3 Sexact;
  double W = 0.0;
  model->material().evaluate(A, Sexact, nullptr, W);
  double serr = 0.0;
  std::vector<MaterialPointState> pts(static_cast<std::size_t>(model->formulation().pointsPerElement()));
  for (std::size_t e = 0; e < m.numElements(); ++e) {
    model->formulation().pointStates(e, model->gather(e, state.u), pts.data());
    for (const auto& p : pts) serr = std::max(serr, (p.S - Sexact).cwiseAbs().maxCoeff());
  }
  std::vector<double> f;
  ElementEnergy en;
  model->internalForce(state.u, f, en);
  std::printf("[patch %s] max |u - A X| = %.3e m, max |S - S_exact| / |S_exact| = %.3e, hourglass energy = %.3e J\n",
              GetParam().c_str(), err, serr / Sexact.cwiseAbs().maxCoeff(), en.hourglass);
  EXPECT_LT(err, 1e-10 * A.cwiseAbs().maxCoeff());
  EXPECT_LT(serr / Sexact.cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT(en.hourglass, 1e-10 * en.strain);
}

INSTANTIATE_TEST_SUITE_P(Fem, FemPatch, ::testing::Values("full", "incompatible-modes", "one-point"),
                         [](const auto& param) {
                           std::string s = param.param;
                           std::erase(s, '-');
                           return s;
                         });

}  // namespace
}  // namespace cosim::fem
