#pragma once
// A periodic, deformable unit cell (Liu 2016 Sec. 2.3: periodic DEM cells for
// the GMH unit-cell problems). The cell is the parallelepiped spanned by the
// columns of H (origin at 0). It deforms with a prescribed velocity gradient
// L: dH/dt = L H, and particles are carried affinely (x <- x + dt L x), so the
// stored velocities are fluctuations about the affine field v = L x; relative
// contact velocities add L d. Simple shear L = [[0, g, 0], [0, 0, 0], [0, 0, 0]]
// is Lees-Edwards.
#include <array>
#include <cmath>
#include <cstdint>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

using Mat3 = std::array<double, 9>;  // row-major

inline Vec3 mul(const Mat3& m, const Vec3& v) {
  return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
          m[6] * v.x + m[7] * v.y + m[8] * v.z};
}
inline Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k)
      for (int s = 0; s < 3; ++s) c[static_cast<std::size_t>(3 * r + s)] += a[static_cast<std::size_t>(3 * r + k)] * b[static_cast<std::size_t>(3 * k + s)];
  return c;
}
inline double det(const Mat3& m) {
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
}
inline Mat3 inverse(const Mat3& m) {
  const double id = 1.0 / det(m);
  return {(m[4] * m[8] - m[5] * m[7]) * id, (m[2] * m[7] - m[1] * m[8]) * id, (m[1] * m[5] - m[2] * m[4]) * id,
          (m[5] * m[6] - m[3] * m[8]) * id, (m[0] * m[8] - m[2] * m[6]) * id, (m[2] * m[3] - m[0] * m[5]) * id,
          (m[3] * m[7] - m[4] * m[6]) * id, (m[1] * m[6] - m[0] * m[7]) * id, (m[0] * m[4] - m[1] * m[3]) * id};
}
inline Vec3 column(const Mat3& m, int c) { return {m[static_cast<std::size_t>(c)], m[static_cast<std::size_t>(3 + c)], m[static_cast<std::size_t>(6 + c)]}; }

struct PeriodicCell {
  bool enabled = false;
  Mat3 h{1, 0, 0, 0, 1, 0, 0, 0, 1};     // cell vectors as columns [m]
  Mat3 velocityGradient{};               // L [1/s]
  double volume() const { return det(h); }
  /// Width of the cell perpendicular to face pair a (distance between opposite faces).
  double width(int a) const {
    const Vec3 b = column(h, (a + 1) % 3), c = column(h, (a + 2) % 3);
    const double w = volume() / norm(cross(b, c));
    if (std::isfinite(w) && w > 0.0) return w;
    // Long or very uneven cell vectors overflow |b x c| or det H: a . (b x c) / |b x c|
    // with each vector scaled by a power of two first (exact, no overflow).
    const Vec3 n = powerOfTwoScaled(cross(powerOfTwoScaled(b), powerOfTwoScaled(c)));
    return dot(column(h, a), (1.0 / norm(n)) * n);
  }
  /// Image offset H n for an integer shift n.
  Vec3 shift(const std::array<std::int8_t, 3>& n) const {
    return mul(h, Vec3{static_cast<double>(n[0]), static_cast<double>(n[1]), static_cast<double>(n[2])});
  }
};

}  // namespace cosim::dem
