// The contact-force maps of the surface coupling (Cheng 2022 Eqs. 14-16):
// total force conserved by both forms, total moment by the point form, and
// inconsistent input refused with a message. The smoothed (energy-consistent)
// wall: its force map and its kinematics are transposes, so a contact does the
// same work on the wall DEM feels and on the nodes.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "cosim/coupler/mapping/smoothed_surface.hpp"
#include "cosim/coupler/mapping/surface_force_map.hpp"

namespace cosim::coupler {
namespace {

// A flat nx x ny grid of unit quads in z = 0, triangulated as FEM exports it
// (four triangles per quad around the centre vertex, which takes 1/4 of each
// corner node), with 2 x 2 Gauss points per quad and bilinear shape values.
struct FlatSurface {
  std::vector<double> positions, nodeWeights, qpPositions, qpWeights, shapes;
  std::vector<std::uint32_t> triangles, rowStart{0}, nodeIds, qpNodes;
  std::vector<std::array<double, 3>> nodes;

  FlatSurface(int nx, int ny, double h) {
    auto node = [nx](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) nodes.push_back({i * h, j * h, 0.0});
    for (std::uint32_t k = 0; k < nodes.size(); ++k) addVertex(nodes[k], {{k, 1.0}});
    const double g = 0.5 / std::sqrt(3.0);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::array<std::uint32_t, 4> q{node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)};
        const std::array<double, 3> c{(i + 0.5) * h, (j + 0.5) * h, 0.0};
        const auto centre = static_cast<std::uint32_t>(positions.size() / 3);
        addVertex(c, {{q[0], 0.25}, {q[1], 0.25}, {q[2], 0.25}, {q[3], 0.25}});
        for (int e = 0; e < 4; ++e) triangles.insert(triangles.end(), {q[static_cast<std::size_t>(e)], q[static_cast<std::size_t>((e + 1) % 4)], centre});
        for (double sy : {-1.0, 1.0})
          for (double sx : {-1.0, 1.0}) {
            const double xi = 0.5 + sx * g, eta = 0.5 + sy * g;  // in [0, 1]
            qpPositions.insert(qpPositions.end(), {(i + xi) * h, (j + eta) * h, 0.0});
            qpWeights.push_back(0.25 * h * h);
            qpNodes.insert(qpNodes.end(), q.begin(), q.end());
            shapes.insert(shapes.end(), {(1 - xi) * (1 - eta), xi * (1 - eta), xi * eta, (1 - xi) * eta});
          }
      }
  }

  void addVertex(const std::array<double, 3>& x, std::vector<std::pair<std::uint32_t, double>> weights) {
    positions.insert(positions.end(), x.begin(), x.end());
    for (const auto& [n, w] : weights) {
      nodeIds.push_back(n);
      nodeWeights.push_back(w);
    }
    rowStart.push_back(static_cast<std::uint32_t>(nodeIds.size()));
  }

  SurfaceMeshView mesh() const { return {positions, triangles, rowStart, nodeIds, nodeWeights}; }
  SurfaceQuadratureView quadrature() const { return {qpPositions, qpWeights, 4, qpNodes, shapes}; }
};

// Contacts at random points of random triangles, with random forces.
struct Contacts {
  std::vector<std::uint32_t> triangles;
  std::vector<double> bary, points, forces;
  Contacts(const FlatSurface& s, int n, unsigned seed, double margin = 0.0, double extent = 0.0) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0), f(-100.0, 100.0);
    const std::size_t nt = s.triangles.size() / 3;
    while (static_cast<int>(triangles.size()) < n) {
      const auto t = static_cast<std::uint32_t>(rng() % nt);
      double a = u(rng), b = u(rng);
      if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
      const std::array<double, 3> w{1.0 - a - b, a, b};
      std::array<double, 3> x{0, 0, 0};
      for (int v = 0; v < 3; ++v)
        for (int d = 0; d < 3; ++d) x[static_cast<std::size_t>(d)] += w[static_cast<std::size_t>(v)] * s.positions[3 * s.triangles[3 * t + static_cast<std::size_t>(v)] + static_cast<std::size_t>(d)];
      if (extent > 0.0 && (x[0] < margin || x[0] > extent - margin || x[1] < margin || x[1] > extent - margin)) continue;
      triangles.push_back(t);
      bary.insert(bary.end(), w.begin(), w.end());
      points.insert(points.end(), x.begin(), x.end());
      for (int d = 0; d < 3; ++d) forces.push_back(f(rng));
    }
  }
  ContactsView view() const { return {triangles, bary, points, forces}; }
};

std::array<double, 6> forceAndMoment(std::span<const double> points, std::span<const double> forces) {
  std::array<double, 6> r{};
  for (std::size_t k = 0; 3 * k < forces.size(); ++k) {
    const double* x = &points[3 * k];
    const double* f = &forces[3 * k];
    r[0] += f[0], r[1] += f[1], r[2] += f[2];
    r[3] += x[1] * f[2] - x[2] * f[1];
    r[4] += x[2] * f[0] - x[0] * f[2];
    r[5] += x[0] * f[1] - x[1] * f[0];
  }
  return r;
}

std::array<double, 6> nodalForceAndMoment(const FlatSurface& s, const NodalForces& out) {
  std::vector<double> points;
  for (std::uint32_t id : out.ids) points.insert(points.end(), s.nodes[id].begin(), s.nodes[id].end());
  return forceAndMoment(points, out.forces);
}

std::unique_ptr<CgKernel> kernel(const std::string& name) { return CgKernelRegistry::create(name, "CG kernel"); }

TEST(SurfaceForceMap, PointFormConservesForceAndMomentToRoundOff) {
  const FlatSurface s(4, 6, 0.4);
  const Contacts c(s, 50, 1);
  const auto k = kernel("dirac");
  SurfaceForceMap map(*k, 0.0);
  NodalForces out;
  map.map(c.view(), s.mesh(), nullptr, out);
  const auto expected = forceAndMoment(c.points, c.forces);
  const auto got = nodalForceAndMoment(s, out);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(got[static_cast<std::size_t>(i)], expected[static_cast<std::size_t>(i)], 1e-11) << "component " << i;
}

TEST(SurfaceForceMap, PointFormGivesBilinearShapeValuesAtQuadCentre) {
  // A unit force at the centre vertex of quad (0, 0) goes 1/4 to each corner (psi_i = 1/4 there).
  const FlatSurface s(1, 1, 1.0);
  const std::vector<std::uint32_t> tri{0};
  const std::vector<double> bary{0, 0, 1}, point{0.5, 0.5, 0}, force{0, 0, -1};
  const auto k = kernel("dirac");
  SurfaceForceMap map(*k, 0.0);
  NodalForces out;
  map.map({tri, bary, point, force}, s.mesh(), nullptr, out);
  ASSERT_EQ(out.ids.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(out.forces[3 * i + 2], -0.25);
}

TEST(SurfaceForceMap, SmoothedFormConservesTotalForceForEveryWidthAndKernel) {
  const FlatSurface s(4, 6, 0.4);
  const Contacts c(s, 40, 2);
  const auto expected = forceAndMoment(c.points, c.forces);
  for (const char* name : {"lucy", "gaussian"})
    for (double width : {0.3, 0.8, 2.0, 10.0}) {
      const auto k = kernel(name);
      SurfaceForceMap map(*k, width);
      NodalForces out;
      const auto q = s.quadrature();
      map.map(c.view(), s.mesh(), &q, out);
      const auto got = nodalForceAndMoment(s, out);
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(got[static_cast<std::size_t>(i)], expected[static_cast<std::size_t>(i)], 1e-10) << name << " c = " << width;
    }
}

TEST(SurfaceForceMap, SmoothedFormConservesMomentWhereTheKernelSupportIsSymmetric) {
  // A contact at a node of a uniform grid, its kernel support inside the surface:
  // the quadrature points around it are symmetric, so the smeared traction's
  // centroid is the contact point and the moment is kept.
  const FlatSurface s(8, 8, 0.25);
  const std::vector<double> bary{1, 0, 0}, point{1.0, 1.0, 0.0}, force{3.0, -2.0, -50.0};
  std::vector<std::uint32_t> triangle{0};
  // Find a triangle with vertex at (1, 1).
  for (std::size_t t = 0; t < s.triangles.size() / 3; ++t)
    if (s.triangles[3 * t] == 4 * 9 + 4) triangle[0] = static_cast<std::uint32_t>(t);
  const auto k = kernel("lucy");
  SurfaceForceMap map(*k, 0.6);
  NodalForces out;
  const auto q = s.quadrature();
  map.map({triangle, bary, point, force}, s.mesh(), &q, out);
  const auto expected = forceAndMoment(point, force);
  const auto got = nodalForceAndMoment(s, out);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(got[static_cast<std::size_t>(i)], expected[static_cast<std::size_t>(i)], 1e-10) << i;
  EXPECT_GT(out.ids.size(), 4u) << "a width of 0.6 m spreads the force over more than one quad";
}

TEST(SurfaceForceMap, RefusesInconsistentInput) {
  const FlatSurface s(2, 2, 1.0);
  const auto dirac = kernel("dirac");
  SurfaceForceMap map(*dirac, 0.0);
  NodalForces out;
  const std::vector<std::uint32_t> tri{999};
  const std::vector<double> bary{1, 0, 0}, point{0, 0, 0}, force{0, 0, 1}, shortForce{0, 0};
  EXPECT_THROW(map.map({tri, bary, point, force}, s.mesh(), nullptr, out), std::invalid_argument);
  const std::vector<std::uint32_t> ok{0};
  EXPECT_THROW(map.map({ok, bary, point, shortForce}, s.mesh(), nullptr, out), std::invalid_argument);
  const auto lucy = kernel("lucy");
  SurfaceForceMap smoothed(*lucy, 1.0);
  try {
    smoothed.map({ok, bary, point, force}, s.mesh(), nullptr, out);
    FAIL() << "a CG map without quadrature points must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("quadrature"), std::string::npos) << e.what();
  }
  // A width below the quadrature spacing leaves a contact without support.
  SurfaceForceMap tiny(*lucy, 1e-3);
  const auto q = s.quadrature();
  EXPECT_THROW(tiny.map({ok, bary, point, force}, s.mesh(), &q, out), std::invalid_argument);
}

// A smooth nodal field (displacement or velocity) on the flat surface's nodes,
// and the vertex values the surface export would carry for it.
std::vector<double> nodalField(const FlatSurface& s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> field;
  for (std::size_t n = 0; n < s.nodes.size(); ++n)
    for (int d = 0; d < 3; ++d) field.push_back(u(rng));
  return field;
}

std::vector<double> vertexValues(const FlatSurface& s, const std::vector<double>& nodal) {
  std::vector<double> out(s.positions.size(), 0.0);
  for (std::size_t v = 0; v + 1 < s.rowStart.size(); ++v)
    for (std::uint32_t e = s.rowStart[v]; e < s.rowStart[v + 1]; ++e)
      for (std::size_t d = 0; d < 3; ++d) out[3 * v + d] += s.nodeWeights[e] * nodal[3 * s.nodeIds[e] + d];
  return out;
}

TEST(SmoothedSurface, ContactDoesEqualWorkOnTheWallAndOnTheNodes) {
  const FlatSurface s(4, 6, 0.4);
  const Contacts c(s, 30, 5);
  const auto lucy = kernel("lucy");
  for (double width : {0.3, 0.8, 2.0}) {
    SurfaceForceMap cg(*lucy, width);
    const auto q = s.quadrature();
    const SmoothedSurface smoothed(cg, s.mesh(), q);
    // Deform the surface, give its nodes velocities, and let DEM's contacts act on it.
    const auto u = nodalField(s, 11), vNodes = nodalField(s, 12);
    std::vector<double> x = vertexValues(s, u);
    for (std::size_t k = 0; k < x.size(); ++k) x[k] += s.positions[k];
    SurfaceMeshView now = s.mesh();
    now.positions = x;
    std::vector<double> wallX, wallV;
    smoothed.kinematics(now, vertexValues(s, vNodes), wallX, wallV);
    const auto dirac = kernel("dirac");
    SurfaceForceMap point(*dirac, 0.0);
    NodalForces out;
    point.map(c.view(), smoothed.withSmoothedWeights(now), nullptr, out);
    double wallPower = 0.0, nodalPower = 0.0, scale = 0.0;
    for (std::size_t k = 0; k < c.triangles.size(); ++k)
      for (std::size_t v = 0; v < 3; ++v) {
        const std::size_t vertex = s.triangles[3 * c.triangles[k] + v];
        for (std::size_t d = 0; d < 3; ++d) {
          wallPower += c.bary[3 * k + v] * wallV[3 * vertex + d] * c.forces[3 * k + d];
          scale += std::abs(c.bary[3 * k + v] * wallV[3 * vertex + d] * c.forces[3 * k + d]);
        }
      }
    for (std::size_t k = 0; k < out.ids.size(); ++k)
      for (std::size_t d = 0; d < 3; ++d) nodalPower += out.forces[3 * k + d] * vNodes[3 * out.ids[k] + d];
    EXPECT_NEAR(nodalPower, wallPower, 1e-12 * scale) << "c = " << width;
    // The total force still arrives whole.
    const auto got = nodalForceAndMoment(s, out), expected = forceAndMoment(c.points, c.forces);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(got[static_cast<std::size_t>(i)], expected[static_cast<std::size_t>(i)], 1e-10);
  }
}

TEST(SmoothedSurface, ReproducesRestAndRigidTranslationAndSmoothsTheRest) {
  const FlatSurface s(4, 6, 0.4);
  const auto lucy = kernel("lucy");
  SurfaceForceMap cg(*lucy, 1.0);
  const auto q = s.quadrature();
  const SmoothedSurface smoothed(cg, s.mesh(), q);
  for (std::size_t v = 0; v + 1 < smoothed.weights().rowStart.size(); ++v) {
    double sum = 0.0;
    for (auto e = smoothed.weights().rowStart[v]; e < smoothed.weights().rowStart[v + 1]; ++e) sum += smoothed.weights().weights[e];
    EXPECT_NEAR(sum, 1.0, 1e-13) << "row " << v;
  }
  std::vector<double> x, v;
  const std::vector<double> still(s.positions.size(), 0.0);
  smoothed.kinematics(s.mesh(), still, x, v);
  for (std::size_t k = 0; k < x.size(); ++k) EXPECT_EQ(x[k], s.positions[k]);
  // A rigid translation moves every vertex by exactly that much, edges included.
  std::vector<double> moved(s.positions);
  for (std::size_t k = 0; k < moved.size(); ++k) moved[k] += (k % 3 == 2) ? 0.25 : -0.5;
  SurfaceMeshView now = s.mesh();
  now.positions = moved;
  smoothed.kinematics(now, still, x, v);
  for (std::size_t k = 0; k < x.size(); ++k) EXPECT_NEAR(x[k], moved[k], 1e-14);
  // A single raised node is spread over its neighbours: less under it, some beside it.
  moved = s.positions;
  const std::size_t centreNode = 3 * 5 + 2;  // node (2, 3), its vertex has the same index
  moved[3 * centreNode + 2] = 1.0;
  now.positions = moved;
  smoothed.kinematics(now, still, x, v);
  EXPECT_LT(x[3 * centreNode + 2], 1.0);
  EXPECT_GT(x[3 * centreNode + 2], 0.0);
  EXPECT_GT(x[3 * (centreNode + 1) + 2], 0.0);
}

TEST(SmoothedSurface, RefusesASurfaceWithoutAVertexOnEveryNode) {
  FlatSurface s(2, 2, 0.5);
  s.nodeWeights[0] = 0.5;  // node 0's own vertex no longer sits on it
  const auto lucy = kernel("lucy");
  SurfaceForceMap cg(*lucy, 1.0);
  const auto q = s.quadrature();
  try {
    const SmoothedSurface smoothed(cg, s.mesh(), q);
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("node 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::coupler
