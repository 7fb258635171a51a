// The nonlocal operator of GMH (Liu 2016 Eqs. 58-59, App. A): bell weights
// normalised over the neighbourhood, a uniform field kept, a radius below the
// point spacing giving the local field back, and a spike spread over R.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "cosim/coupler/mapping/nonlocal_operator.hpp"

namespace cosim::coupler {
namespace {

std::vector<double> grid(int nx, int ny, int nz, double h) {
  std::vector<double> x;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) x.insert(x.end(), {(i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h});
  return x;
}

TEST(NonlocalOperator, BellWeightsOnThreePointsInARow) {
  // h = 1, R = 2: alpha(0) = 1, alpha(1) = (1 - 1/4)^2 = 0.5625, alpha(2) = 0 (Eq. A.3).
  const std::vector<double> x{0, 0, 0, 1, 0, 0, 2, 0, 0};
  const NonlocalOperator op(x, 2.0);
  const std::vector<double> in{1.0, 2.0, 4.0};
  std::vector<double> out(3);
  op.apply(in, 1, out);
  EXPECT_NEAR(out[1], (0.5625 * 1.0 + 2.0 + 0.5625 * 4.0) / 2.125, 1e-15);
  EXPECT_NEAR(out[0], (1.0 + 0.5625 * 2.0) / 1.5625, 1e-15);  // point 2 is at r = R: weight 0
  EXPECT_EQ(op.neighbours(0).size(), 2u);
}

TEST(NonlocalOperator, KeepsAUniformFieldAndWeightsSumToOne) {
  const auto x = grid(6, 5, 4, 0.1);
  const NonlocalOperator op(x, 0.27);
  std::vector<double> in, out(9 * op.points());
  for (std::size_t p = 0; p < op.points(); ++p)
    for (int c = 0; c < 9; ++c) in.push_back(1e-4 * (c + 1));
  op.apply(in, 9, out);
  for (std::size_t k = 0; k < in.size(); ++k) EXPECT_NEAR(out[k], in[k], 1e-14 * in[k]);
  for (std::size_t p = 0; p < op.points(); ++p) {
    double sum = 0.0;
    for (double w : op.weights(p)) sum += w;
    EXPECT_NEAR(sum, 1.0, 1e-14);
  }
  EXPECT_GT(op.meanNeighbours(), 20.0);  // interior: the 4.4 R^3 / h^3 within R, edges fewer
}

TEST(NonlocalOperator, RadiusBelowTheSpacingIsLocal) {
  const auto x = grid(4, 4, 1, 0.1);
  const NonlocalOperator op(x, 0.099);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> in(x.size() / 3), out(in.size());
  for (double& v : in) v = u(rng);
  op.apply(in, 1, out);
  EXPECT_EQ(out, in);
  EXPECT_EQ(op.meanNeighbours(), 1.0);
}

TEST(NonlocalOperator, SpreadsASpikeOverTheRadiusOnly) {
  const auto x = grid(21, 1, 1, 1.0);
  const NonlocalOperator op(x, 3.0);
  std::vector<double> in(21, 0.0), out(21);
  in[10] = 1.0;
  op.apply(in, 1, out);
  EXPECT_LT(out[10], 1.0);
  EXPECT_GT(out[9], 0.0);
  EXPECT_GT(out[12], 0.0);
  EXPECT_GT(out[10], out[11]);
  EXPECT_GT(out[11], out[12]);
  EXPECT_EQ(out[13], 0.0);  // |x_13 - x_10| = R: outside
  EXPECT_EQ(out[7], 0.0);
}

TEST(NonlocalOperator, RefusesBadInput) {
  const std::vector<double> x{0, 0, 0, 1, 0, 0};
  EXPECT_THROW(NonlocalOperator(x, 0.0), std::invalid_argument);
  EXPECT_THROW(NonlocalOperator(x, -1.0), std::invalid_argument);
  EXPECT_THROW(NonlocalOperator(std::vector<double>{0, 0}, 1.0), std::invalid_argument);
  EXPECT_THROW(NonlocalOperator(x, 1.5, -0.1), std::invalid_argument);
  EXPECT_THROW(NonlocalOperator(x, 1.5, 1.0), std::invalid_argument);
  const NonlocalOperator op(x, 1.5);
  std::vector<double> out(3);
  EXPECT_THROW(op.apply(std::vector<double>{1, 2, 3}, 1, out), std::invalid_argument);
}

/// Every eigenvalue of the operator, from its dense matrix.
Eigen::VectorXd denseEigenvalues(const NonlocalOperator& op) {
  const auto n = static_cast<Eigen::Index>(op.points());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto nb = op.neighbours(static_cast<std::size_t>(i));
    const auto w = op.weights(static_cast<std::size_t>(i));
    for (std::size_t k = 0; k < nb.size(); ++k) a(i, nb[k]) = w[k];
  }
  return a.eigenvalues().real();
}

/// Element centres of L5's plane-strain mesh (40 x 80 mm, one layer).
std::vector<double> l5Mesh(int nx, int ny) {
  std::vector<double> x;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) x.insert(x.end(), {(i + 0.5) * 0.04 / nx, (j + 0.5) * 0.08 / ny, 0.0025});
  return x;
}

TEST(NonlocalOperator, BellKernelIsIndefiniteOnAFineMeshAndPositiveOnACoarseOne) {
  // R = 6.75 mm (Liu Sec. 3.5). h = 5 mm: the neighbours at h weigh 0.20 and
  // the diagonal ones lie beyond R, so every eigenvalue is positive. h = 3.3 mm:
  // neighbours at h weigh 0.57 and diagonal ones 0.26; the checkerboard
  // pattern's symbol 1 - 4(0.57) + 4(0.26) is negative.
  const NonlocalOperator coarse(l5Mesh(8, 16), 6.75e-3), fine(l5Mesh(12, 24), 6.75e-3);
  const double coarseDense = denseEigenvalues(coarse).minCoeff(), fineDense = denseEigenvalues(fine).minCoeff();
  EXPECT_GT(coarseDense, 0.1);
  EXPECT_LT(fineDense, -0.04);
  // 128 and 288 points: Lanczos is exact on the first, and from above on the second.
  EXPECT_NEAR(coarse.smallestEigenvalue(), coarseDense, 1e-10);
  EXPECT_GE(fine.smallestEigenvalue(), fineDense - 1e-10);
  EXPECT_NEAR(fine.smallestEigenvalue(), fineDense, 1e-3 * std::abs(fineDense));
}

TEST(NonlocalOperator, LocalFractionLiftsTheSpectrumAndKeepsAUniformField) {
  const NonlocalOperator pure(l5Mesh(12, 24), 6.75e-3);
  const double lowest = denseEigenvalues(pure).minCoeff();
  const double beta = NonlocalOperator::localFractionFor(lowest, 0.0, 0.1);
  EXPECT_NEAR((1.0 - beta) * lowest + beta, 0.1, 1e-14);
  EXPECT_EQ(NonlocalOperator::localFractionFor(0.3, 0.0, 0.1), 0.0);
  const NonlocalOperator blended(l5Mesh(12, 24), 6.75e-3, beta);
  const double blendedLowest = denseEigenvalues(blended).minCoeff();
  EXPECT_NEAR(blendedLowest, 0.1, 1e-9);
  // From the blended operator the same fraction is found again, and a higher target asks for more.
  EXPECT_NEAR(NonlocalOperator::localFractionFor(blendedLowest, beta, 0.1), beta, 1e-9);
  EXPECT_GT(NonlocalOperator::localFractionFor(blendedLowest, beta, 0.2), beta);
  std::vector<double> in(blended.points(), 2.5e-4), out(in.size());
  blended.apply(in, 1, out);
  for (double v : out) EXPECT_NEAR(v, 2.5e-4, 1e-17);
  // A spike keeps beta of itself on top of its pure average.
  std::vector<double> spike(pure.points(), 0.0), a(spike.size()), b(spike.size());
  spike[100] = 1.0;
  pure.apply(spike, 1, a);
  blended.apply(spike, 1, b);
  for (std::size_t p = 0; p < spike.size(); ++p) EXPECT_NEAR(b[p], (1.0 - beta) * a[p] + beta * spike[p], 1e-15);
}

TEST(NonlocalOperator, SmallestEigenvalueOfSixPointsInARow) {
  // h = 1, R = 2: W = tri(0.5625, 1, 0.5625); A = D^-1 W has the eigenvalues of
  // D^-1/2 W D^-1/2, here computed densely: one of them is negative.
  const NonlocalOperator op(grid(6, 1, 1, 1.0), 2.0);
  const double dense = denseEigenvalues(op).minCoeff();
  EXPECT_LT(dense, 0.0);
  EXPECT_NEAR(op.smallestEigenvalue(), dense, 1e-12);
}

}  // namespace
}  // namespace cosim::coupler
