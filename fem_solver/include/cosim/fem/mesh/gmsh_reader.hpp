#pragma once
// Reader for Gmsh 4.1 ASCII meshes of eight-node hexahedra. Physical groups
// become named sets: a physical surface gives a face set (its quads, oriented
// outward by matching the hexahedron faces) and a node set; physical points
// and curves give node sets; a physical volume gives a node set of its
// elements' nodes. Errors name the file and line.
#include <istream>
#include <string>

#include "cosim/fem/mesh/mesh.hpp"

namespace cosim::fem {

Mesh readGmsh(const std::string& path);
Mesh readGmsh(std::istream& in, const std::string& name);

}  // namespace cosim::fem
