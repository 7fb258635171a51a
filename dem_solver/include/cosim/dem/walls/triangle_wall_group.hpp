#pragma once
// A group of triangle walls forming one surface (e.g. a coupled FE boundary),
// with vertices moved from outside (positions and velocities each step).
// Contacts follow Cheng 2022 Alg. 1: naive contacts with every overlapping
// triangle, Modification 1 (drop the smaller of two contacts whose triangles
// meet at a flat or convex angle as seen from the particle), Modification 2
// (weight the remaining ones by |f| / sum |f|). One tangential history per
// particle and group follows the particle from triangle to triangle.
// Candidates come from the neighbour grid by triangle bounding box (Alg. 2).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

/// Closest point of triangle (a, b, c) to p, with its barycentric coordinates.
struct ClosestPoint {
  Vec3 point;
  std::array<double, 3> bary{};
};
ClosestPoint closestPointOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

struct TriangleContact {
  std::uint32_t particle = 0;
  std::uint32_t triangle = 0;
  std::array<double, 3> bary{};  // contact point on the triangle
  Vec3 force;                    // force on the wall (minus the force on the particle)
  double elastic = 0.0;          // its springs' energy, weighted as its force (Modification 2) [J]
};

class TriangleWallGroup {
 public:
  static constexpr int kSlots = 4;  // contacts kept per particle (concave corners)
  std::string name;
  std::uint16_t material = 0;
  std::vector<Vec3> vertices, velocities;
  std::vector<std::array<std::uint32_t, 3>> triangles;

  /// Checks indices and degenerate triangles; throws naming the triangle.
  void validate() const;
  /// Bounding box of triangle t (Cheng 2022 Alg. 2; the neighbour grid grows it).
  void boundingBox(std::size_t t, Vec3& lo, Vec3& hi) const;
  /// True when a vertex moved more than limit since the candidates were built.
  bool movedBeyond(double limit) const;
  void markBuilt() { verticesRef_ = vertices; }
  const std::vector<Vec3>& verticesAtBuild() const { return verticesRef_; }
  void setVerticesAtBuild(std::vector<Vec3> v) { verticesRef_ = std::move(v); }

  /// Work of the wall on the particles since the last force evaluation,
  /// one trapezoid as for a driven particle (DemSystem::drivenWorkSinceEvaluation):
  /// every contact point moved by sum_v b_v (x_v - x_v at the last evaluation),
  /// charged half the contact forces before (workBeforeEvaluation, while
  /// `contacts` still holds them) and half those after (workAfterEvaluation).
  /// Exact for a linear spring. The move covers both DEM's own motion of the
  /// vertices (v dt per step) and the jump when a coupled FE surface sets
  /// them each exchange, which f_end . v dt missed (scene C1 at c = 0: DEM's
  /// balance 94 J off over the run, every stored energy below 2 J; docs/dem.md,
  /// "Work and energy of triangle walls").
  double workBeforeEvaluation() const;
  double workAfterEvaluation();
  /// Positions at the last force evaluation (a checkpoint is written after one).
  void markEvaluated() { verticesAtEval_ = vertices; }

  // Per particle: candidate triangles (CSR, rebuilt with the neighbour list),
  // and slots holding the tangential history of the current contacts.
  std::vector<std::uint32_t> candStart, candTri;
  struct Slot {
    std::int64_t triangle = -1;  // -1: free
    Vec3 shear;
  };
  std::vector<std::array<Slot, kSlots>> history;
  std::vector<TriangleContact> contacts;  // of the last force evaluation
  Vec3 force, torque;                     // total on the group (torque about the origin)

 private:
  /// sum over the contacts of (-force) . (the move at the contact point).
  double contactWork() const;
  std::vector<Vec3> verticesRef_;
  std::vector<Vec3> verticesAtEval_;
};

}  // namespace cosim::dem
