#pragma once
// Maps DEM contact forces on a coupling surface to FE nodal forces (Cheng
// 2022 Sec. 5.1): the point form (c = 0, Eq. 16) through barycentric and
// vertex-to-node weights, or the CG-enriched form (c > 0, Eqs. 14-15) with the
// kernel evaluated at the surface quadrature points and normalised over them.
// Both conserve the total force exactly; the point form also the moment.
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {

/// The triangulated surface as FEM exports it (surface.capnp TriangleMeshKinematics).
struct SurfaceMeshView {
  std::span<const double> positions;  // 3 per vertex
  std::span<const std::uint32_t> triangles, rowStart, nodeIds;
  std::span<const double> nodeWeights;
};

/// Surface quadrature points (surface.capnp SurfaceQuadrature).
struct SurfaceQuadratureView {
  std::span<const double> positions, weights;
  std::uint32_t nodesPerPoint = 0;
  std::span<const std::uint32_t> nodeIds;
  std::span<const double> shapeValues;
};

/// Contacts DEM reports on the surface (surface.capnp ContactList); forces act ON the wall.
struct ContactsView {
  std::span<const std::uint32_t> triangleIds;
  std::span<const double> barycentric, points, forces;
};

/// Nodal forces on the nodes that received any, in increasing node order.
struct NodalForces {
  std::vector<std::uint32_t> ids;
  std::vector<double> forces;  // 3 per id
};

/// Sparse rows of weights from points (vertices) to nodes, in CSR form like the
/// vertex-to-node weights FEM exports.
struct VertexNodeWeights {
  std::vector<std::uint32_t> rowStart, nodeIds;
  std::vector<double> weights;
};

class SurfaceForceMap {
 public:
  /// kernel: the CG kernel (Dirac selects Eq. 16); width: c in metres (ignored for Dirac).
  SurfaceForceMap(const CgKernel& kernel, double width) : kernel_(kernel), width_(width) {}
  /// quadrature may be null for the Dirac kernel. Throws std::invalid_argument on inconsistent input.
  void map(const ContactsView& contacts, const SurfaceMeshView& mesh, const SurfaceQuadratureView* quadrature,
           NodalForces& out);
  /// The CG weights G_i(x) = sum_q a_q N_i(x_q) / sum_q a_q, a_q = w_q W(|x_q - x|),
  /// at each point x (what Eqs. 14-15 give a unit force at x): one row per point,
  /// each summing to 1. Needs a kernel with a width; throws std::invalid_argument
  /// when a point has no quadrature point within c.
  VertexNodeWeights weightsAt(std::span<const double> points, const SurfaceQuadratureView& quadrature);

 private:
  void addPointForm(std::size_t contact, const ContactsView& c, const SurfaceMeshView& mesh);
  void addSmoothedForm(std::size_t contact, const ContactsView& c, const SurfaceQuadratureView& q);
  /// Fills support_ with a_q for the quadrature points near x; returns their sum.
  double gatherSupport(const double* x, const SurfaceQuadratureView& q);
  void addSupport(double total, const SurfaceQuadratureView& q, const double* force);
  std::invalid_argument noSupport(const std::string& what, const double* x) const;
  void binQuadrature(const SurfaceQuadratureView& q);
  void add(std::uint32_t node, double weight, const double* force);
  void collect(NodalForces& out);

  const CgKernel& kernel_;
  double width_;
  std::vector<double> accumulated_;      // 3 per node, zero outside `touched_`
  std::vector<std::uint32_t> touched_;   // nodes with a non-zero entry
  std::vector<std::uint8_t> isTouched_;
  // Quadrature points binned in cubic cells of size c, so a contact visits its neighbourhood only.
  double lo_[3] = {0, 0, 0};
  std::int64_t cells_[3] = {1, 1, 1};
  std::vector<std::uint32_t> cellStart_, cellPoints_;
  std::vector<double> support_;          // a_q = w_q W(|x_q - x_c|) of the contact being mapped
  std::vector<std::uint32_t> supportPoints_;
};

}  // namespace cosim::coupler
