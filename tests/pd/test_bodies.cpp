// Discretisation, neighbour lists, hybrid surface particles and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <sstream>

#include "cosim/pd/hybrid.hpp"
#include "cosim/util/host_memory.hpp"
#include "pd_test_util.hpp"

namespace cosim::pd {
namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(PdBodies, LatticeShapes) {
  const double h = 1e-3;
  auto box = test::box("b", "pmb", 10, 4, 3, h, 3.0);
  const auto cb = discretise(box);
  EXPECT_EQ(cb.volumes.size(), 120u);
  EXPECT_DOUBLE_EQ(cb.volumes[0], h * h * h);
  BodySpec sphere = box;
  sphere.shape = Shape::Sphere;
  sphere.center = {0, 0, 0};
  sphere.radius = 8 * h;
  const auto cs = discretise(sphere);
  const double vs = 4.0 / 3.0 * std::numbers::pi * std::pow(8 * h, 3);
  EXPECT_NEAR(cs.volumes.size() * h * h * h / vs, 1.0, 0.05);
  BodySpec cyl = box;
  cyl.shape = Shape::Cylinder;
  cyl.center = {0, 0, 0};
  cyl.radius = 6 * h;
  cyl.length = 10 * h;
  cyl.axis = 0;
  const auto cc = discretise(cyl);
  const double vc = std::numbers::pi * 36 * h * h * 10 * h;
  EXPECT_NEAR(cc.volumes.size() * h * h * h / vc, 1.0, 0.05);
  for (std::size_t q = 0; q < cc.volumes.size(); ++q) EXPECT_TRUE(insideShape(cyl, &cc.positions[3 * q], 1e-12));
}

TEST(PdBodies, NeighbourListsAreSymmetricWithPartialVolumes) {
  PdSystem sys;
  sys.addBody(test::box("b", "pmb", 9, 9, 9, 1.0, 3.0));
  sys.finalise();
  const auto& b = sys.bodies()[0].bonds;
  const auto& p = sys.particles();
  for (std::size_t i = 0; i < b.rows(); ++i)
    for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
      const std::size_t j = b.neighbor[k];
      bool found = false;
      for (std::size_t q = b.offset[j]; q < b.offset[j + 1]; ++q) found = found || b.neighbor[q] == i;
      ASSERT_TRUE(found);
      EXPECT_LT(b.length[k], 3.5);
      EXPECT_GT(b.volumeFraction[k], 0.0);
      EXPECT_LE(b.volumeFraction[k], 1.0);
      if (b.length[k] <= 2.5) {
        EXPECT_EQ(b.volumeFraction[k], 1.0);
      }
    }
  // The centre particle (4,4,4) has the complete family: lattice points with |xi| < 3.5.
  std::size_t centre = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.reference[3 * i] == 4.5 && p.reference[3 * i + 1] == 4.5 && p.reference[3 * i + 2] == 4.5) centre = i;
  int expected = 0;
  for (int x = -3; x <= 3; ++x)
    for (int y = -3; y <= 3; ++y)
      for (int z = -3; z <= 3; ++z)
        if ((x || y || z) && std::sqrt(x * x + y * y + z * z) < 3.5) ++expected;
  EXPECT_EQ(b.offset[centre + 1] - b.offset[centre], static_cast<std::size_t>(expected));
}

// The truncated rule (Hartmann's family: every partner within delta) on the
// H2 plate's lattice, whose positions 0.2 + (i - 9.5) 0.02 put 10 of the 18
// axial pairs two spacings apart at 0.04 + 1 ulp: every pair of lattice
// offsets with |d| <= 2 is bonded, prod (n_k - |d_k|) of each offset, and the
// pairs at |xi| = delta carry half their volume.
TEST(PdBodies, TruncatedFamilyKeepsEveryPartnerAtTheHorizon) {
  auto plate = test::box("plate", "lps", 20, 20, 5, 0.02, 2.0);
  plate.options.partialVolume = PartialVolume::Truncated;
  PdSystem sys;
  sys.addBody(plate);
  sys.finalise();
  const auto& b = sys.bodies()[0].bonds;
  const int n[3] = {20, 20, 5};
  std::size_t expected = 0;
  for (int x = -2; x <= 2; ++x)
    for (int y = -2; y <= 2; ++y)
      for (int z = -2; z <= 2; ++z) {
        if ((x == 0 && y == 0 && z == 0) || x * x + y * y + z * z > 4) continue;
        expected += static_cast<std::size_t>((n[0] - std::abs(x)) * (n[1] - std::abs(y)) * (n[2] - std::abs(z)));
      }
  EXPECT_EQ(expected, 51332u);
  EXPECT_EQ(b.count(), expected);
  std::size_t atHorizon = 0;
  for (std::size_t k = 0; k < b.count(); ++k) {
    if (std::abs(b.length[k] - 0.04) > 1e-12) continue;
    ++atHorizon;
    EXPECT_NEAR(b.volumeFraction[k], 0.5, 1e-9);
  }
  EXPECT_EQ(atHorizon, 2u * (18 * 20 * 5 + 20 * 18 * 5 + 20 * 20 * 3));
}

TEST(PdBodies, HybridSurfaceParticlesQuasiRadiusAndNormals) {
  const double h = 2e-3;
  PdSystem sys;
  sys.addBody(test::box("b", "lps", 6, 5, 4, h, 3.0));
  sys.finalise();
  const auto& p = sys.particles();
  const auto s = surfaceParticles(p, 0, p.size(), h);
  EXPECT_EQ(s.size(), 120u - 4u * 3u * 2u);  // all but the 4 x 3 x 2 core
  for (const auto i : s) {
    bool onFace = false;
    for (int a = 0; a < 3; ++a) {
      const double x = p.reference[3 * i + a] / h;
      const double n = a == 0 ? 6 : (a == 1 ? 5 : 4);
      onFace = onFace || std::abs(x - 0.5) < 1e-9 || std::abs(x - (n - 0.5)) < 1e-9;
    }
    EXPECT_TRUE(onFace);
  }
  // Hartmann Eq. 39 and the paper's example: spacing 1.5 cm gives R = 0.93 cm.
  EXPECT_NEAR(quasiRadius(1.5e-2 * 1.5e-2 * 1.5e-2), 0.93e-2, 0.005e-2);
  // Outward normal of the particle in the middle of the x-min face of a cube.
  PdSystem cube;
  cube.addBody(test::box("c", "lps", 7, 7, 7, h, 3.0));
  cube.finalise();
  const auto& q = cube.particles();
  int checked = 0;
  for (std::size_t i = 0; i < q.size(); ++i)
    if (std::abs(q.reference[3 * i] - 0.5 * h) < 1e-12 && std::abs(q.reference[3 * i + 1] - 3.5 * h) < 1e-12 &&
        std::abs(q.reference[3 * i + 2] - 3.5 * h) < 1e-12) {
      double n[3];
      ASSERT_TRUE(surfaceNormal(q, cube.bodies()[0].bonds, i, n));
      EXPECT_NEAR(n[0], -1.0, 1e-12);
      EXPECT_NEAR(n[1], 0.0, 1e-12);
      EXPECT_NEAR(n[2], 0.0, 1e-12);
      ++checked;
    }
  EXPECT_EQ(checked, 1);
}

TEST(PdBodies, BadInputNamesBodyFileAndLine) {
  auto spec = test::box("slab", "pmb", 4, 4, 4, 1e-3, 3.0);
  spec.spacing = 0.0;
  auto msg = errorOf([&] { PdSystem s; s.addBody(spec); });
  EXPECT_NE(msg.find("body 'slab'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("spacing"), std::string::npos) << msg;
  spec.spacing = 1e-3;
  spec.horizonFactor = -1.0;
  msg = errorOf([&] { PdSystem s; s.addBody(spec); });
  EXPECT_NE(msg.find("body 'slab'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("horizon"), std::string::npos) << msg;
  spec.horizonFactor = 3.0;
  spec.model = "nonesuch";
  msg = errorOf([&] { PdSystem s; s.addBody(spec); });
  EXPECT_NE(msg.find("nonesuch"), std::string::npos) << msg;
  EXPECT_NE(msg.find("lps"), std::string::npos) << msg;  // lists the known models

  // Overlap: a second box starting inside the first; touching boxes are fine.
  auto a = test::box("a", "pmb", 4, 4, 4, 1e-3, 3.0);
  auto b = a;
  b.name = "b";
  b.min = {2e-3, 0, 0};
  b.max = {6e-3, 4e-3, 4e-3};
  msg = errorOf([&] { PdSystem s; s.addBody(a); s.addBody(b); });
  EXPECT_NE(msg.find("body 'b' overlaps body 'a'"), std::string::npos) << msg;
  b.min = {4e-3, 0, 0};
  b.max = {8e-3, 4e-3, 4e-3};
  EXPECT_EQ(errorOf([&] { PdSystem s; s.addBody(a); s.addBody(b); s.finalise(); }), "");

  const auto nanFile = test::tempFile("nan.txt", "# x y z V\n0 0 0 1e-9\n0.001 0 nan 1e-9\n");
  msg = errorOf([&] { readPointFile(nanFile.string()); });
  EXPECT_NE(msg.find(nanFile.string() + ":3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("NaN"), std::string::npos) << msg;
  const auto zeroFile = test::tempFile("zero.txt", "0 0 0 1e-9\n0.001 0 0 0\n");
  msg = errorOf([&] { readPointFile(zeroFile.string()); });
  EXPECT_NE(msg.find(zeroFile.string() + ":2"), std::string::npos) << msg;
  EXPECT_NE(msg.find("volume must be positive"), std::string::npos) << msg;
  const auto badFile = test::tempFile("bad.txt", "0 0 zero 1e-9\n");
  msg = errorOf([&] { readPointFile(badFile.string()); });
  EXPECT_NE(msg.find(":1: 'zero' is not a number"), std::string::npos) << msg;
  const auto twiceFile = test::tempFile("twice.txt", "0 0 0 1e-9\n0.001 0 0 1e-9\n0.002 0 0 1e-9\n0.001 0 0 1e-9\n");
  msg = errorOf([&] { readPointFile(twiceFile.string()); });
  EXPECT_NE(msg.find(twiceFile.string() + ":4: the point repeats line 2"), std::string::npos) << msg;
  BodySpec pts = a;
  pts.name = "cloud";
  pts.shape = Shape::Points;
  pts.pointsFile = zeroFile.string();
  msg = errorOf([&] { PdSystem s; s.addBody(pts); });
  EXPECT_NE(msg.find("body 'cloud'"), std::string::npos) << msg;
}

// Sizes are estimated before discretising: the estimate of a box is its exact
// lattice count; counts that overflow (a box of 1e200 m used to become one
// particle through lround to int) or exceed the index or memory are refused.
TEST(PdBodies, LatticeSizeIsCheckedBeforeAllocating) {
  auto spec = test::box("b", "lps", 10, 4, 3, 1e-3, 3.0);
  EXPECT_EQ(latticeParticleEstimate(spec), static_cast<double>(discretise(spec).volumes.size()));
  std::string key;
  EXPECT_EQ(bodySizeProblem(spec, latticeParticleEstimate(spec), key), "");
  const auto size = estimateBodySize(spec, 1000.0);
  EXPECT_NEAR(size.bonds, 1000.0 * 4.0 / 3.0 * std::numbers::pi * 3.5 * 3.5 * 3.5, 1e-6);
  EXPECT_DOUBLE_EQ(estimateBodySize(spec, 10.0).bonds, 90.0);  // at most every other particle
  EXPECT_GT(util::availableMemoryBytes(), 0.0);

  spec.max[0] = 1e200;
  auto msg = errorOf([&] { discretise(spec); });
  EXPECT_NE(msg.find("body 'b': 'spacing' 0.001 gives about 1.2e+204 particles"), std::string::npos) << msg;
  spec.min[0] = -1e308;
  spec.max[0] = 1e308;
  msg = errorOf([&] { PdSystem s; s.addBody(spec); });
  EXPECT_NE(msg.find("gives about inf particles"), std::string::npos) << msg;
  EXPECT_EQ(bodySizeProblem(spec, latticeParticleEstimate(spec), key).empty(), false);
  EXPECT_EQ(key, "spacing");

  auto wide = test::box("wide", "lps", 10, 10, 10, 1e-3, 3.0);
  wide.horizonFactor = 1e6;
  key.clear();
  EXPECT_NE(bodySizeProblem(wide, 1e6, key), "");  // 1e12 bonds
  EXPECT_EQ(key, "horizon");

  // A small body with a huge horizon factor: its own bonds are few (at most
  // every other particle), but the complete lattice family the models are
  // computed against is not.
  auto rod = test::box("rod", "pmb", 24, 2, 2, 2.5e-3, 8.9e100);
  key.clear();
  msg = bodySizeProblem(rod, latticeParticleEstimate(rod), key);
  EXPECT_NE(msg.find("complete lattice family"), std::string::npos) << msg;
  EXPECT_EQ(key, "horizon");
}

TEST(PdBodies, EveryParticleNeedsAPartner) {
  auto spec = test::box("pair", "lps", 2, 1, 1, 1e-3, 3.0);
  PointCloud one;
  one.positions = {0, 0, 0};
  one.volumes = {1e-9};
  auto msg = errorOf([&] { PdSystem s; s.addBody(spec, one); });
  EXPECT_NE(msg.find("body 'pair': 1 particle at spacing 0.001"), std::string::npos) << msg;
  PointCloud apart;
  apart.positions = {0, 0, 0, 0.01, 0, 0};
  apart.volumes = {1e-9, 1e-9};
  PdSystem s;
  s.addBody(test::box("first", "lps", 3, 3, 3, 1e-3, 3.0));
  s.addBody(spec, apart);
  try {
    s.finalise();
    FAIL() << "a body of two particles ten spacings apart was accepted";
  } catch (const EntryError& e) {
    EXPECT_EQ(e.entry(), EntryError::Entry::Body);
    EXPECT_EQ(e.index(), 1u);
    EXPECT_NE(std::string(e.what()).find("body 'pair': particle 0 at (0, 0, 0) has no partner within the horizon 0.003"),
              std::string::npos) << e.what();
  }
}

TEST(PdBodies, PointCloudBodyMatchesLattice) {
  // The same lattice given as a file behaves like the lattice body.
  std::ostringstream text;
  const double h = 1e-3;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      for (int k = 0; k < 6; ++k) text << (i + 0.5) * h << ' ' << (j + 0.5) * h << ' ' << (k + 0.5) * h << ' ' << h * h * h << '\n';
  const auto file = test::tempFile("cloud.txt", text.str());
  auto spec = test::box("cloud", "lps", 6, 6, 6, h, 3.0);
  spec.shape = Shape::Points;
  spec.pointsFile = file.string();
  spec.spacing = 0.0;  // from the mean volume
  PdSystem a, b;
  a.addBody(spec);
  a.finalise();
  b.addBody(test::box("lattice", "lps", 6, 6, 6, h, 3.0));
  b.finalise();
  EXPECT_NEAR(a.bodies()[0].spacing / h, 1.0, 1e-12);
  EXPECT_EQ(a.bodies()[0].bonds.count(), b.bodies()[0].bonds.count());
}

TEST(PdBodies, SeveralBodiesKeepTheirOwnMaterialAndHorizon) {
  PdSystem sys;
  auto a = test::box("soft", "lps", 4, 4, 4, 1e-3, 3.0, 0.3);
  auto b = test::box("hard", "pmb", 4, 4, 4, 0.5e-3, 2.0);
  b.min = {10e-3, 0, 0};
  b.max = {12e-3, 2e-3, 2e-3};
  b.material.youngsModulus = 100e9;
  sys.addBody(a);
  sys.addBody(b);
  sys.finalise();
  EXPECT_DOUBLE_EQ(sys.bodies()[0].horizon, 3e-3);
  EXPECT_DOUBLE_EQ(sys.bodies()[1].horizon, 1e-3);
  // No bond crosses bodies.
  for (const auto& body : sys.bodies())
    for (const auto j : body.bonds.neighbor) {
      EXPECT_GE(j, body.begin);
      EXPECT_LT(j, body.end);
    }
  // The stiffer body with the smaller horizon sets the critical step
  // (0.45 delta / c_p, after Eqs. 41-42).
  EXPECT_DOUBLE_EQ(sys.criticalTimeStep(), 0.45 * 1e-3 / b.material.cflWaveSpeed());
}

TEST(PdBoundary, FixedVelocityAndNormalOnlyConstraints) {
  const double h = 1e-3;
  PdSystem sys;
  auto spec = test::box("b", "lps", 8, 8, 8, h, 3.0);
  spec.initialVelocity = {1.0, 2.0, 0.0};
  sys.addBody(spec);
  BoundaryCondition normal;  // the x-min face may slide in y and z only
  normal.where.hasBox = true;
  normal.where.min = {-1, 2 * h, 2 * h};
  normal.where.max = {0.6 * h, 6 * h, 6 * h};
  normal.type = Constraint::NormalOnly;
  sys.addBoundaryCondition(normal);
  BoundaryCondition driven;
  driven.where.hasBox = true;
  driven.where.min = {7 * h, -1, -1};
  driven.where.max = {1, 1, 1};
  driven.type = Constraint::Velocity;
  driven.velocity = {0.0, 0.0, -3.0};
  sys.addBoundaryCondition(driven);
  BoundaryCondition fixed;
  fixed.where.hasBox = true;
  fixed.where.min = {3 * h, 7 * h, -1};
  fixed.where.max = {5 * h, 1, 1};
  fixed.type = Constraint::Fixed;
  sys.addBoundaryCondition(fixed);
  sys.finalise();
  for (int s = 0; s < 5; ++s) sys.step(0.25 * sys.criticalTimeStep());
  const auto& p = sys.particles();
  const auto& bcs = sys.boundaryConditions();
  ASSERT_EQ(bcs[0].particles.size(), 16u);  // 4 x 4 face particles, all with a normal
  for (std::size_t q = 0; q < bcs[0].particles.size(); ++q) {
    const auto i = bcs[0].particles[q];
    EXPECT_NEAR(bcs[0].normals[3 * q], -1.0, 0.2);  // outward, roughly -x
    const double* n = &bcs[0].normals[3 * q];
    EXPECT_NEAR(p.velocity[3 * i] * n[0] + p.velocity[3 * i + 1] * n[1] + p.velocity[3 * i + 2] * n[2], 0.0, 1e-12);
    EXPECT_GT(std::abs(p.velocity[3 * i + 1]), 0.5);  // tangential motion kept
  }
  for (const auto i : bcs[1].particles) {
    EXPECT_EQ(p.velocity[3 * i + 2], -3.0);
    EXPECT_EQ(p.velocity[3 * i], 0.0);
  }
  for (const auto i : bcs[2].particles)
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(p.velocity[3 * i + a], 0.0);
      EXPECT_EQ(p.displacement[3 * i + a], 0.0);
    }
}

}  // namespace
}  // namespace cosim::pd
