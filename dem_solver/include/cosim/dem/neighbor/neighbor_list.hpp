#pragma once
// Linked-cell neighbour search with a Verlet skin. A half list in compressed
// rows: row i holds partners j > i whose surfaces are closer than the skin at
// build time (r_i + r_j + skin, so correct for any size distribution). A
// transposed index lets each particle gather the pair forces it receives
// without atomics, in a fixed order (results do not depend on thread count).
// Per-pair contact history travels with the pair across rebuilds.
#include <cstdint>
#include <utility>
#include <vector>

#include "cosim/dem/particles.hpp"
#include "cosim/dem/periodic_cell.hpp"

namespace cosim::dem {

/// The Verlet skin when none is given: a fifth of the smallest radius.
constexpr double kDefaultSkinPerRadius = 0.2;

class NeighborList {
 public:
  double skin = 0.0;
  /// True when some particle moved more than skin/2 since the last build
  /// (in a periodic cell: fluctuation plus the cell's deformation since then).
  bool needsRebuild(const Particles& p, const PeriodicCell* cell = nullptr) const;
  /// Rebuilds the list; contact history of pairs still listed is kept. With a
  /// periodic cell, positions must lie in the cell; each pair stores the
  /// image shift n of its partner (partner at x_j + H n).
  void build(const Particles& p, const PeriodicCell* cell = nullptr);
  std::size_t pairs() const { return partner.size(); }
  std::uint64_t builds = 0;
  /// Particles binned (at the last build) in cells overlapping the box [lo, hi]
  /// (Cheng 2022 Alg. 2: finite walls registered in the grid by bounding box).
  void particlesInBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out) const;

  std::vector<std::uint32_t> rowStart;  // n + 1
  std::vector<std::uint32_t> partner;   // j of each pair
  std::vector<Vec3> shear;              // tangential history per pair
  std::vector<std::uint8_t> touching;   // 1 while in contact
  std::vector<std::uint32_t> revStart;  // n + 1
  std::vector<std::uint32_t> revPair;   // pair indices where the particle is j
  std::vector<Vec3> xRef;               // positions at the last build (fractional when periodic)
  std::vector<std::array<std::int8_t, 3>> image;  // partner image per pair (periodic only)
  Mat3 hRef{};                          // cell at the last build (periodic only)
  // Pairs never listed (bonded pairs; hybrid PD particles of one body closer
  // than the horizon): per particle i, sorted partners j > i. Empty = none.
  std::vector<std::uint32_t> exclStart, exclPartner;
  void setExclusions(std::size_t n, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs);

 private:
  void binParticles(const Particles& p, double cell);
  /// Turns the per-cell counts in cellStart_ (and cellOf_) into cellItems_.
  void sortIntoCells(std::size_t n, std::size_t ncell);
  template <class Visit>
  void forCandidates(const Particles& p, std::size_t i, Visit&& visit) const;
  template <class Visit>
  void forPeriodicCandidates(const Particles& p, const PeriodicCell& cell, std::size_t i, Visit&& visit) const;
  template <class Candidates>
  void buildRows(const Particles& p, Candidates&& candidates, bool periodic);
  void binPeriodic(const Particles& p, const PeriodicCell& cell, double size);
  std::vector<Vec3> frac_;  // fractional coordinates at build (periodic)
  Vec3 lo_;
  int dims_[3] = {1, 1, 1};
  double cell_ = 1.0;
  std::vector<std::uint32_t> cellStart_, cellItems_, cellOf_;
};

}  // namespace cosim::dem
