#pragma once
// Surface coupling export (DESIGN.md 6.3, Cheng 2022 Sec. 5.1): a face set as
// moving triangles, four per quad around an interpolated centre vertex, with
// vertex-to-node weights; and surface quadrature points (2 x 2 Gauss per
// face, current configuration) for the CG-enriched force map (Cheng Eqs. 14-15).
#include <string>
#include <vector>

#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/fem/types.hpp"
#include "surface.capnp.h"

namespace cosim::fem {

class SurfaceExport {
 public:
  SurfaceExport(std::string name, const Mesh& mesh, const std::vector<Quad>& faces);
  const std::string& name() const { return name_; }
  std::size_t numVertices() const { return rowStart_.size() - 1; }
  std::size_t numTriangles() const { return triangles_.size() / 3; }
  const std::vector<std::uint32_t>& triangles() const { return triangles_; }
  /// Vertex v = sum_k nodeWeights[k] node[nodeIds[k]], k in [rowStart[v], rowStart[v+1]).
  const std::vector<std::uint32_t>& rowStart() const { return rowStart_; }
  const std::vector<std::uint32_t>& nodeIds() const { return nodeIds_; }
  const std::vector<double>& nodeWeights() const { return nodeWeights_; }
  /// Interpolates a nodal field (3 per node) to the vertices.
  std::vector<double> interpolate(const std::vector<double>& nodal) const;
  void fillMesh(proto::TriangleMeshKinematics::Builder out, const Mesh& mesh, const std::vector<double>& u,
                const std::vector<double>& v) const;
  void fillQuadrature(proto::SurfaceQuadrature::Builder out, const Mesh& mesh, const std::vector<double>& u) const;

 private:
  std::string name_;
  std::vector<Quad> faces_;
  std::vector<std::uint32_t> triangles_, rowStart_, nodeIds_;
  std::vector<double> nodeWeights_;
};

}  // namespace cosim::fem
