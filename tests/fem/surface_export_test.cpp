// Surface coupling export: four triangles per quad around the interpolated
// centre vertex, vertex-to-node weights that sum to one and reproduce the
// vertex positions, triangle areas and quadrature weights that add up to the
// deformed face area, and the export through the solver's setup outputs.
#include <capnp/message.h>
#include <gtest/gtest.h>

#include "cosim/fem/coupling/surface_export.hpp"
#include "cosim/fem/solver/fem_solver.hpp"
#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

TEST(FemSurfaceExport, TrianglesWeightsAndQuadrature) {
  const Mesh mesh = makeBoxMesh({0, 0, 0}, {0.8, 12, 0.8}, {2, 30, 2});
  const auto& faces = mesh.faceSet("zmax");
  SurfaceExport s("top", mesh, faces);
  EXPECT_EQ(s.numTriangles(), 4 * faces.size());
  EXPECT_EQ(s.numVertices(), mesh.nodeSet("zmax").size() + faces.size());
  for (std::size_t v = 0; v < s.numVertices(); ++v) {
    double w = 0.0;
    for (auto k = s.rowStart()[v]; k < s.rowStart()[v + 1]; ++k) w += s.nodeWeights()[k];
    EXPECT_NEAR(w, 1.0, 1e-15);
  }
  // Stretch the top in x by 10 % (u_x = 0.1 x): area grows to 0.88 x 12.
  std::vector<double> u(3 * mesh.numNodes(), 0.0), v(3 * mesh.numNodes(), 0.0);
  for (Index n = 0; n < mesh.numNodes(); ++n) {
    u[3 * n] = 0.1 * mesh.X[3 * n];
    v[3 * n + 2] = 2.0;
  }
  capnp::MallocMessageBuilder msg;
  auto data = msg.initRoot<proto::CouplingData>();
  auto meshes = data.initMeshes(1);
  s.fillMesh(meshes[0], mesh, u, v);
  auto quad = data.initQuadratures(1);
  s.fillQuadrature(quad[0], mesh, u);
  auto pos = meshes[0].asReader().getPositions();
  auto tri = meshes[0].asReader().getTriangles();
  double area = 0.0;
  bool outward = true;
  for (unsigned t = 0; t < tri.size() / 3; ++t) {
    Vec3 p[3];
    for (unsigned k = 0; k < 3; ++k)
      for (unsigned i = 0; i < 3; ++i) p[k][static_cast<int>(i)] = pos[3 * tri[3 * t + k] + i];
    const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
    area += 0.5 * n.norm();
    outward = outward && n.z() > 0.0;
  }
  double qarea = 0.0;
  for (double w : quad[0].getWeights()) qarea += w;
  std::printf("[surface] %zu triangles, area %.12f, quadrature area %.12f (exact %.12f)\n", s.numTriangles(), area,
              qarea, 0.88 * 12.0);
  EXPECT_NEAR(area, 0.88 * 12.0, 1e-12);
  EXPECT_NEAR(qarea, 0.88 * 12.0, 1e-12);
  EXPECT_TRUE(outward);  // every triangle faces +z
  for (unsigned k = 2; k < meshes[0].getVelocities().size(); k += 3) EXPECT_DOUBLE_EQ(meshes[0].getVelocities()[k], 2.0);
}

std::string exportScene(const std::string& quadrature) {
  return R"(solvers:
  - name: beam
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [0.8, 12, 0.8], divisions: [2, 30, 2]}}
      material: {E: 1.0e8, nu: 0.0, density: 1309}
      boundary: [{set: ymin}]
      integrator: {type: newmark}
      coupling: {surfaces: [zmax], quadrature: )" + quadrature + "}\n";
}

TEST(FemSurfaceExport, SolverExportsAtSetup) {
  const std::string yaml = exportScene("true");
  capnp::MallocMessageBuilder inMsg, outMsg;
  auto in = inMsg.initRoot<proto::CouplingData>();
  auto out = outMsg.initRoot<proto::CouplingData>();
  FemSolver solver;
  solver.setup({"s.yaml", yaml, "beam", "", in.asReader()}, out);
  ASSERT_EQ(out.getMeshes().size(), 1u);
  EXPECT_EQ(std::string(out.getMeshes()[0].getSurface().cStr()), "zmax");
  EXPECT_EQ(out.getMeshes()[0].getTriangles().size(), 3u * 4u * 60u);
  EXPECT_EQ(out.getQuadratures()[0].getWeights().size(), 4u * 60u);
}

TEST(FemSurfaceExport, SetupOnlyQuadratureGoesWithTheSetupReplyAlone) {
  capnp::MallocMessageBuilder inMsg, setupMsg, advanceMsg;
  auto in = inMsg.initRoot<proto::CouplingData>();
  auto atSetup = setupMsg.initRoot<proto::CouplingData>();
  FemSolver solver;
  solver.setup({"s.yaml", exportScene("setup"), "beam", "", in.asReader()}, atSetup);
  ASSERT_EQ(atSetup.getQuadratures().size(), 1u);
  EXPECT_EQ(atSetup.getQuadratures()[0].getWeights().size(), 4u * 60u);
  wire::AdvanceRequest request;
  request.steps = 1;
  request.dt = 1e-4;
  request.inputs = in.asReader();
  auto advanced = advanceMsg.initRoot<proto::CouplingData>();
  solver.advance(request, advanced);
  ASSERT_EQ(advanced.getMeshes().size(), 1u);  // the moving surface still goes every exchange
  EXPECT_EQ(advanced.getMeshes()[0].getPositions().size(), atSetup.getMeshes()[0].getPositions().size());
  EXPECT_EQ(advanced.getQuadratures().size(), 0u);
}

TEST(FemSurfaceExport, UnknownQuadratureChoiceIsRefusedNamingTheKey) {
  capnp::MallocMessageBuilder inMsg, outMsg;
  auto in = inMsg.initRoot<proto::CouplingData>();
  auto out = outMsg.initRoot<proto::CouplingData>();
  FemSolver solver;
  try {
    solver.setup({"s.yaml", exportScene("always"), "beam", "", in.asReader()}, out);
    FAIL() << "quadrature: always was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("coupling.quadrature must be true, false or setup"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace cosim::fem

#include "cosim/fem/coupling/volume_zone.hpp"

namespace cosim::fem {
namespace {

// Volume zone: partition of unity makes sum_ij int psi_i psi_j dV = V_zone
// and every point's shape values sum to one; the weights add up to V_zone.
TEST(FemVolumeZone, ZoneMatrixAndQuadrature) {
  const Mesh mesh = makeBoxMesh({0, 8, 0}, {0.8, 20, 0.8}, {2, 30, 2});
  VolumeZone zone("overlap", mesh, {-1, 8, -1}, {1, 12, 1});
  const double V = 0.64 * 4.0;
  EXPECT_EQ(zone.elements().size(), 2u * 10u * 2u);
  double sum = 0.0;
  for (std::size_t k = 2; k < zone.zoneMatrix().size(); k += 3) sum += zone.zoneMatrix()[k];
  capnp::MallocMessageBuilder msg;
  auto data = msg.initRoot<proto::CouplingData>();
  auto arrays = data.initArrays(VolumeZone::kArrays);
  // Distinct per-dof values show that the per-node arrays follow "<zone>/nodes".
  std::vector<double> u(3 * mesh.numNodes()), v(3 * mesh.numNodes()), m(mesh.numNodes());
  for (std::size_t d = 0; d < u.size(); ++d) u[d] = 1e-3 * static_cast<double>(d), v[d] = -2.0 * static_cast<double>(d);
  for (std::size_t n = 0; n < m.size(); ++n) m[n] = 0.5 + static_cast<double>(n);
  zone.fill(arrays, 0, mesh, u, v, m);
  double wsum = 0.0, worst = 0.0;
  for (double w : arrays[2].asReader().getValues()) wsum += w;
  auto shapes = arrays[4].asReader().getValues();
  for (unsigned p = 0; p < zone.numPoints(); ++p) {
    double s = 0.0;
    for (unsigned a = 0; a < 8; ++a) s += shapes[8 * p + a];
    worst = std::max(worst, std::abs(s - 1.0));
  }
  std::printf("[zone] sum M_ij = %.12f, sum weights = %.12f (V = %.12f), max |sum N - 1| = %.1e\n", sum, wsum, V, worst);
  EXPECT_NEAR(sum, V, 1e-12);
  EXPECT_NEAR(wsum, V, 1e-12);
  EXPECT_LT(worst, 1e-14);
  EXPECT_EQ(std::string(arrays[5].asReader().getName().cStr()), "overlap/matrix");
  // Connectivity, reference positions and nodal fields of the zone nodes.
  auto nodes = arrays[0].asReader().getValues();
  auto X = arrays[6].asReader().getValues();
  auto elements = arrays[7].asReader().getValues();
  auto disp = arrays[8].asReader().getValues(), vel = arrays[9].asReader().getValues();
  auto mass = arrays[10].asReader().getValues();
  EXPECT_EQ(std::string(arrays[7].asReader().getName().cStr()), "overlap/elements");
  ASSERT_EQ(elements.size(), 8u * zone.elements().size());
  ASSERT_EQ(X.size(), 3u * nodes.size());
  ASSERT_EQ(mass.size(), nodes.size());
  for (unsigned k = 0; k < nodes.size(); ++k) {
    const auto n = static_cast<std::size_t>(nodes[k]);
    EXPECT_EQ(mass[k], m[n]);
    for (unsigned i = 0; i < 3; ++i) {
      EXPECT_EQ(X[3 * k + i], mesh.X[3 * n + i]);
      EXPECT_EQ(disp[3 * k + i], u[3 * n + i]);
      EXPECT_EQ(vel[3 * k + i], v[3 * n + i]);
    }
  }
  for (unsigned a = 0; a < 8; ++a) EXPECT_EQ(elements[a], mesh.elements[zone.elements()[0]][a]);
}

}  // namespace
}  // namespace cosim::fem
