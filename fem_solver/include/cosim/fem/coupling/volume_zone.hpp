#pragma once
// Volume (Arlequin) coupling zone export (DESIGN.md 6.3, Cheng 2022 Sec. 5.2):
// the elements whose centroid lies in a box, their nodes, their 2x2x2
// quadrature points (current position, reference weight, element node ids,
// shape values) and the zone matrix int_{Omega^C} psi_i psi_j dV of Cheng
// Eq. 32 as (i, j, value) triplets over global node ids.
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
  /// Adds arrays "<name>/nodes", "/qp_positions", "/qp_weights", "/qp_nodes",
  /// "/qp_shapes", "/matrix" from index `first` on (6 slots).
  void fill(capnp::List<proto::NamedArray>::Builder arrays, unsigned first, const Mesh& mesh,
            const std::vector<double>& u) const;
  static constexpr unsigned kArrays = 6;

 private:
  std::string name_;
  std::vector<std::size_t> elements_;
  std::vector<Index> nodes_;
  std::vector<double> weights_, matrix_;
};

}  // namespace cosim::fem
