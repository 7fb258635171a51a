// Gmsh 4.1 reader: a two-hexahedron bar with physical groups reads into the
// same model as the equivalent box mesh (same static solution), faces are
// oriented outward, and malformed files give file:line errors.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <tuple>

#include "cosim/fem/mesh/gmsh_reader.hpp"
#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

// Two hexahedra along x with named end faces and volume (Gmsh 4.1 ASCII),
// shared with the fuzz targets' fixtures.
std::string barText() {
  std::ifstream in(COSIM_FEM_SOURCE_DIR "/tests/fem/data/two_hex_bar.msh");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}
const std::string kBar = barText();

TEST(FemGmsh, ReadsPhysicalGroupsAndMatchesBoxMesh) {
  std::istringstream in(kBar);
  Mesh mesh = readGmsh(in, "bar.msh");
  ASSERT_EQ(mesh.numNodes(), 12u);
  ASSERT_EQ(mesh.numElements(), 2u);
  EXPECT_EQ(mesh.nodeSet("left").size(), 4u);
  EXPECT_EQ(mesh.nodeSet("solid").size(), 12u);
  ASSERT_EQ(mesh.faceSet("right").size(), 1u);
  // Outward: the right face normal points +x although the file lists it inward.
  const Quad q = mesh.faceSet("right")[0];
  const Vec3 n = (mesh.node(q[1]) - mesh.node(q[0])).cross(mesh.node(q[2]) - mesh.node(q[0]));
  EXPECT_GT(n.x(), 0.0);
  auto solve = [](Mesh m) {
    auto model = test::makeModel(std::move(m), "incompatible-modes", 1e8, 0.3, 1000.0);
    for (Index node : model->mesh().nodeSet(model->mesh().nodeSets.count("left") ? "left" : "xmin"))
      for (int d = 0; d < 3; ++d) model->prescribe(node, d, Prescribed::Kind::displacement, 0.0);
    model->addTraction(model->mesh().faceSet(model->mesh().faceSets.count("right") ? "right" : "xmax"), Vec3(1e5, 0, -2e4));
    State s;
    s.resize(model->numDofs());
    solveStatic(*model, s, NewtonOptions{});
    return s.u;
  };
  const auto a = solve(std::move(mesh));
  const auto b = solve(makeBoxMesh({0, 0, 0}, {2, 1, 1}, {2, 1, 1}));  // same node numbering
  double diff = 0.0, mag = 0.0;
  for (std::size_t d = 0; d < a.size(); ++d) {
    diff = std::max(diff, std::abs(a[d] - b[d]));
    mag = std::max(mag, std::abs(b[d]));
  }
  std::printf("[gmsh] max |u_gmsh - u_box| = %.2e (max |u| = %.2e)\n", diff, mag);
  EXPECT_LT(diff, 1e-12 * mag);
}

TEST(FemGmsh, ErrorsNameFileAndLine) {
  std::string bad = kBar;
  bad.replace(bad.find("4 2 3 6 5 8 9 12 11"), 19, "4 2 3 6 5 8 9 12 99");
  std::istringstream in(bad);
  try {
    readGmsh(in, "bar.msh");
    ADD_FAILURE() << "expected an error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("bar.msh:52"), std::string::npos) << msg;
    EXPECT_NE(msg.find("undefined node 99"), std::string::npos) << msg;
  }
  std::istringstream v2("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n");
  EXPECT_THROW(readGmsh(v2, "old.msh"), InputError);
  // Counts that are negative or larger than the file: refused before allocating.
  for (const auto& [from, to, expected] :
       {std::tuple<std::string, std::string, std::string>{"1 12 1 12\n", "1 4000000000 1 12\n", "bar.msh:17: number of nodes 4000000000"},
        {"1 12 1 12\n", "1 -1 1 12\n", "bar.msh:17: number of nodes -1"},
        {"3 1 0 12\n", "3 1 0 -1\n", "bar.msh:18: nodes in block -1"}}) {
    std::string text = kBar;
    text.replace(text.find(from), from.size(), to);
    std::istringstream huge(text);
    try {
      readGmsh(huge, "bar.msh");
      ADD_FAILURE() << "accepted " << to;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected + " is negative or more than the file holds"), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace cosim::fem
