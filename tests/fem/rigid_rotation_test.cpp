// A 90 degree rigid rotation of a distorted mesh produces no strain and no
// stress in the total Lagrangian formulation (objectivity).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

class FemRigidRotation : public ::testing::TestWithParam<std::string> {};

TEST_P(FemRigidRotation, NinetyDegreesGivesNoStress) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {1, 2, 1}, {2, 3, 2});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> shift(-0.05, 0.05);
  for (double& x : mesh.X) x += shift(rng);
  const double E = 2e8;
  auto model = test::makeModel(std::move(mesh), GetParam(), E, 0.3, 1000.0);
  const Vec3 axis = Vec3(1, 2, 3).normalized();
  const Mat3 R = Eigen::AngleAxisd(M_PI / 2, axis).toRotationMatrix();
  const Mesh& m = model->mesh();
  std::vector<double> u(model->numDofs());
  for (Index n = 0; n < m.numNodes(); ++n) {
    const Vec3 d = (R - Mat3::Identity()) * m.node(n);
    for (int i = 0; i < 3; ++i) u[3 * n + static_cast<std::size_t>(i)] = d[i];
  }
  double smax = 0.0;
  std::vector<MaterialPointState> pts(static_cast<std::size_t>(model->formulation().pointsPerElement()));
  for (std::size_t e = 0; e < m.numElements(); ++e) {
    model->formulation().pointStates(e, model->gather(e, u), pts.data());
    for (const auto& p : pts) smax = std::max(smax, p.S.cwiseAbs().maxCoeff());
  }
  std::vector<double> f;
  ElementEnergy en;
  model->internalForce(u, f, en);
  double fmax = 0.0;
  for (double v : f) fmax = std::max(fmax, std::abs(v));
  std::printf("[rotation %s] max |S| / E = %.3e, max |f_int| / (E h^2) = %.3e, hourglass energy %.3e J\n",
              GetParam().c_str(), smax / E, fmax / (E * 0.25), en.hourglass);
  EXPECT_LT(smax / E, 1e-10);
  EXPECT_LT(fmax / (E * 0.25), 1e-10);
  EXPECT_LT(en.hourglass, 1e-10 * E * 0.125);
}

INSTANTIATE_TEST_SUITE_P(Fem, FemRigidRotation, ::testing::Values("full", "incompatible-modes", "one-point"),
                         [](const auto& param) {
                           std::string s = param.param;
                           std::erase(s, '-');
                           return s;
                         });

}  // namespace
}  // namespace cosim::fem
