// Triangle-mesh walls (Cheng 2022 Sec. 5.1.1): a sphere sliding over a
// triangulated plane feels the force of a single plane; forces across concave
// and convex edges are continuous; contacts report triangle and barycentrics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <cstdlib>
#include <random>

#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

constexpr double kR = 0.01;

// Triangulations of the square [-L, L]^2 in the plane z = 0, normals +z.
TriangleWallGroup gridTwo(double L, int n) {  // each square cut along its diagonal
  TriangleWallGroup g;
  const double h = 2 * L / n;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) g.vertices.push_back({-L + i * h, -L + j * h, 0});
  auto id = [n](int i, int j) { return static_cast<std::uint32_t>(i + (n + 1) * j); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      g.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      g.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return g;
}

TriangleWallGroup gridFour(double L, int n) {  // four triangles around each square's centre (Cheng 2022 Fig. 3)
  TriangleWallGroup g;
  const double h = 2 * L / n;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) g.vertices.push_back({-L + i * h, -L + j * h, 0});
  auto id = [n](int i, int j) { return static_cast<std::uint32_t>(i + (n + 1) * j); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const auto c = static_cast<std::uint32_t>(g.vertices.size());
      g.vertices.push_back({-L + (i + 0.5) * h, -L + (j + 0.5) * h, 0});
      g.triangles.push_back({id(i, j), id(i + 1, j), c});
      g.triangles.push_back({id(i + 1, j), id(i + 1, j + 1), c});
      g.triangles.push_back({id(i + 1, j + 1), id(i, j + 1), c});
      g.triangles.push_back({id(i, j + 1), id(i, j), c});
    }
  return g;
}

TriangleWallGroup fan(double L, int spokes) {  // many triangles meeting at the origin, closed by a square rim
  TriangleWallGroup g;
  const Vec3 c{-0.02, -0.02, 0};  // on the slider's path
  g.vertices.push_back(c);
  for (int k = 0; k < spokes; ++k) {
    const double a = 2 * std::numbers::pi * k / spokes;
    g.vertices.push_back(c + Vec3{0.5 * L * std::cos(a), 0.5 * L * std::sin(a), 0});
  }
  for (int k = 0; k < spokes; ++k)
    g.triangles.push_back({0, static_cast<std::uint32_t>(1 + k), static_cast<std::uint32_t>(1 + (k + 1) % spokes)});
  // Outer ring out to a big square, so the sphere never leaves the surface.
  const auto base = static_cast<std::uint32_t>(g.vertices.size());
  for (int k = 0; k < spokes; ++k) {
    const double a = 2 * std::numbers::pi * k / spokes;
    g.vertices.push_back(c + Vec3{3 * L * std::cos(a), 3 * L * std::sin(a), 0});
  }
  for (int k = 0; k < spokes; ++k) {
    const auto i0 = static_cast<std::uint32_t>(1 + k), i1 = static_cast<std::uint32_t>(1 + (k + 1) % spokes);
    const auto o0 = base + static_cast<std::uint32_t>(k), o1 = base + static_cast<std::uint32_t>((k + 1) % spokes);
    g.triangles.push_back({i0, o0, o1});
    g.triangles.push_back({i0, o1, i1});
  }
  return g;
}

TriangleWallGroup irregular(double L, int n, unsigned seed) {  // grid with jittered interior vertices
  TriangleWallGroup g = gridTwo(L, n);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  const double h = 2 * L / n;
  for (auto& v : g.vertices)
    if (std::fabs(v.x) < L - 1e-12 && std::fabs(v.y) < L - 1e-12) {
      v.x += u(rng) * h;
      v.y += u(rng) * h;
    }
  return g;
}

DemSystem slider(const Material& m) {
  DemSystem s;
  s.setContactLaw("hertz", "mindlin", "restitution");
  s.materials.add(m);
  // Start at the static overlap under the load (E = 1e7 Pa: about 0.2 mm), so
  // the sphere slides instead of bouncing.
  s.particles.add({-0.04, -0.04, kR - 2.0e-4}, kR, m.density);
  s.particles.v[0] = {0.5, 0.5, 0};
  s.particles.omega[0] = {0, 0, 3};
  s.gravity = {0, 0, -200};  // presses the sphere on while it slides
  s.neighbors.skin = 0.1 * kR;
  return s;
}

// Largest |f_mesh - f_plane| / |f_plane| over a slide across the surface.
double slideMismatch(TriangleWallGroup mesh, Vec3 velocity, std::size_t* contactsSeen = nullptr) {
  Material m = glass(0.7, 0.3);
  m.young = 1e7;
  DemSystem plane = slider(m), tri = slider(m);
  plane.particles.v[0] = tri.particles.v[0] = velocity;
  plane.planes.push_back(PlaneWall{});
  mesh.name = "surface";
  mesh.velocities.assign(mesh.vertices.size(), {});
  tri.meshes.push_back(mesh);
  plane.initialize();
  tri.initialize();
  double worst = 0.0;
  std::size_t seen = 0;
  for (int step = 0; step < 4000; ++step) {
    plane.advance(2e-5);
    tri.advance(2e-5);
    const double fp = norm(plane.particles.f[0] - plane.gravity * plane.particles.mass[0]);
    if (fp == 0.0) continue;
    const Vec3 df = tri.particles.f[0] - plane.particles.f[0];
    const Vec3 dt = tri.particles.torque[0] - plane.particles.torque[0];
    if (std::getenv("DEM_DEBUG") && norm(df) / fp > 1e-9)
      std::printf("step %d x=(%g %g %g) fp=%g df=%g contacts=%zu tri=%u bary=(%g %g %g)\n", step, tri.particles.x[0].x,
                  tri.particles.x[0].y, tri.particles.x[0].z, fp, norm(df), tri.meshes[0].contacts.size(),
                  tri.meshes[0].contacts.empty() ? 0u : tri.meshes[0].contacts[0].triangle,
                  tri.meshes[0].contacts.empty() ? 0.0 : tri.meshes[0].contacts[0].bary[0],
                  tri.meshes[0].contacts.empty() ? 0.0 : tri.meshes[0].contacts[0].bary[1],
                  tri.meshes[0].contacts.empty() ? 0.0 : tri.meshes[0].contacts[0].bary[2]);
    worst = std::max(worst, norm(df) / fp);
    worst = std::max(worst, norm(dt) / (fp * kR));
    seen += tri.meshes[0].contacts.size();
    EXPECT_EQ(tri.meshes[0].contacts.size(), 1u) << "step " << step;
  }
  if (contactsSeen) *contactsSeen = seen;
  std::printf("  slid from (-0.04, -0.04) to (%.4f, %.4f), %llu neighbour builds\n", tri.particles.x[0].x,
              tri.particles.x[0].y, static_cast<unsigned long long>(tri.neighbors.builds));
  EXPECT_GT(norm(tri.particles.x[0] - Vec3{-0.04, -0.04, tri.particles.x[0].z}), 0.03);
  return worst;
}

TEST(DemTriangleWalls, ClosestPointBarycentrics) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  auto cp = closestPointOnTriangle({0.2, 0.3, 1}, a, b, c);  // face
  EXPECT_NEAR(cp.point.x, 0.2, 1e-15);
  EXPECT_NEAR(cp.bary[1], 0.2, 1e-15);
  EXPECT_NEAR(cp.bary[2], 0.3, 1e-15);
  cp = closestPointOnTriangle({2, -1, 0}, a, b, c);  // vertex b
  EXPECT_EQ(cp.bary[1], 1.0);
  cp = closestPointOnTriangle({1, 1, 0}, a, b, c);  // edge bc midpoint
  EXPECT_NEAR(cp.bary[1], 0.5, 1e-15);
  EXPECT_NEAR(cp.bary[2], 0.5, 1e-15);
}

TEST(DemTriangleWalls, SlidingOverTriangulationsEqualsSinglePlane) {
  struct Case {
    const char* name;
    TriangleWallGroup mesh;
    Vec3 velocity;
  };
  const std::vector<Case> cases{
      {"2 per square, through vertices", gridTwo(0.1, 16), {0.5, 0.5, 0}},
      {"2 per square, oblique", gridTwo(0.1, 16), {0.6, 0.23, 0}},
      {"4 per square (Cheng), through centres", gridFour(0.1, 16), {0.5, 0.5, 0}},
      {"4 per square, along edges", gridFour(0.1, 16), {0.8, 0.0, 0}},
      {"fan of 24 at the path", fan(0.1, 24), {0.5, 0.5, 0}},
      {"irregular", irregular(0.1, 12, 5), {0.55, 0.4, 0}},
  };
  for (const Case& c : cases) {
    std::size_t seen = 0;
    const double worst = slideMismatch(c.mesh, c.velocity, &seen);
    std::printf("%-40s: max relative force/torque difference to a plane %.3e\n", c.name, worst);
    EXPECT_LT(worst, 1e-9) << c.name;
    EXPECT_GT(seen, 1000u);
  }
}

// Force on a frictionless sphere at x, in contact with a surface.
Vec3 staticForce(const TriangleWallGroup& mesh, const Vec3& x) {
  DemSystem s;
  s.setContactLaw("hertz", "none", "none");
  s.materials.add(glass());
  s.particles.add(x, kR, 2500);
  TriangleWallGroup g = mesh;
  g.velocities.assign(g.vertices.size(), {});
  s.meshes.push_back(g);
  s.neighbors.skin = 0.1 * kR;
  s.initialize();
  return s.particles.f[0];
}

// Two strips meeting along the y axis, each tilted by angle a about it
// (a > 0: concave valley, a < 0: convex ridge, 0: flat).
TriangleWallGroup crease(double a) {
  TriangleWallGroup g;
  const double L = 0.05, z = L * std::tan(a);
  g.vertices = {{-L, -L, z}, {0, -L, 0}, {0, L, 0}, {-L, L, z}, {L, -L, z}, {L, L, z}};
  g.triangles = {{0, 1, 2}, {0, 2, 3}, {1, 4, 5}, {1, 5, 2}};
  return g;
}

TEST(DemTriangleWalls, ForceContinuousAcrossConcaveAndConvexEdges) {
  for (double deg : {10.0, 2.0, 0.0, -2.0, -10.0}) {
    const TriangleWallGroup g = crease(deg * std::numbers::pi / 180.0);
    double maxJump = 0.0, maxF = 0.0;
    Vec3 last{};
    const int n = 4000;
    for (int k = 0; k <= n; ++k) {
      const double x = -1.5 * kR + 3.0 * kR * k / n;
      // Hold the sphere at a fixed overlap with the nearer strip's plane.
      const double zs = std::fabs(x) * std::tan(deg * std::numbers::pi / 180.0);
      const Vec3 f = staticForce(g, {x, 0.001, zs + kR * std::cos(deg * std::numbers::pi / 180.0) - 1e-4});
      if (k > 0) maxJump = std::max(maxJump, norm(f - last));
      maxF = std::max(maxF, norm(f));
      last = f;
    }
    std::printf("crease %+5.1f deg: max force %.4e N, largest jump between samples %.3e (relative %.3e)\n", deg,
                maxF, maxJump, maxJump / maxF);
    EXPECT_GT(maxF, 0.0);
    // 4000 samples over 3 R: a continuous force changes by far less than 1 % per sample.
    EXPECT_LT(maxJump / maxF, 0.01) << deg;
  }
}

TEST(DemTriangleWalls, ContactReportsTriangleBarycentricsAndForce) {
  TriangleWallGroup g = gridTwo(0.1, 4);
  g.velocities.assign(g.vertices.size(), {});
  DemSystem s;
  s.setContactLaw("hertz", "none", "none");
  s.materials.add(glass());
  s.particles.add({0.013, 0.031, kR - 1e-4}, kR, 2500);
  s.meshes.push_back(g);
  s.neighbors.skin = 0.1 * kR;
  s.initialize();
  ASSERT_EQ(s.meshes[0].contacts.size(), 1u);
  const TriangleContact& c = s.meshes[0].contacts[0];
  const auto& tri = g.triangles[c.triangle];
  Vec3 p;
  for (int k = 0; k < 3; ++k) p += c.bary[static_cast<std::size_t>(k)] * g.vertices[tri[static_cast<std::size_t>(k)]];
  EXPECT_NEAR(p.x, 0.013, 1e-15);
  EXPECT_NEAR(p.y, 0.031, 1e-15);
  EXPECT_NEAR(c.force.z, -s.particles.f[0].z, 1e-12);
  EXPECT_LT(c.force.z, 0.0);  // the particle pushes the wall down
  EXPECT_NEAR(s.meshes[0].force.z, c.force.z, 1e-15);
}

// A coupled FE surface sets the wall's vertices every exchange, and DEM moves
// them with the velocities it was sent in between (wall_kinematics:
// extrapolated). Where the two disagree the vertices jump, and the jump does
// work on the particles in contact. A sphere rests on a four-triangle grid
// that rises and falls by 10 um at 50 Hz, from rest (the contact rings at
// 490 Hz, its static overlap is 1 um):
// the wall's work must equal the change of kinetic + elastic + potential
// energy. Returns the balance's error over the largest work of the run.
double wallSetFromOutsideBalanceError(bool sendVelocities) {
  TriangleWallGroup g = gridFour(0.1, 2);
  g.velocities.assign(g.vertices.size(), {});
  DemSystem s;
  s.setContactLaw("linear", "none", "none");
  s.materials.add(glass());  // k_n = 1e5 N/m
  s.gravity = {0, 0, -9.81};
  const double mass = 2500 * 4.0 / 3.0 * std::numbers::pi * kR * kR * kR;
  s.particles.add({0.013, 0.031, kR - mass * 9.81 / 1e5}, kR, 2500);
  s.meshes.push_back(g);
  s.neighbors.skin = 0.1 * kR;
  s.initialize();
  const double amplitude = 1e-5, omega = 2 * std::numbers::pi / 0.02, dt = 1e-5;
  const int sub = 10;  // DEM steps per exchange
  auto lift = [&](double t) { return 0.5 * amplitude * (1.0 - std::cos(omega * t)); };
  const Energies start = energies(s);
  double largest = 0.0, worst = 0.0;
  for (int x = 1; x <= 400; ++x) {  // two periods
    const double t = x * sub * dt;
    // The FE surface at t, moving on with the secant velocity of the last interval.
    const double z = lift(t), vz = sendVelocities ? (z - lift(t - sub * dt)) / (sub * dt) : 0.0;
    for (std::size_t v = 0; v < s.meshes[0].vertices.size(); ++v) {
      s.meshes[0].vertices[v].z = z;
      s.meshes[0].velocities[v] = {0, 0, vz};
    }
    for (int k = 0; k < sub; ++k) s.advance(dt);
    EXPECT_EQ(s.meshes[0].contacts.size(), 1u) << "the sphere left the wall at exchange " << x;
    const Energies e = energies(s);
    largest = std::max(largest, std::abs(e.externalWork - start.externalWork));
    worst = std::max(worst, std::abs(e.balance() - start.balance()));
  }
  std::printf("wall set from outside (%s velocities): largest work %.4e J, worst balance error %.3e J\n",
              sendVelocities ? "secant" : "no", largest, worst);
  return worst / largest;
}

TEST(DemTriangleWalls, AWallSetFromOutsideDoesTheWorkOfItsJumps) {
  // The wall's work f_end . v_wall dt alone would miss every jump (with no
  // velocities sent, all of the wall's work), and the contact springs of
  // triangle walls count in the elastic energy (1.5 % of the largest work
  // here). The trapezoid is exact for a
  // linear spring: the balance closes to round-off (2e-13 J of 1e-6 J).
  EXPECT_LT(wallSetFromOutsideBalanceError(false), 1e-6);
  EXPECT_LT(wallSetFromOutsideBalanceError(true), 1e-6);
}

}  // namespace
}  // namespace cosim::dem::test

namespace cosim::dem::test {
namespace {

// Love-Weber stress with walls (Liu 2016 Eq. 54, walls as contact partners):
// two spheres in a row pressed between a plane wall at x = 0 and a wall at
// x = L, at rest and in equilibrium (each contact carries the same Hertz force
// F). Over the volume between the walls, sigma_xx V = -F L exactly; the pair
// term alone gives -F (2r - u_p), so the wall terms carry the difference.
void checkWallStress(bool triangleLid) {
  DemSystem s;
  s.setContactLaw("hertz", "none", "none");
  s.materials.add(glass());
  s.gravity = {};
  // Equal forces: wall contacts have R* = r, the pair R* = r/2, so u_p = 2^(1/3) u_w.
  const double uw = 2e-5, up = std::cbrt(2.0) * uw;
  const double xa = kR - uw, xb = xa + 2 * kR - up, length = xb + kR - uw;
  const double y = 0.2 * kR, z = -0.1 * kR;
  s.particles.add({xa, y, z}, kR, 2500);
  s.particles.add({xb, y, z}, kR, 2500);
  PlaneWall left;
  left.normal = {1, 0, 0};
  s.planes.push_back(left);
  if (triangleLid) {
    TriangleWallGroup g;
    const double h = 0.05;
    g.vertices = {{length, -h, -h}, {length, h, -h}, {length, h, h}, {length, -h, h}};
    g.triangles = {{0, 1, 2}, {0, 2, 3}};
    g.velocities.assign(g.vertices.size(), {});
    s.meshes.push_back(g);
  } else {
    PlaneWall right;
    right.point = {length, 0, 0};
    right.normal = {-1, 0, 0};
    s.planes.push_back(right);
  }
  s.neighbors.skin = 0.1 * kR;
  s.initialize();
  const double force = -s.planes[0].force.x;  // the particles push the left wall towards -x
  ASSERT_GT(force, 0.0);
  EXPECT_NEAR(norm(s.particles.f[0]), 0.0, 1e-12 * force);  // equilibrium to round-off
  const double area = 1e-4, volume = area * length;
  const auto sig = loveWeberStress(s, volume);
  std::printf("%s lid: sigma_xx %.10e Pa, -F/A %.10e Pa, pair term alone %.10e Pa\n",
              triangleLid ? "triangle" : "plane", sig[0], -force / area, -force * (xb - xa) / volume);
  EXPECT_NEAR(sig[0], -force / area, 1e-12 * force / area);
  for (std::size_t k = 1; k < 9; ++k) EXPECT_NEAR(sig[k], 0.0, 1e-12 * force / area) << k;
}

TEST(DemTriangleWalls, LoveWeberStressIncludesPlaneWalls) { checkWallStress(false); }
TEST(DemTriangleWalls, LoveWeberStressIncludesTriangleWalls) { checkWallStress(true); }

}  // namespace
}  // namespace cosim::dem::test
