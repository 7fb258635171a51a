#include "cosim/fem/fem/hex8.hpp"

#include <cmath>
#include <sstream>

namespace cosim::fem::hex8 {

const double kNodeXi[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                              {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};

Shape shape(const Vec3& xi) {
  Shape N;
  for (int a = 0; a < 8; ++a)
    N(a) = 0.125 * (1 + kNodeXi[a][0] * xi[0]) * (1 + kNodeXi[a][1] * xi[1]) * (1 + kNodeXi[a][2] * xi[2]);
  return N;
}

Mat83 shapeDerivatives(const Vec3& xi) {
  Mat83 d;
  for (int a = 0; a < 8; ++a) {
    const double s = kNodeXi[a][0], t = kNodeXi[a][1], u = kNodeXi[a][2];
    d(a, 0) = 0.125 * s * (1 + t * xi[1]) * (1 + u * xi[2]);
    d(a, 1) = 0.125 * t * (1 + s * xi[0]) * (1 + u * xi[2]);
    d(a, 2) = 0.125 * u * (1 + s * xi[0]) * (1 + t * xi[1]);
  }
  return d;
}

Vec3 gaussPoint(int i) {
  const double g = 1.0 / std::sqrt(3.0);
  return {g * kNodeXi[i][0], g * kNodeXi[i][1], g * kNodeXi[i][2]};
}

void checkElement(std::size_t e, const Mat83& X) {
  const Mat3 J0 = X.transpose() * shapeDerivatives(Vec3::Zero());
  const double scale = std::pow(std::abs(J0.determinant()) + 1e-300, 1.0);
  for (int q = -1; q < 8; ++q) {
    const Vec3 xi = q < 0 ? Vec3::Zero() : gaussPoint(q);
    const double detJ = (X.transpose() * shapeDerivatives(xi)).determinant();
    if (!(detJ > 1e-12 * scale) || !std::isfinite(detJ)) {
      std::ostringstream msg;
      msg << "element " << e << " is " << (detJ < 0 ? "inverted" : "degenerate") << " (det J = " << detJ << " at "
          << (q < 0 ? std::string("its centre") : "Gauss point " + std::to_string(q)) << ")";
      throw InputError(msg.str());
    }
  }
  if (!(scale > 0.0)) throw InputError("element " + std::to_string(e) + " is degenerate (zero volume)");
}

void ReferenceGeometry::build(const Mesh& mesh) {
  const std::size_t ne = mesh.numElements();
  dNdX.resize(8 * ne);
  wdetJ.resize(8 * ne);
  volume.assign(ne, 0.0);
  Mat83 dxi[8];
  for (int q = 0; q < 8; ++q) dxi[q] = shapeDerivatives(gaussPoint(q));
  for (std::size_t e = 0; e < ne; ++e) {
    const Mat83 X = mesh.elementCoordinates(e);
    checkElement(e, X);
    for (int q = 0; q < 8; ++q) {
      const Mat3 J = X.transpose() * dxi[q];  // J_ij = dX_i / dxi_j
      dNdX[8 * e + static_cast<std::size_t>(q)] = dxi[q] * J.inverse();
      wdetJ[8 * e + static_cast<std::size_t>(q)] = J.determinant();
      volume[e] += J.determinant();
    }
  }
}

}  // namespace cosim::fem::hex8
