#include "cosim/dem/walls/triangle_wall_group.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace cosim::dem {

// Ericson, Real-Time Collision Detection (2005), Sec. 5.1.5: Voronoi regions
// of the vertices, edges and face, in that order.
ClosestPoint closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {a, {1.0, 0.0, 0.0}};
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0.0 && d4 <= d3) return {b, {0.0, 1.0, 0.0}};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {a + v * ab, {1.0 - v, v, 0.0}};
  }
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0.0 && d5 <= d6) return {c, {0.0, 0.0, 1.0}};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {a + w * ac, {1.0 - w, 0.0, w}};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {b + w * (c - b), {0.0, 1.0 - w, w}};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {a + v * ab + w * ac, {1.0 - v - w, v, w}};
}

void TriangleWallGroup::validate() const {
  if (velocities.size() != vertices.size())
    throw std::invalid_argument("wall group '" + name + "': " + std::to_string(velocities.size()) +
                                " velocities for " + std::to_string(vertices.size()) + " vertices");
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (std::uint32_t v : triangles[t])
      if (v >= vertices.size())
        throw std::invalid_argument("wall group '" + name + "': triangle " + std::to_string(t) +
                                    " names vertex " + std::to_string(v) + " of " +
                                    std::to_string(vertices.size()));
    const Vec3& a = vertices[triangles[t][0]];
    const double area2 = norm(cross(vertices[triangles[t][1]] - a, vertices[triangles[t][2]] - a));
    if (!(area2 > 0.0))
      throw std::invalid_argument("wall group '" + name + "': triangle " + std::to_string(t) +
                                  " is degenerate (zero area)");
  }
}

void TriangleWallGroup::boundingBox(std::size_t t, Vec3& lo, Vec3& hi) const {
  lo = hi = vertices[triangles[t][0]];
  for (int k = 1; k < 3; ++k)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], vertices[triangles[t][k]][d]);
      hi[d] = std::max(hi[d], vertices[triangles[t][k]][d]);
    }
}

bool TriangleWallGroup::movedBeyond(double limit) const {
  if (verticesRef_.size() != vertices.size()) return true;
  for (std::size_t v = 0; v < vertices.size(); ++v)
    if (norm2(vertices[v] - verticesRef_[v]) > limit * limit) return true;
  return false;
}

double TriangleWallGroup::workBeforeEvaluation() const { return 0.5 * contactWork(); }

double TriangleWallGroup::workAfterEvaluation() {
  const double work = 0.5 * contactWork();
  verticesAtEval_ = vertices;
  return work;
}

double TriangleWallGroup::contactWork() const {
  // A new surface, or one of another size, has no contacts to charge.
  if (verticesAtEval_.size() != vertices.size()) return 0.0;
  auto moved = [&](std::uint32_t v) { return vertices[v] - verticesAtEval_[v]; };
  double work = 0.0;
  for (const TriangleContact& c : contacts) {
    if (c.triangle >= triangles.size()) continue;  // of a surface since replaced
    const auto& tri = triangles[c.triangle];        // validate(): its vertices exist
    const Vec3 d = c.bary[0] * moved(tri[0]) + c.bary[1] * moved(tri[1]) + c.bary[2] * moved(tri[2]);
    work -= dot(c.force, d);  // c.force is the force on the wall; the particle feels -c.force
  }
  return work;
}

}  // namespace cosim::dem
