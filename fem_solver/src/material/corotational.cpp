#include "cosim/fem/material/corotational.hpp"

#include <Eigen/SVD>

namespace cosim::fem::corotational {

Mat3 polarRotation(const Mat3& F) {
  const Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3 V = svd.matrixV();
  // det F > 0 for an admissible deformation; guard against a reflection anyway.
  if ((U * V.transpose()).determinant() < 0.0) U.col(2) *= -1.0;
  return U * V.transpose();
}

Increment strainIncrement(const Mat3& Fn, const Mat3& Fn1) {
  const Mat3 Fmid = 0.5 * (Fn + Fn1);                  // Liu Eq. 61 at x_{n+1/2}
  const Mat3 dL = (Fn1 - Fn) * Fmid.inverse();          // increment of the spatial gradient
  const Mat3 deps = 0.5 * (dL + dL.transpose());
  Increment inc;
  inc.rotation = polarRotation(Fmid);
  inc.strainIncrement = inc.rotation.transpose() * deps * inc.rotation;  // Liu Eq. 60
  return inc;
}

Mat3 logarithmicIncrement(const Mat3& Fn, const Mat3& Fn1) {
  // log(I + A) = A - A^2/2 + A^3/3 - ...; GMH increments are small (|A| about
  // 1e-4 to 1e-2 per coarse step), so a few terms reach round-off.
  const Mat3 A = Fn1 * Fn.inverse() - Mat3::Identity();
  const double size = A.norm();
  if (!(size < 0.5))
    throw InputError("deformation increment |F_n+1 F_n^-1 - I| = " + std::to_string(size) +
                     " is not small (at least 0.5): no logarithmic strain increment");
  Mat3 term = A, out = Mat3::Zero();
  for (int k = 1; k <= 60 && term.norm() > 1e-17 * size; ++k) {
    out += ((k % 2) ? 1.0 : -1.0) / k * term;
    term = term * A;
  }
  return out;
}

Mat3 rotateToGlobal(const Mat3& R, const Mat3& sigmaCorotational) {
  return R * sigmaCorotational * R.transpose();  // Liu Eq. 62
}

Mat3 secondPiolaFromCauchy(const Mat3& F, const Mat3& sigma) {
  const Mat3 Finv = F.inverse();
  return F.determinant() * Finv * sigma * Finv.transpose();
}

}  // namespace cosim::fem::corotational
