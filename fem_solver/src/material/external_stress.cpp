#include "cosim/fem/material/external_stress.hpp"

#include <algorithm>

#include "cosim/fem/material/corotational.hpp"

namespace cosim::fem {

ExternalStressMaterial::ExternalStressMaterial(const MaterialParams& params)
    : Material(params), C_(isotropicTangent(lambda_, mu_)) {}

void ExternalStressMaterial::evaluate(const Mat3&, Mat3&, Mat6*, double&) const {
  throw SolveError("external material evaluated without a material point");
}

void ExternalStressMaterial::evaluateAt(std::size_t point, const Mat3& H, Mat3& S, Mat6* tangent, double& W) const {
  if (9 * point + 9 > stress_.size())
    throw SolveError("external material: no stress for material point " + std::to_string(point));
  const Mat3 F = Mat3::Identity() + H;
  const Mat3 sigmaR = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(stress_.data() + 9 * point);
  const Mat3 sigma = frame_ == CellFrame::Spatial
                         ? sigmaR
                         : corotational::rotateToGlobal(corotational::polarRotation(F), sigmaR);  // Liu Eq. 62
  S = corotational::secondPiolaFromCauchy(F, sigma);
  W = 0.0;
  if (tangent) *tangent = C_;
}

Mat3 ExternalStressMaterial::cellIncrement(const Mat3& Fn, const Mat3& Fn1) const {
  if (frame_ == CellFrame::Spatial) return corotational::logarithmicIncrement(Fn, Fn1);
  return corotational::strainIncrement(Fn, Fn1).strainIncrement;  // Liu Eqs. 60-61
}

void ExternalStressMaterial::setCellStress(std::size_t point, const double* values) {
  if (9 * point + 9 > stress_.size())
    throw InputError("external stress for material point " + std::to_string(point) + " but the model has " +
                     std::to_string(pointCount()));
  std::copy(values, values + 9, stress_.begin() + static_cast<long>(9 * point));
}

namespace {
const MaterialRegistry::Registrar kExternal("external", [](const MaterialParams& p) {
  return std::make_unique<ExternalStressMaterial>(p);
});
}  // namespace

}  // namespace cosim::fem
