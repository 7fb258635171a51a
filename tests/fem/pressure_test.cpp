// Follower pressure: a cube under hydrostatic pressure p on its three free
// faces (symmetry planes on the others) deforms homogeneously, F = lambda I,
// with Cauchy stress -p I. For St. Venant-Kirchhoff, sigma = S / lambda with
// S = (3 lambda_L + 2 mu) (lambda^2 - 1) / 2, so lambda solves
// (3 lambda_L + 2 mu) (lambda^2 - 1) / (2 lambda) = -p. A dead load of the
// same magnitude gives a different stretch (its area does not shrink).
#include <gtest/gtest.h>

#include <cmath>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

TEST(FemPressure, HydrostaticCubeFollowsTheFaces) {
  const double E = 1e8, nu = 0.3, p = 3e6;
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {2, 2, 2}), "full", E, nu, 1000.0);
  const char* sym[3] = {"xmin", "ymin", "zmin"};
  for (int d = 0; d < 3; ++d)
    for (Index n : model->mesh().nodeSet(sym[d])) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  for (const char* f : {"xmax", "ymax", "zmax"}) model->addPressure(model->mesh().faceSet(f), p);
  State state;
  state.resize(model->numDofs());
  const NewtonReport r = solveStatic(*model, state, NewtonOptions{});
  const double lam = model->material().lambda(), mu = model->material().mu(), k = 3 * lam + 2 * mu;
  double stretch = 1.0;  // scalar Newton on g(l) = k (l^2 - 1) / (2 l) + p
  for (int i = 0; i < 50; ++i) stretch -= (k * (stretch * stretch - 1) / (2 * stretch) + p) / (k * (0.5 + 0.5 / (stretch * stretch)));
  const Index corner = model->mesh().nodesInBox({0.99, 0.99, 0.99}, {1.01, 1.01, 1.01})[0];
  const double u = state.u[3 * corner];
  std::printf("[pressure] corner u = %.10e m, exact lambda - 1 = %.10e, relative error %.2e, Newton iterations %d\n", u,
              stretch - 1, std::abs(u - (stretch - 1)) / std::abs(stretch - 1), r.iterations);
  EXPECT_LT(std::abs(u - (stretch - 1)) / std::abs(stretch - 1), 1e-8);
}

}  // namespace
}  // namespace cosim::fem
