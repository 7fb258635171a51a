#pragma once
// The energy-consistent form of the CG-enriched surface coupling.
//
// Eqs. (14)-(15) of Cheng 2022 spread a contact force over the nodes within
// the CG width c, while DEM still feels the unsmoothed surface under the
// particle. The power the particle puts into the wall, f_c . v_wall(x_c), and
// the power the nodes receive, sum_i f_i . v_i, then differ, and with a stiff
// contact the difference pumps energy into the beam (docs/coupling_surface.md).
//
// Here DEM feels the surface displaced by the CG-smoothed nodal field: each
// triangle vertex v moves by u'_v = sum_i G_i(X_v) u_i with velocity
// v'_v = sum_i G_i(X_v) v_i, where G_i(X) are the CG weights of Eq. 15 at the
// vertex's reference position X_v (SurfaceForceMap::weightsAt). The contact
// forces go back through the same weights: f_i = sum_c sum_v b_cv G_i(X_v) f_c
// (Eq. 16 with G in place of the vertex-to-node weights). The two maps are
// transposes, so sum_i f_i . v_i = f_c . v_wall(x_c) exactly: the contact does
// the same work on both sides. For c -> 0, G_i(X_v) -> psi_i(X_v) and the
// point form of Eq. 16 with the unsmoothed wall is recovered. Displacements,
// not positions, are smoothed: smoothing positions would pull the surface's
// edges inwards wherever the kernel overhangs them.
#include <cstdint>
#include <span>
#include <vector>

#include "cosim/coupler/mapping/surface_force_map.hpp"

namespace cosim::coupler {

class SmoothedSurface {
 public:
  /// reference: the surface as first exported (its positions are X_v);
  /// cgMap: the kernel and width; quadrature: the surface quadrature points.
  /// Throws std::invalid_argument when a node has no vertex of its own or a
  /// vertex has no quadrature point within c.
  SmoothedSurface(SurfaceForceMap& cgMap, const SurfaceMeshView& reference, const SurfaceQuadratureView& quadrature);

  /// The smoothed vertex positions and velocities of the current export.
  void kinematics(const SurfaceMeshView& mesh, std::span<const double> velocities, std::vector<double>& positions,
                  std::vector<double>& smoothedVelocities) const;
  /// `mesh` with G in place of its vertex-to-node weights, for the point-form map.
  SurfaceMeshView withSmoothedWeights(const SurfaceMeshView& mesh) const;
  const VertexNodeWeights& weights() const { return g_; }

 private:
  std::vector<double> reference_;           // X_v, 3 per vertex
  VertexNodeWeights g_;                     // G_i(X_v), one row per vertex
  std::vector<std::uint32_t> nodeVertex_;   // the vertex that sits on each node
  std::vector<std::uint32_t> source_;       // per entry of g_: the vertex of its node
  mutable std::vector<double> displacement_;  // scratch: x_v - X_v of the current export
};

}  // namespace cosim::coupler
