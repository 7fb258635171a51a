// The linear solvers behind Newmark and the static solve: every name solves
// the C1 beam's Newmark system (K_0 + M / (beta dt^2), 810 free dofs) to
// round-off and agrees with the others; a system without supports is named
// singular, with a dof of the floating body, by every direct solver.
#include <gtest/gtest.h>

#include <random>

#include "cosim/fem/linalg/sparse_system.hpp"
#include "cosim/fem/mesh/mesh.hpp"
#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

/// K_0 + c0 M of the 0.8 x 12 x 0.8 m beam on 2 x 30 x 2 elements, clamped at y = 0 unless free.
SparseSystem beamSystem(bool clamped, double c0) {
  auto model = test::makeModel(makeBoxMesh({-0.4, 0, 0}, {0.4, 12.0, 0.8}, {2, 30, 2}), "full", 1e8, 0.0, 1309.0);
  if (clamped)
    for (Index n : model->mesh().nodeSet("ymin"))
      for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  return model->shiftedStiffness(c0);
}

std::vector<std::string> availableSolvers() {
  std::vector<std::string> names;
  for (const auto& n : linearSolverNames()) {
    try {
      makeLinearSolver(n);
      names.push_back(n);
    } catch (const InputError&) {  // cholmod in a build without it
    }
  }
  return names;
}

TEST(FemLinearSolvers, EverySolverSolvesTheBeamSystemToRoundOff) {
  const SparseSystem A = beamSystem(true, 1.0 / (0.25 * 6.43e-5 * 6.43e-5));
  ASSERT_EQ(A.size(), 810);  // 279 nodes, the 9 at y = 0 clamped
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd b(A.size());
  for (auto& v : b) v = u(rng);
  Eigen::VectorXd reference;
  for (const auto& name : availableSolvers()) {
    auto solver = makeLinearSolver(name, 1e-13);
    for (int round = 0; round < 2; ++round) {  // the second factorisation reuses the analysis
      solver->factorize(A.matrix());
      EXPECT_EQ(solver->singularDof(), -1) << name;
      const Eigen::VectorXd x = solver->solve(b);
      const double residual = (A.matrix() * x - b).norm() / b.norm();
      EXPECT_LT(residual, name == "cg" ? 1e-11 : 1e-14) << name;
      if (reference.size() == 0) reference = x;
      EXPECT_LT((x - reference).norm() / reference.norm(), 1e-10) << name << " against " << availableSolvers()[0];
    }
  }
}

TEST(FemLinearSolvers, AFloatingBodyIsNamedSingular) {
  const SparseSystem A = beamSystem(false, 0.0);  // K_0 alone, no support: six rigid-body modes
  for (const auto& name : {"ldlt", "profile", "direct"}) {
    auto solver = makeLinearSolver(name);
    solver->factorize(A.matrix());
    EXPECT_GE(solver->singularDof(), 0) << name;
    EXPECT_LT(solver->singularDof(), A.size()) << name;
  }
}

// Reverse Cuthill-McKee orders component by component: two disconnected
// beams side by side, plus a dof coupled to nothing, solve like one system.
TEST(FemLinearSolvers, ProfileHandlesDisconnectedComponents) {
  const SparseSystem one = beamSystem(true, 1.0 / (0.25 * 6.43e-5 * 6.43e-5));
  const int n = one.size();
  std::vector<Eigen::Triplet<double>> t;
  for (int c = 0; c < 2; ++c)
    for (int k = 0; k < one.matrix().outerSize(); ++k)
      for (SparseSystem::Matrix::InnerIterator it(one.matrix(), k); it; ++it)
        t.emplace_back(static_cast<int>(it.row()) + c * n, static_cast<int>(it.col()) + c * n, (1.0 + c) * it.value());
  t.emplace_back(2 * n, 2 * n, 3.0);
  SparseSystem::Matrix A(2 * n + 1, 2 * n + 1);
  A.setFromTriplets(t.begin(), t.end());
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.rows(), -1.0, 2.0);
  auto profile = makeLinearSolver("profile");
  profile->factorize(A);
  ASSERT_EQ(profile->singularDof(), -1);
  const Eigen::VectorXd x = profile->solve(b);
  EXPECT_LT((A * x - b).norm() / b.norm(), 1e-14);
  EXPECT_DOUBLE_EQ(x(2 * n), b(2 * n) / 3.0);
}

}  // namespace
}  // namespace cosim::fem
