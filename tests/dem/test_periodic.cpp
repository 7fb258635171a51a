// Periodic and deformable periodic cells: an affinely deformed lattice gives
// the analytic Love-Weber stress; a random packing under pure shear gives a
// symmetric stress; the neighbour list matches brute force over images.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cosim/dem/packing/packing.hpp"
#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

constexpr double kR = 0.01, kK = 1e5;

// Simple cubic lattice of n^3 spheres, spacing a (overlap 2r - a with each
// of its 6 neighbours), filling a periodic cube.
DemSystem lattice(int n, double a) {
  DemSystem s;
  s.setContactLaw("linear", "none", "none");
  Material m = glass();
  m.kn = kK;
  s.materials.add(m);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) s.particles.add({(i + 0.5) * a, (j + 0.5) * a, (k + 0.5) * a}, kR, m.density);
  s.cell.enabled = true;
  s.cell.h = {n * a, 0, 0, 0, n * a, 0, 0, 0, n * a};
  s.neighbors.skin = 0.01 * kR;
  s.initialize();
  return s;
}

// Analytic stress of the deformed lattice: per particle the three bonds are
// d_a = H e_a / n, each carrying k (2r - |d_a|) along d_a (tension positive).
std::array<double, 9> latticeStress(const Mat3& h, int n) {
  std::array<double, 9> sig{};
  const double vp = det(h) / (n * n * n);
  for (int a = 0; a < 3; ++a) {
    const Vec3 d = (1.0 / n) * column(h, a);
    const double len = norm(d), overlap = 2 * kR - len;
    if (overlap <= 0) continue;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) sig[static_cast<std::size_t>(3 * r + c)] -= kK * overlap * d[r] * d[c] / len / vp;
  }
  return sig;
}

TEST(DemPeriodic, AffinelyDeformedLatticeGivesAnalyticStress) {
  struct Case { const char* name; Mat3 L; };
  const std::vector<Case> cases{
      {"triaxial stretch", {0.5, 0, 0, 0, -0.3, 0, 0, 0, 0.2}},
      {"simple shear (Lees-Edwards)", {0, 2.0, 0, 0, 0, 0, 0, 0, 0}},
      {"pure shear", {1.0, 0, 0, 0, -1.0, 0, 0, 0, 0}},
      {"general", {0.3, 0.8, -0.2, 0.1, -0.4, 0.5, 0.0, 0.3, 0.2}},
  };
  for (const Case& c : cases) {
    DemSystem s = lattice(4, 2 * kR - 1e-4);
    s.cell.velocityGradient = c.L;
    const double dt = 1e-5;
    for (int step = 0; step < 1000; ++step) s.advance(dt);  // strain about 1e-2
    // The lattice stays affine: every particle is in equilibrium by symmetry.
    double fmax = 0.0;
    for (const Vec3& f : s.particles.f) fmax = std::max(fmax, norm(f));
    const auto sig = loveWeberStress(s, s.cell.volume());
    const auto ref = latticeStress(s.cell.h, 4);
    double err = 0.0, scale = 0.0;
    for (std::size_t k = 0; k < 9; ++k) {
      err = std::max(err, std::fabs(sig[k] - ref[k]));
      scale = std::max(scale, std::fabs(ref[k]));
    }
    std::printf("%-28s: sigma_xx %.6e sigma_xy %.6e (analytic %.6e, %.6e), max rel. error %.2e, %llu rebuilds, "
                "max |f| %.1e N\n",
                c.name, sig[0], sig[1], ref[0], ref[1], err / scale,
                static_cast<unsigned long long>(s.neighbors.builds), fmax);
    EXPECT_LT(err / scale, 1e-9) << c.name;
    EXPECT_GT(s.neighbors.builds, 1u) << c.name;  // rebuilt (and wrapped) while deforming
  }
}

// Builds the list of p in the cell h and checks it against brute force over
// the 27 neighbouring images; returns the number of pairs.
std::size_t checkAgainstBruteForce(const Particles& p, const Mat3& h, double skin) {
  PeriodicCell cell;
  cell.enabled = true;
  cell.h = h;
  NeighborList nl;
  nl.skin = skin;
  nl.build(p, &cell);
  std::size_t brute = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      // Nearest image by search over the 27 neighbouring images.
      double best = 1e300;
      for (int a = -1; a <= 1; ++a)
        for (int b = -1; b <= 1; ++b)
          for (int c = -1; c <= 1; ++c)
            best = std::min(best, norm(p.x[i] - p.x[j] - mul(h, Vec3{double(a), double(b), double(c)})));
      const double cut = p.radius[i] + p.radius[j] + nl.skin;
      if (best < cut) {
        ++brute;
        bool found = false;
        for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k)
          if (nl.partner[k] == j) {
            found = true;
            EXPECT_NEAR(norm(p.x[i] - p.x[j] - cell.shift(nl.image[k])), best, 1e-15);
          }
        EXPECT_TRUE(found) << i << " " << j;
      }
    }
  EXPECT_EQ(nl.pairs(), brute);
  return brute;
}

TEST(DemPeriodic, NeighbourListMatchesBruteForceOverImages) {
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Particles p;
  const Mat3 h{0.2, 0.05, 0.0, 0.0, 0.18, 0.03, 0.01, 0.0, 0.22};  // triclinic
  for (int i = 0; i < 1500; ++i) p.add(mul(h, Vec3{u(rng), u(rng), u(rng)}), 0.003 + 0.006 * u(rng), 1000);
  const std::size_t pairs = checkAgainstBruteForce(p, h, 0.002);
  std::printf("triclinic periodic cell: %zu pairs listed and by brute force over images\n", pairs);
}

TEST(DemPeriodic, AWideCellGetsACappedGridWithTheSamePairs) {
  // 300 small spheres in 6 clusters 5 cm across, some straddling a face: a grid
  // of cut-off cells would have 10^6 cells in the 3 m cell, 10^9 in the 30 m
  // one, and more than memory holds in the 1e6 m one.
  for (const double side : {3.0, 30.0, 1e6}) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const Mat3 h{side, 0.1 * side, 0.0, 0.0, side, 0.0, 0.0, 0.0, side};  // sheared
    const double edge = 1.0 - 0.025 / side;                                 // a cluster there straddles the face
    Particles p;
    for (int c = 0; c < 6; ++c) {
      const Vec3 centre{c % 2 ? edge : u(rng), c % 3 ? u(rng) : edge, u(rng)};
      for (int i = 0; i < 50; ++i) {
        Vec3 f = centre + (0.05 / side) * Vec3{u(rng), u(rng), u(rng)};
        for (int d = 0; d < 3; ++d) f[d] -= std::floor(f[d]);
        p.add(mul(h, f), 0.003 + 0.006 * u(rng), 1000);
      }
    }
    EXPECT_GT(checkAgainstBruteForce(p, h, 0.002), 100u) << side;
  }
}

TEST(DemPeriodic, RandomPackingUnderPureShearHasSymmetricStress) {
  DemSystem s;
  s.setContactLaw("hertz", "mindlin", "restitution");
  Material m = glass(0.3, 0.5);
  m.young = 1e8;
  s.materials.add(m);
  const double box = 0.02;
  const SphereSet set = randomPacking({0, 0, 0}, {box, box, box}, 0.0012, 0.0018, 400, 21);
  for (std::size_t i = 0; i < set.radii.size(); ++i) s.particles.add(set.centres[i], set.radii[i], m.density);
  s.cell.enabled = true;
  s.cell.h = {box, 0, 0, 0, box, 0, 0, 0, box};
  s.neighbors.skin = 2e-4;
  s.massDamping = 200.0;  // dynamic relaxation (Liu 2016 Sec. 2.3.2)
  s.initialize();
  const double dt = 5e-6;
  auto pressure = [&s] {
    const auto sig = loveWeberStress(s, s.cell.volume());
    return -(sig[0] + sig[4] + sig[8]) / 3.0;
  };
  // Isotropic compression in increments, each relaxed (Liu 2016 Sec. 2.3.2),
  // until the relaxed packing is jammed and carries 2 kPa.
  int steps = 0;
  long relax1 = 0;
  while (steps < 60000) {
    s.cell.velocityGradient = {-5.0, 0, 0, 0, -5.0, 0, 0, 0, -5.0};
    for (int k = 0; k < 200; ++k) s.advance(dt);
    steps += 200;
    s.cell.velocityGradient = {};
    relax1 += relax(s, dt, 1e-2, 2000);
    if (pressure() > 2e3 && coordinationNumber(s) > 4.0) break;
  }
  ASSERT_GT(pressure(), 2e3) << "packing did not jam";
  relax1 += relax(s, dt, 1e-3, 50000);
  // Pure shear strain of 1 %, then relax again.
  s.cell.velocityGradient = {1.0, 0, 0, 0, -1.0, 0, 0, 0, 0};
  for (int k = 0; k < 2000; ++k) s.advance(dt);
  s.cell.velocityGradient = {};
  const long relax2 = relax(s, dt, 1e-3, 50000);
  const auto sig = loveWeberStress(s, s.cell.volume());
  double scale = 0.0;
  for (double v : sig) scale = std::max(scale, std::fabs(v));
  double asym = 0.0;
  for (int r = 0; r < 3; ++r)
    for (int c = r + 1; c < 3; ++c)
      asym = std::max(asym, std::fabs(sig[static_cast<std::size_t>(3 * r + c)] - sig[static_cast<std::size_t>(3 * c + r)]));
  std::printf("random packing, %zu spheres: jammed after %d steps, relaxed in %ld + %ld steps, I_uf %.2e, Z = %.2f, "
              "sigma diag [%.4e %.4e %.4e] Pa, max |sigma_ij - sigma_ji| / max |sigma| = %.2e\n",
              s.particles.size(), steps, relax1, relax2, unbalancedForceIndex(s), coordinationNumber(s), sig[0],
              sig[4], sig[8], asym / scale);
  EXPECT_LT(unbalancedForceIndex(s), 1e-3);
  EXPECT_GT(coordinationNumber(s), 3.5);
  EXPECT_GT(pressure(), 1e3);
  EXPECT_LT(sig[0] + sig[4] + sig[8], 0.0);  // compressive
  EXPECT_GT(sig[0], sig[4]);                 // x was stretched, y compressed
  EXPECT_LT(asym / scale, 1e-3);
}

}  // namespace
}  // namespace cosim::dem::test
