#pragma once
// Trilinear eight-node hexahedron: shape functions, 2x2x2 Gauss rule and the
// reference geometry (dN/dX, w det J) of every element at every Gauss point.
#include <array>
#include <vector>

#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/fem/types.hpp"

namespace cosim::fem::hex8 {

/// Natural coordinates of the nodes (VTK order).
extern const double kNodeXi[8][3];
using Shape = Eigen::Matrix<double, 8, 1>;

Shape shape(const Vec3& xi);
Mat83 shapeDerivatives(const Vec3& xi);  // row a: dN_a / dxi
/// 2x2x2 Gauss point i (same sign pattern as node i), weight 1.
Vec3 gaussPoint(int i);

/// Reference geometry of all elements at the 8 Gauss points.
struct ReferenceGeometry {
  std::vector<Mat83> dNdX;     // [8 e + q]
  std::vector<double> wdetJ;   // [8 e + q]
  std::vector<double> volume;  // [e]
  /// Computes it; throws InputError naming the first inverted or degenerate element.
  void build(const Mesh& mesh);
  const Mat83& grad(std::size_t e, int q) const { return dNdX[8 * e + static_cast<std::size_t>(q)]; }
  double weight(std::size_t e, int q) const { return wdetJ[8 * e + static_cast<std::size_t>(q)]; }
};

/// det J at the Gauss points and the centre must all be positive; throws naming the element.
void checkElement(std::size_t e, const Mat83& X);

}  // namespace cosim::fem::hex8
