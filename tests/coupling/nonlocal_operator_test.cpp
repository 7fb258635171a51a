// The nonlocal operator of GMH (Liu 2016 Eqs. 58-59, App. A): bell weights
// normalised over the neighbourhood, a uniform field kept, a radius below the
// point spacing giving the local field back, and a spike spread over R.
#include <gtest/gtest.h>

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
  const NonlocalOperator op(x, 1.5);
  std::vector<double> out(3);
  EXPECT_THROW(op.apply(std::vector<double>{1, 2, 3}, 1, out), std::invalid_argument);
}

}  // namespace
}  // namespace cosim::coupler
