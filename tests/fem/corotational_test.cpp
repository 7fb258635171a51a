// Corotational update (Liu 2016 Eqs. 60-62): a rigid rotation gives no
// corotational strain increment, so a prestress carried in the corotational
// frame rotates with the body; a stretch in a rotated frame gives the
// logarithmic-rate increment in the material axes.
#include <gtest/gtest.h>

#include <cmath>

#include "cosim/fem/material/corotational.hpp"

namespace cosim::fem {
namespace {

TEST(FemCorotational, RigidRotationCarriesStress) {
  const Vec3 axis = Vec3(1, -2, 0.5).normalized();
  const Mat3 U = (Mat3() << 1.02, 0.01, 0, 0.01, 0.99, 0.005, 0, 0.005, 1.01).finished();
  Mat3 sigmaR = Mat3::Zero();
  sigmaR(0, 0) = 1e5;
  sigmaR(0, 1) = sigmaR(1, 0) = 2e4;
  const int n = 100;
  double maxIncrement = 0.0;
  Mat3 R1 = Mat3::Identity();
  for (int k = 0; k < n; ++k) {
    const Mat3 R0 = Eigen::AngleAxisd(M_PI / 2 * k / n, axis).toRotationMatrix();
    R1 = Eigen::AngleAxisd(M_PI / 2 * (k + 1) / n, axis).toRotationMatrix();
    const auto inc = corotational::strainIncrement(R0 * U, R1 * U);
    maxIncrement = std::max(maxIncrement, inc.strainIncrement.cwiseAbs().maxCoeff());
    sigmaR += 1e8 * inc.strainIncrement;  // a stand-in hypoelastic unit cell
  }
  const Mat3 sigma = corotational::rotateToGlobal(corotational::polarRotation(R1 * U), sigmaR);
  const Mat3 R = corotational::polarRotation(R1 * U);
  const Mat3 expected = R * (Mat3() << 1e5, 2e4, 0, 2e4, 0, 0, 0, 0, 0).finished() * R.transpose();
  std::printf("[corotational] max |d eps^R| under rigid rotation = %.2e, stress error %.2e Pa\n", maxIncrement,
              (sigma - expected).cwiseAbs().maxCoeff());
  EXPECT_LT(maxIncrement, 1e-14);
  EXPECT_LT((sigma - expected).cwiseAbs().maxCoeff(), 1e-12 * 1e5);  // relative to the prestress
  // The rotation from the polar decomposition of R1 U is R1 (U is symmetric positive definite).
  EXPECT_LT((R - R1).cwiseAbs().maxCoeff(), 1e-14);
}

TEST(FemCorotational, StretchInRotatedFrame) {
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(0, 0, 1)).toRotationMatrix();
  const Mat3 Fn = R * Vec3(1.01, 1.0, 1.0).asDiagonal();
  const Mat3 Fn1 = R * Vec3(1.02, 1.0, 1.0).asDiagonal();
  const auto inc = corotational::strainIncrement(Fn, Fn1);
  Mat3 expected = Mat3::Zero();
  expected(0, 0) = 0.01 / 1.015;  // Delta lambda / lambda_{n+1/2}
  EXPECT_LT((inc.strainIncrement - expected).cwiseAbs().maxCoeff(), 1e-15);
  // S from sigma and back: sigma = F S F^T / J.
  const Mat3 sigma = (Mat3() << 3, 1, 0, 1, 2, 0.5, 0, 0.5, 1).finished();
  const Mat3 S = corotational::secondPiolaFromCauchy(Fn1, sigma);
  EXPECT_LT((Fn1 * S * Fn1.transpose() / Fn1.determinant() - sigma).cwiseAbs().maxCoeff(), 1e-14);
}

// frame: spatial: the whole increment log(F_n+1 F_n^-1). Its exponential
// gives the increment of F back (the cell follows F exactly, spin included);
// a rigid rotation gives a skew increment (the cell turns, no strain); a
// stretch along a rotated axis gives ln(lambda_n+1 / lambda_n) along it.
TEST(FemCorotational, LogarithmicIncrementReproducesTheStep) {
  const Mat3 Fn = (Mat3() << 1.01, 0.02, 0, -0.01, 0.98, 0.004, 0.003, 0, 1.005).finished();
  const Mat3 dF = (Mat3() << 1.003, 0.004, -0.001, 0.0, 0.998, 0.002, 0.001, -0.002, 1.001).finished();
  const Mat3 Fn1 = dF * Fn;
  const Mat3 d = corotational::logarithmicIncrement(Fn, Fn1);
  Mat3 expD = Mat3::Identity(), term = Mat3::Identity();
  for (int k = 1; k < 20; ++k) expD += (term = term * d / k);
  EXPECT_LT((expD - dF).cwiseAbs().maxCoeff(), 1e-15);

  const Mat3 R0 = Eigen::AngleAxisd(0.3, Vec3(0, 0, 1)).toRotationMatrix();
  const Mat3 R1 = Eigen::AngleAxisd(0.31, Vec3(0, 0, 1)).toRotationMatrix();
  const Mat3 spin = corotational::logarithmicIncrement(R0, R1);
  EXPECT_LT((spin + spin.transpose()).cwiseAbs().maxCoeff(), 1e-16);
  EXPECT_NEAR(spin(1, 0), 0.01, 1e-15);

  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(0, 0, 1)).toRotationMatrix();
  const Mat3 stretch = corotational::logarithmicIncrement(R * Vec3(1.01, 1.0, 1.0).asDiagonal() * R.transpose(),
                                                          R * Vec3(1.02, 1.0, 1.0).asDiagonal() * R.transpose());
  const Mat3 expected = R * Vec3(std::log(1.02 / 1.01), 0, 0).asDiagonal() * R.transpose();
  EXPECT_LT((stretch - expected).cwiseAbs().maxCoeff(), 1e-15);

  // Not an increment: refused, with the size.
  try {
    corotational::logarithmicIncrement(Mat3::Identity(), 2.0 * Mat3::Identity());
    ADD_FAILURE() << "a doubling of F was taken as an increment";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not small"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::fem
