#pragma once
// External material (GMH, Liu 2016 Sec. 2.3): the corotational Cauchy stress
// at every material point is supplied from outside (a DEM unit cell per
// point). At evaluation it is rotated to the global frame with the rotation
// of the polar decomposition of the current F (Liu Eq. 62) and converted to
// the second Piola-Kirchhoff stress, S = J F^-1 sigma F^-T. The tangent is
// the isotropic elastic predictor from E and nu (used for the element
// critical step and implicit iterations); the stored energy is unknown and
// reported as zero.
// frame: spatial (not Liu's) sends the cells the whole increment, spin
// included, and takes their stress as the lab-frame Cauchy stress: the cell
// turns with the material like a directly sheared sample (docs/gmh_unit_cells.md, L2).
#include <vector>

#include "cosim/fem/material/material.hpp"

namespace cosim::fem {

/// The frame the unit cells work in.
enum class CellFrame {
  Corotational,  // Liu 2016 Eqs. 60-62: rotated strain increments, stress rotated back
  Spatial,       // the whole increment log(F_n+1 F_n^-1), lab-frame stress
};

class ExternalStressMaterial final : public Material {
 public:
  explicit ExternalStressMaterial(const MaterialParams& params);
  std::string name() const override { return "external"; }
  void evaluate(const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override;
  void evaluateAt(std::size_t point, const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override;
  void setPointCount(std::size_t points) override { stress_.assign(9 * points, 0.0); }
  std::size_t pointCount() const { return stress_.size() / 9; }
  /// Cauchy stress of one point as its cell returned it (row-major 3 x 3),
  /// in the cell's frame.
  void setCellStress(std::size_t point, const double* values);
  std::vector<double>& stresses() { return stress_; }

  void setFrame(CellFrame frame) { frame_ = frame; }
  /// The strain increment a point's cell receives for the step F_n -> F_n+1, in the cell's frame.
  Mat3 cellIncrement(const Mat3& Fn, const Mat3& Fn1) const;

 private:
  std::vector<double> stress_;
  CellFrame frame_ = CellFrame::Corotational;
  Mat6 C_;
};

}  // namespace cosim::fem
