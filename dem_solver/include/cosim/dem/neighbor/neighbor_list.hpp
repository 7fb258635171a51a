#pragma once
// Linked-cell neighbour search with a Verlet skin. A half list in compressed
// rows: row i holds partners j > i whose surfaces are closer than the skin at
// build time (r_i + r_j + skin, so correct for any size distribution). Where
// the radii spread over more than a factor 2 (a few large spheres among many
// small ones: DEM spheres among hybrid PD particles), the largest tenth gets a
// grid of its own, so the small particles' cells are sized by their own radii
// and the search stays O(N) whatever the size ratio. A
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
  /// Whether the list is built for n particles (if not, it needs a build).
  bool builtFor(std::size_t n) const { return xRef.size() == n && rowStart.size() == n + 1; }
  /// (skin/2)^2: outside a periodic cell, a particle farther than skin/2 from
  /// its position at the build calls for a rebuild (two may approach by skin).
  double driftLimit2() const { return 0.25 * skin * skin; }
  /// Rebuilds the list; contact history of pairs still listed is kept. With a
  /// periodic cell, positions must lie in the cell; each pair stores the
  /// image shift n of its partner (partner at x_j + H n).
  void build(const Particles& p, const PeriodicCell* cell = nullptr);
  std::size_t pairs() const { return partner.size(); }
  std::uint64_t builds = 0;
  /// Particles that may lie within their radius + skin of the box [lo, hi]:
  /// those binned (at the last build) in cells overlapping the box grown by
  /// the largest radius of their grid and the skin (Cheng 2022 Alg. 2: finite
  /// walls registered in the grid by bounding box). Open (non-periodic) lists only.
  void particlesNearBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out) const;

  std::vector<std::uint32_t> rowStart;  // n + 1
  std::vector<std::uint32_t> partner;   // j of each pair
  std::vector<Vec3> shear;              // tangential history per pair
  std::vector<std::uint8_t> touching;   // 1 while in contact
  std::vector<std::uint32_t> revStart;  // n + 1
  std::vector<std::uint32_t> revPair;   // pair indices where the particle is j
  std::vector<std::uint32_t> pairRow;   // row i of each pair, so the pair loop can run over pairs
  /// Derives the transposed index and pairRow from rowStart and partner (done
  /// by build(); a restored checkpoint calls it).
  void indexPairs(std::size_t n);
  std::vector<Vec3> xRef;               // positions at the last build (fractional when periodic)
  std::vector<std::array<std::int8_t, 3>> image;  // partner image per pair (periodic only)
  Mat3 hRef{};                          // cell at the last build (periodic only)
  // Pairs never listed (bonded pairs; hybrid PD particles of one body closer
  // than the horizon): per particle i, sorted partners j > i. Empty = none.
  std::vector<std::uint32_t> exclStart, exclPartner;
  void setExclusions(std::size_t n, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs);

 private:
  /// One linked-cell grid: its members counted into cells.
  struct CellGrid {
    Vec3 lo;            // corner of cell (0, 0, 0) (open grids)
    double cell = 1.0;  // cell width (open grids)
    double rmax = 0.0;  // largest radius binned here
    int dims[3] = {1, 1, 1};
    std::vector<std::uint32_t> start, items;  // members of cell c: items[start[c] .. start[c + 1])
    std::size_t cells() const {
      return static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]) * static_cast<std::size_t>(dims[2]);
    }
    std::size_t index(int x, int y, int z) const {
      return static_cast<std::size_t>(x) +
             static_cast<std::size_t>(dims[0]) * (static_cast<std::size_t>(y) + static_cast<std::size_t>(dims[1]) * z);
    }
    /// Counting sort: members[k] lies in cell cellOf[k].
    void fill(const std::vector<std::uint32_t>& members, const std::vector<std::uint32_t>& cellOf);
    /// Calls visit(first, last) with the members of each cell overlapping the box [a, b].
    template <class Visit>
    void forCellsOverlapping(const Vec3& a, const Vec3& b, Visit&& visit) const;
  };

  void binOpen(const Particles& p);
  void binOpenGrid(CellGrid& g, const Particles& p, const std::vector<std::uint32_t>& members, const Vec3& lo,
                   const Vec3& hi);
  template <class Visit>
  void forCandidates(const Particles& p, std::size_t i, Visit&& visit) const;
  template <class Visit>
  void forPeriodicCandidates(const Particles& p, const PeriodicCell& cell, std::size_t i, Visit&& visit) const;
  template <class Candidates>
  void buildRows(const Particles& p, Candidates&& candidates, bool periodic);
  void binPeriodic(const Particles& p, const PeriodicCell& cell, double size);
  std::vector<Vec3> frac_;  // fractional coordinates at build (periodic)
  /// The rows of one block of particles as a build finds them (kept between
  /// builds for their capacity).
  struct RowBlock {
    std::vector<std::uint32_t> partner;
    std::vector<std::array<std::int8_t, 3>> image;
  };
  std::vector<RowBlock> blocks_;
  CellGrid open_[2];        // open lists: small radii, and the largest tenth where split (else empty)
  CellGrid periodic_;       // periodic lists: one grid in fractional coordinates
  std::vector<std::uint32_t> cellOf_;  // each particle's cell in periodic_
};

}  // namespace cosim::dem
