// The linked-cell Verlet list against brute force, on polydisperse sets.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <set>
#include <utility>
#include <vector>

#include "cosim/dem/neighbor/neighbor_list.hpp"

namespace cosim::dem {
namespace {

Particles randomCloud(std::size_t n, double rmin, double rmax, double box, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(0.0, box), rad(rmin, rmax);
  Particles p;
  for (std::size_t i = 0; i < n; ++i) p.add({pos(rng), pos(rng), pos(rng)}, rad(rng), 1000.0);
  return p;
}

std::set<std::pair<std::uint32_t, std::uint32_t>> listed(const NeighborList& nl, std::size_t n) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> s;
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k)
      s.emplace(static_cast<std::uint32_t>(i), nl.partner[k]);
  return s;
}

std::set<std::pair<std::uint32_t, std::uint32_t>> bruteForce(const Particles& p, double skin) {
  std::set<std::pair<std::uint32_t, std::uint32_t>> s;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const double cut = p.radius[i] + p.radius[j] + skin;
      if (norm2(p.x[i] - p.x[j]) < cut * cut) s.emplace(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    }
  return s;
}

TEST(DemNeighbor, EqualsBruteForcePolydisperse) {
  // Size ratios up to 10, dense and sparse clouds, a flat (quasi 2-D) one.
  struct Case { std::size_t n; double rmin, rmax, box; };
  for (const Case c : {Case{3000, 0.01, 0.1, 1.0}, Case{2000, 0.05, 0.06, 2.0}, Case{500, 0.001, 0.2, 5.0}}) {
    const Particles p = randomCloud(c.n, c.rmin, c.rmax, c.box, 42);
    NeighborList nl;
    nl.skin = 0.3 * c.rmin;
    nl.build(p);
    const auto a = listed(nl, p.size());
    const auto b = bruteForce(p, nl.skin);
    std::printf("n=%zu radii [%g, %g]: %zu pairs listed, %zu brute force\n", c.n, c.rmin, c.rmax, a.size(), b.size());
    EXPECT_EQ(a, b);
    // The transposed index lists every pair exactly once under its partner.
    std::size_t rev = 0;
    for (std::size_t j = 0; j < p.size(); ++j)
      for (std::uint32_t r = nl.revStart[j]; r < nl.revStart[j + 1]; ++r) {
        EXPECT_EQ(nl.partner[nl.revPair[r]], j);
        ++rev;
      }
    EXPECT_EQ(rev, a.size());
    // pairRow names the row of every pair (the pair loop runs over pairs).
    ASSERT_EQ(nl.pairRow.size(), nl.pairs());
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) EXPECT_EQ(nl.pairRow[k], i);
  }
}

// A few large spheres among many small ones (DEM spheres among hybrid PD
// particles, size ratio 16 in H5): the largest tenth get a grid of their own,
// and the list must still be exactly the brute-force one, large spheres at the
// cloud's edges and corners included, with and without the skin dwarfing the
// small radii.
TEST(DemNeighbor, AFewLargeSpheresAmongManySmallOnesEqualsBruteForce) {
  for (const double skinPerSmall : {0.2, 3.0}) {
    Particles p = randomCloud(4000, 0.004, 0.006, 1.0, 7);
    const Particles large = randomCloud(24, 0.1, 0.2, 1.0, 8);
    for (std::size_t k = 0; k < large.size(); ++k) p.add(large.x[k], large.radius[k], 1000.0);
    p.add({0.0, 0.0, 0.0}, 0.15, 1000.0);  // corners of the cloud
    p.add({1.0, 1.0, 1.0}, 0.15, 1000.0);
    p.add({0.5, 0.5, 0.5}, 0.005, 1000.0);  // and a small one last
    NeighborList nl;
    nl.skin = skinPerSmall * 0.004;
    nl.build(p);
    const auto a = listed(nl, p.size());
    const auto b = bruteForce(p, nl.skin);
    std::size_t largeSmall = 0;
    for (const auto& [i, j] : b) largeSmall += (p.radius[i] > 0.01) != (p.radius[j] > 0.01);
    std::printf("skin %g: %zu pairs listed, %zu brute force (%zu large-small)\n", nl.skin, a.size(), b.size(), largeSmall);
    EXPECT_GT(largeSmall, 1000u);
    EXPECT_EQ(a, b);
  }
}

// The mesh walls' candidate query (Cheng 2022 Alg. 2) returns every particle
// whose sphere grown by the skin reaches the box, from either size class.
TEST(DemNeighbor, ParticlesNearABoxIncludeEveryOneReachingIt) {
  Particles p = randomCloud(3000, 0.004, 0.006, 1.0, 11);
  const Particles large = randomCloud(20, 0.1, 0.2, 1.0, 12);
  for (std::size_t k = 0; k < large.size(); ++k) p.add(large.x[k], large.radius[k], 1000.0);
  NeighborList nl;
  nl.skin = 0.001;
  nl.build(p);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.1, 1.1), w(0.0, 0.2);
  std::vector<std::uint32_t> found;
  for (int box = 0; box < 50; ++box) {
    const Vec3 lo{u(rng), u(rng), u(rng)};
    const Vec3 hi = lo + Vec3{w(rng), w(rng), 0.0};  // flat, like a triangle's box
    nl.particlesNearBox(lo, hi, found);
    const std::set<std::uint32_t> got(found.begin(), found.end());
    EXPECT_EQ(got.size(), found.size()) << "a particle listed twice";
    std::size_t reaching = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      double d2 = 0.0;  // squared distance from the centre to the box
      for (int d = 0; d < 3; ++d) {
        const double out = std::max({lo[d] - p.x[i][d], 0.0, p.x[i][d] - hi[d]});
        d2 += out * out;
      }
      const double cut = p.radius[i] + nl.skin;
      if (d2 < cut * cut) {
        ++reaching;
        EXPECT_TRUE(got.count(static_cast<std::uint32_t>(i))) << "box " << box << ": particle " << i << " missed";
      }
    }
    if (box == 0) std::printf("box 0: %zu reaching, %zu candidates\n", reaching, found.size());
  }
}

TEST(DemNeighbor, RebuildKeepsHistoryOfSurvivingPairs) {
  Particles p = randomCloud(2000, 0.02, 0.05, 1.0, 7);
  NeighborList nl;
  nl.skin = 0.01;
  nl.build(p);
  // Tag each pair's history with its (i, j).
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k)
      nl.shear[k] = {static_cast<double>(i), static_cast<double>(nl.partner[k]), 1.0};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> step(0.0, 0.01);
  for (auto& x : p.x) x += Vec3{step(rng), step(rng), step(rng)};
  ASSERT_TRUE(nl.needsRebuild(p));
  nl.build(p);
  std::size_t kept = 0, fresh = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) {
      if (nl.shear[k].z == 1.0) {
        EXPECT_EQ(nl.shear[k].x, static_cast<double>(i));
        EXPECT_EQ(nl.shear[k].y, static_cast<double>(nl.partner[k]));
        ++kept;
      } else {
        EXPECT_EQ(norm2(nl.shear[k]), 0.0);
        ++fresh;
      }
    }
  std::printf("after rebuild: %zu pairs kept their history, %zu new\n", kept, fresh);
  EXPECT_GT(kept, 0u);
  EXPECT_GT(fresh, 0u);
  EXPECT_EQ(listed(nl, p.size()), bruteForce(p, nl.skin));
}

TEST(DemNeighbor, AnUnbinnableCloudStopsWithTheParticlesNotAnEndlessLoop) {
  // Two finite positions whose extent overflows to inf, and a NaN coordinate:
  // both once made the cell count NaN and the sizing loop endless.
  Particles wide;
  wide.add({-1.5e308, 0, 0}, 0.001, 1000.0);
  wide.add({1.5e308, 0, 0}, 0.001, 1000.0);
  NeighborList nl;
  nl.skin = 1e-4;
  try {
    nl.build(wide);
    FAIL() << "binned an infinite extent";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("particles 0 and 1 lie at x = "), std::string::npos) << e.what();
  }
  Particles nan = randomCloud(20, 0.001, 0.002, 0.05, 3);
  nan.x[7].z = std::nan("");
  try {
    nl.build(nan);
    FAIL() << "binned a NaN coordinate";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("particle 7: non-finite z coordinate"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::dem
