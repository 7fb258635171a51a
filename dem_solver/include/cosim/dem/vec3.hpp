#pragma once
// Small fixed-size vector and quaternion types for the DEM hot loops. Plain
// aggregates (no Eigen expression templates) so arrays of them are contiguous
// x,y,z triples that checkpoint and travel on the wire as flat doubles.
#include <cmath>

namespace cosim::dem {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
  constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  constexpr Vec3& operator*=(double s) { x *= s; y *= s; z *= s; return *this; }
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

constexpr Vec3 operator+(Vec3 a, const Vec3& b) { return a += b; }
constexpr Vec3 operator-(Vec3 a, const Vec3& b) { return a -= b; }
constexpr Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
constexpr Vec3 operator*(Vec3 a, double s) { return a *= s; }
constexpr Vec3 operator*(double s, Vec3 a) { return a *= s; }
constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
constexpr double norm2(const Vec3& a) { return dot(a, a); }
inline double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
/// a times the power of two that brings its largest component into [1, 2):
/// exact, so its direction has the same bits, and |a| can neither overflow nor
/// underflow (a zero or non-finite a comes back as it is).
inline Vec3 powerOfTwoScaled(const Vec3& a) {
  const double largest = std::fmax(std::fabs(a.x), std::fmax(std::fabs(a.y), std::fabs(a.z)));
  if (!(largest > 0.0) || !std::isfinite(largest)) return a;
  const int e = -std::ilogb(largest);  // up to 1074 for a subnormal: scale each component, not by 2^e
  return {std::scalbn(a.x, e), std::scalbn(a.y, e), std::scalbn(a.z, e)};
}
/// c ? a : b per component, as selects (no branch), so loops over contacts vectorise.
constexpr Vec3 select(bool c, const Vec3& a, const Vec3& b) {
  return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z};
}

/// Unit quaternion w + xi + yj + zk for particle orientation.
struct Quat {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
};

constexpr Quat operator*(const Quat& a, const Quat& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

/// Below this |phi|^2 a turn uses the Taylor series (smallTurn): every DEM step.
constexpr double kSmallTurn2 = 1e-6;

/// cos(a/2) and sin(a/2)/a for a^2 = a2 < kSmallTurn2: Taylor series,
/// truncation below 1e-22, instead of sincos.
inline void smallTurn(double a2, double& c, double& s) {
  c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0;
  s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0;
}

/// q turned by phi given c = cos(a/2) and s = sin(a/2)/a, a = |phi|:
/// exp(phi/2) * q, renormalised against round-off drift. A select, not a
/// branch, so that a loop over spheres vectorises.
inline Quat turned(const Quat& q, const Vec3& phi, double c, double s) {
  const Quat r{c, phi.x * s, phi.y * s, phi.z * s};
  Quat out = r * q;
  // |out|^2 = 1 + e with |e| ~ 1e-16: one Newton step from 1, 1/sqrt(1 + e) = 1 - e/2 + O(e^2),
  // replaces the root and the division; far from 1 (a quaternion set from outside) the exact form.
  const double n2 = out.w * out.w + out.x * out.x + out.y * out.y + out.z * out.z;
  const double inv = std::fabs(n2 - 1.0) < 1e-8 ? 1.5 - 0.5 * n2 : 1.0 / std::sqrt(n2);
  out.w *= inv; out.x *= inv; out.y *= inv; out.z *= inv;
  return out;
}

/// Rotates q by the rotation vector phi (angle |phi| about phi/|phi|), in the
/// space frame: q <- exp(phi/2) * q.
inline Quat rotated(const Quat& q, const Vec3& phi) {
  const double a2 = norm2(phi);
  if (a2 == 0.0) return q;
  double c, s;
  if (a2 < kSmallTurn2) {
    smallTurn(a2, c, s);
  } else {
    const double angle = std::sqrt(a2);
    c = std::cos(0.5 * angle);
    s = std::sin(0.5 * angle) / angle;
  }
  return turned(q, phi, c, s);
}

}  // namespace cosim::dem
