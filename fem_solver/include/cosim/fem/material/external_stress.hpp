#pragma once
// External material (GMH, Liu 2016 Sec. 2.3): the corotational Cauchy stress
// at every material point is supplied from outside (a DEM unit cell per
// point). At evaluation it is rotated to the global frame with the rotation
// of the polar decomposition of the current F (Liu Eq. 62) and converted to
// the second Piola-Kirchhoff stress, S = J F^-1 sigma F^-T. The tangent is
// the isotropic elastic predictor from E and nu (used for the element
// critical step and implicit iterations); the stored energy is unknown and
// reported as zero.
#include <vector>

#include "cosim/fem/material/material.hpp"

namespace cosim::fem {

class ExternalStressMaterial final : public Material {
 public:
  explicit ExternalStressMaterial(const MaterialParams& params);
  std::string name() const override { return "external"; }
  void evaluate(const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override;
  void evaluateAt(std::size_t point, const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override;
  void setPointCount(std::size_t points) override { stress_.assign(9 * points, 0.0); }
  std::size_t pointCount() const { return stress_.size() / 9; }
  /// Corotational Cauchy stress of one point (row-major 3 x 3).
  void setCorotationalStress(std::size_t point, const double* values);
  std::vector<double>& stresses() { return stress_; }

 private:
  std::vector<double> stress_;
  Mat6 C_;
};

}  // namespace cosim::fem
