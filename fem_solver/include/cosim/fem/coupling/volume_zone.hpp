#pragma once
// Volume (Arlequin) coupling zone export (DESIGN.md 6.3, Cheng 2022 Sec. 5.2):
// the elements whose centroid lies in a box, their nodes, their 2x2x2
// quadrature points (current position, reference weight, element node ids,
// shape values) and the zone matrix int_{Omega^C} psi_i psi_j dV of Cheng
// Eq. 32 as (i, j, value) triplets over global node ids; the zone's element
// connectivity and reference node positions (for the coupler's inverse
// isoparametric map, Cheng Eq. 27 with c = 0) and the zone nodes'
// displacements, velocities and weighted masses.
#include <string>
#include <vector>

#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/fem/types.hpp"
#include "data.capnp.h"

namespace cosim::fem {

class VolumeZone {
 public:
  VolumeZone(std::string name, const Mesh& mesh, const Vec3& lo, const Vec3& hi);
  const std::string& name() const { return name_; }
  const std::vector<std::size_t>& elements() const { return elements_; }
  const std::vector<Index>& nodes() const { return nodes_; }
  /// (i, j, value) triplets, 3 per entry.
  const std::vector<double>& zoneMatrix() const { return matrix_; }
  std::size_t numPoints() const { return 8 * elements_.size(); }
  /// Adds, from index `first` on (kArrays slots): "<name>/nodes" (global ids),
  /// "/node_positions" (reference, 3 per zone node), "/elements" (8 global
  /// node ids per element), "/qp_positions" (current), "/qp_weights",
  /// "/qp_nodes", "/qp_shapes", "/matrix", and per zone node "/displacement",
  /// "/velocity" (3 each) and "/masses" (lumped, Arlequin-weighted by 1 - w).
  void fill(capnp::List<proto::NamedArray>::Builder arrays, unsigned first, const Mesh& mesh,
            const std::vector<double>& u, const std::vector<double>& v, const std::vector<double>& lumpedMass) const;
  static constexpr unsigned kArrays = 11;

 private:
  std::string name_;
  std::vector<std::size_t> elements_;
  std::vector<Index> nodes_;
  std::vector<double> weights_, matrix_;
};

}  // namespace cosim::fem
