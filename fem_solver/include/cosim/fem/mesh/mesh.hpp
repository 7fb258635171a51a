#pragma once
// An unstructured mesh of eight-node hexahedra (VTK/XDMF node order) with
// named node sets and named boundary face sets.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "cosim/fem/types.hpp"

namespace cosim::fem {

using Hex = std::array<Index, 8>;
using Quad = std::array<Index, 4>;  // counter-clockwise seen from outside

/// Local node lists of the six hexahedron faces, outward normal.
extern const int kHexFaces[6][4];

class Mesh {
 public:
  std::vector<double> X;     // reference coordinates, 3 per node
  std::vector<Hex> elements;
  std::map<std::string, std::vector<Index>> nodeSets;
  std::map<std::string, std::vector<Quad>> faceSets;

  std::size_t numNodes() const { return X.size() / 3; }
  std::size_t numElements() const { return elements.size(); }
  Vec3 node(Index n) const { return {X[3 * n], X[3 * n + 1], X[3 * n + 2]}; }
  Mat83 elementCoordinates(std::size_t e) const;

  /// Throws InputError naming the set (and `context`, e.g. the config key) when absent.
  const std::vector<Index>& nodeSet(const std::string& name, const std::string& context = "") const;
  const std::vector<Quad>& faceSet(const std::string& name, const std::string& context = "") const;
  /// Nodes inside the closed box [lo, hi] (tolerance tol).
  std::vector<Index> nodesInBox(const Vec3& lo, const Vec3& hi, double tol = 1e-9) const;
  /// Boundary faces whose four nodes are in the box.
  std::vector<Quad> boundaryFacesInBox(const Vec3& lo, const Vec3& hi, double tol = 1e-9) const;
  /// All faces that belong to exactly one element.
  std::vector<Quad> boundaryFaces() const;
  /// Checks indices and that no node is unused; throws naming the element.
  void validate() const;
};

/// Periodic partner of every node in `maxNodes`: the node of `minNodes` at
/// X - offset (within tol). Pairs are (max node, min node). Throws InputError
/// naming the first node without a partner and its coordinates.
std::vector<std::pair<Index, Index>> matchPeriodicNodes(const Mesh& mesh, const std::vector<Index>& minNodes,
                                                        const std::vector<Index>& maxNodes, const Vec3& offset,
                                                        double tol);

/// Structured box [lo, hi] with n[0] x n[1] x n[2] elements. Defines node and
/// face sets xmin, xmax, ymin, ymax, zmin, zmax and the node set "all".
Mesh makeBoxMesh(const Vec3& lo, const Vec3& hi, const std::array<int, 3>& divisions);

}  // namespace cosim::fem
