// The linked-cell Verlet list against brute force, on polydisperse sets.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <set>
#include <utility>

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
