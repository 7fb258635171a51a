#pragma once
// Bonded linear springs between lattice neighbours (Cheng 2022 Sec. 6.2): a
// bond acts in tension and compression, F_i = -k (|d| - d0) d/|d| with
// d = x_i - x_j and d0 its length when created, times the Arlequin weight
// at the bond (mean of the two particle weights). Bonded pairs are excluded
// from the contact law (the neighbour list skips them).
#include <cstdint>
#include <vector>

#include "cosim/dem/particles.hpp"
#include "cosim/dem/periodic_cell.hpp"

namespace cosim::dem {

class BondedSprings {
 public:
  double stiffness = 0.0;  // k [N/m]
  std::vector<std::uint32_t> first, second;  // bond ends, first < second
  std::vector<double> rest;                  // d0 [m]

  std::size_t size() const { return rest.size(); }
  /// Bonds every pair closer than factor (r_i + r_j); returns the number made.
  std::size_t bondNeighbours(const Particles& p, const PeriodicCell& cell, double factor);
  /// Per-particle bond index (both ends); call after the bonds change.
  void index(std::size_t particles);
  /// Adds the bond forces to f (fixed order per particle: deterministic).
  void addForces(const Particles& p, const PeriodicCell& cell, std::vector<Vec3>& f);
  double energy(const Particles& p, const PeriodicCell& cell) const;

  std::vector<std::uint32_t> byParticleStart, byParticle;  // bond ids of each particle
 private:
  Vec3 bondVector(const Particles& p, const PeriodicCell& cell, std::size_t b) const;
  std::vector<Vec3> force_;  // on `first` of each bond
};

}  // namespace cosim::dem
