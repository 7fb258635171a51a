// Fuzz target: the Gmsh 4.1 reader (readGmsh) on fuzzed .msh text, then what
// fem_solver does with the mesh of `mesh: {gmsh: FILE}`: a model built on it
// (the mesh validated, element geometry and lumped mass computed) and its
// physical groups looked up as node and face sets. A bad file must end in an
// InputError; one from the reader must name the file and line.
//
// Input layout: the .msh text, read from memory as the file "fuzz.msh".
#include <sstream>

#include "cosim/fem/material/material.hpp"
#include "cosim/fem/mesh/gmsh_reader.hpp"
#include "cosim/fem/model/model.hpp"
#include "cosim/fem/registry.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

constexpr const char* kName = "fuzz.msh";

// The sets a scene's boundary, loads and coupling would name.
void useSets(const fem::Model& model) {
  const fem::Mesh& mesh = model.mesh();
  for (const auto& [name, nodes] : mesh.nodeSets)
    if (!nodes.empty()) (void)mesh.nodeSet(name, "fuzz");
  for (const auto& [name, faces] : mesh.faceSets)
    if (!faces.empty()) (void)mesh.faceSet(name, "fuzz");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto text = fuzz::inputText(data, size);
  if (!text) return -1;
  std::istringstream in{std::string(*text)};
  fem::Mesh mesh;
  try {
    mesh = fem::readGmsh(in, kName);
  } catch (const fem::InputError& e) {
    fuzz::userError(e, {kName});
    return 0;
  }
  try {
    auto material = fem::MaterialRegistry::instance().create("st-venant-kirchhoff", fem::MaterialParams{1e6, 0.3, 1000.0});
    const fem::Model model(std::move(mesh), std::move(material), fem::FormulationRegistry::instance().create("full"),
                           fem::FormulationOptions{});
    useSets(model);
  } catch (const fem::InputError& e) {
    fuzz::userError(e);
  }
  return 0;
}

namespace cosim::fuzz {

// Seeds: the fixture bar (two hexahedra, named surfaces and volume), and
// hand-made files with what it lacks: physical points and curves, several
// node blocks, an unknown section, CRLF line ends.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out{bytesOf(barMesh())};
  const std::string cube = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$Comments
made by hand
$EndComments
$Entities
1 1 1 1
1 0 0 0 1 7
1 0 0 0 1 0 0 1 8 2 1 2
1 0 0 0 1 1 0 1 -9 0
1 0 0 0 1 1 1 0 0
$EndEntities
$Nodes
2 8 1 8
0 1 0 1
1
0 0 0
3 1 0 7
2
3
4
5
6
7
8
1 0 0
1 1 0
0 1 0
0 0 1
1 0 1
1 1 1
0 1 1
$EndNodes
$Elements
4 4 1 4
0 1 15 1
1 1
1 1 1 1
2 1 2
2 1 3 1
3 1 4 3 2
3 1 5 1
4 1 2 3 4 5 6 7 8
$EndElements
)";
  out.push_back(bytesOf(cube));
  std::string crlf;
  for (const char c : barMesh()) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  out.push_back(bytesOf(crlf));
  return out;
}

}  // namespace cosim::fuzz
