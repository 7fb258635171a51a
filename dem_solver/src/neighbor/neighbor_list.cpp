#include "cosim/dem/parallel.hpp"
#include "cosim/dem/neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace cosim::dem {

bool NeighborList::needsRebuild(const Particles& p, const PeriodicCell* cell) const {
  const std::size_t n = p.size();
  if (!builtFor(n)) return true;
  if (cell && cell->enabled) {
    // Affine motion does not change fractional coordinates; the fluctuation is
    // H (s - s_ref), and the deformation since the build changes a pair
    // distance by at most |H H_ref^-1 - I| times the cut-off.
    const Mat3 f = mul(cell->h, inverse(hRef));
    double strain = 0.0;
    for (int k = 0; k < 9; ++k) strain += (f[static_cast<std::size_t>(k)] - (k % 4 == 0 ? 1.0 : 0.0)) *
                                          (f[static_cast<std::size_t>(k)] - (k % 4 == 0 ? 1.0 : 0.0));
    double rmax = 0.0;
    for (double r : p.radius) rmax = std::max(rmax, r);
    // A pair may approach by |du_i| + |du_j| + |F - I| d <= skin: each particle gets half of what is left.
    const double budget = skin - std::sqrt(strain) * (2.0 * rmax + skin);
    if (budget <= 0.0) return true;
    bool rebuild = false;
#pragma omp parallel for schedule(static) reduction(|| : rebuild) if (n > kParallelMin)
    for (std::size_t i = 0; i < n; ++i)
      if (norm2(p.x[i] - mul(cell->h, xRef[i])) > 0.25 * budget * budget)
        rebuild = true;
    return rebuild;
  }
  const double limit = driftLimit2();
  bool rebuild = false;
#pragma omp parallel for schedule(static) reduction(|| : rebuild) if (n > kParallelMin)
  for (std::size_t i = 0; i < n; ++i)
    if (norm2(p.x[i] - xRef[i]) > limit) rebuild = true;
  return rebuild;
}

namespace {
// Grows the cell size until the grid (cellsAt(size) cells) holds at most about
// 2N cells, so a sparse, wide cloud or a large periodic cell cannot exhaust
// memory. Counted in double: a runaway particle (an unstable coupled run) or a
// huge cell must not overflow the int cell index.
template <class CellsAt>
double cappedCellSize(double size, std::size_t n, CellsAt&& cellsAt) {
  const double cap = static_cast<double>(2 * n + 64);
  for (double total = cellsAt(size); total > cap; total = cellsAt(size)) size *= total > 1e12 ? std::cbrt(total / cap) : 1.26;
  return size;
}

std::string unbinnableMessage(const Particles& p) {
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(p.x[i][d]))
        return "particle " + std::to_string(p.id[i]) + ": non-finite " + static_cast<char>('x' + d) +
               " coordinate, cannot bin it";
  int d = 0;  // the axis whose extent overflows
  std::size_t lo = 0, hi = 0;
  for (int a = 0; a < 3; ++a) {
    std::size_t l = 0, h = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      if (p.x[i][a] < p.x[l][a]) l = i;
      if (p.x[i][a] > p.x[h][a]) h = i;
    }
    if (!std::isfinite(p.x[h][a] - p.x[l][a])) d = a, lo = l, hi = h;
  }
  const char axis = static_cast<char>('x' + d);
  std::ostringstream s;
  s << "particles " << p.id[lo] << " and " << p.id[hi] << " lie at " << axis << " = " << p.x[lo][d] << " and "
    << p.x[hi][d] << " m: an extent no neighbour grid can hold";
  return s.str();
}
}  // namespace

namespace {
// Radii spread over more than a factor 2: the largest tenth (above the 90th
// percentile) get a grid of their own. Returns the largest radius of the small
// grid (every radius when there is no split).
double splitRadius(const std::vector<double>& radius) {
  double rmax = 0.0;
  for (double r : radius) rmax = std::max(rmax, r);
  if (radius.size() < 16) return rmax;
  std::vector<double> sorted(radius);
  const auto q = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() * 9 / 10);
  std::nth_element(sorted.begin(), q, sorted.end());
  return rmax > 2.0 * *q ? *q : rmax;
}
}  // namespace

void NeighborList::CellGrid::fill(const std::vector<std::uint32_t>& members, const std::vector<std::uint32_t>& cellOf) {
  // Counting sort: counts shifted by one, a prefix sum turns them into
  // offsets, then each member goes to its slot (in member order).
  start.assign(cells() + 1, 0);
  for (std::uint32_t c : cellOf) ++start[c + 1];
  for (std::size_t c = 0; c + 1 < start.size(); ++c) start[c + 1] += start[c];
  items.resize(members.size());
  std::vector<std::uint32_t> slot(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < members.size(); ++k) items[slot[cellOf[k]]++] = members[k];
}

template <class Visit>
void NeighborList::CellGrid::forCellsOverlapping(const Vec3& a, const Vec3& b, Visit&& visit) const {
  int from[3], to[3];
  for (int d = 0; d < 3; ++d) {
    // In double first: a box far outside the grid must not overflow the int.
    const double fa = std::floor((a[d] - lo[d]) / cell), fb = std::floor((b[d] - lo[d]) / cell);
    if (!(fb >= 0.0 && fa <= dims[d] - 1)) return;
    from[d] = static_cast<int>(std::max(0.0, fa));
    to[d] = static_cast<int>(std::min(static_cast<double>(dims[d] - 1), fb));
  }
  for (int z = from[2]; z <= to[2]; ++z)
    for (int y = from[1]; y <= to[1]; ++y)
      for (int x = from[0]; x <= to[0]; ++x) {
        const std::size_t c = index(x, y, z);
        visit(items.data() + start[c], items.data() + start[c + 1]);
      }
}

void NeighborList::binOpen(const Particles& p) {
  const std::size_t n = p.size();
  Vec3 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
          std::numeric_limits<double>::max()};
  Vec3 hi = -lo;
  if (n == 0) lo = hi = Vec3{};  // no particles yet (a DEM side of only hybrid PD particles): one empty cell
  bool finite = true;
  for (const Vec3& x : p.x)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], x[d]);
      hi[d] = std::max(hi[d], x[d]);
      finite = finite && std::isfinite(x[d]);
    }
  // A non-finite coordinate has no cell, and an extent that overflows would
  // make the cell count below NaN and its loop endless: stop with the particles.
  if (!finite || !std::isfinite(hi.x - lo.x) || !std::isfinite(hi.y - lo.y) || !std::isfinite(hi.z - lo.z))
    throw std::runtime_error(unbinnableMessage(p));
  const double split = splitRadius(p.radius);
  std::vector<std::uint32_t> members[2];
  for (std::size_t i = 0; i < n; ++i) members[p.radius[i] > split ? 1 : 0].push_back(static_cast<std::uint32_t>(i));
  for (int g = 0; g < 2; ++g) binOpenGrid(open_[g], p, members[g], lo, hi);
}

void NeighborList::binOpenGrid(CellGrid& g, const Particles& p, const std::vector<std::uint32_t>& members,
                               const Vec3& lo, const Vec3& hi) {
  g.rmax = 0.0;
  for (std::uint32_t i : members) g.rmax = std::max(g.rmax, p.radius[i]);
  // Cells at least 2 r_max + skin wide (r_max of this grid): a member's
  // partners in it lie in the cells its reach r_i + skin + r_max overlaps.
  g.cell = cappedCellSize(std::max(2.0 * g.rmax + skin, 1e-300), members.size(), [&](double size) {
    double total = 1.0;
    for (int d = 0; d < 3; ++d) total *= std::floor((hi[d] - lo[d]) / size) + 1.0;
    return total;
  });
  for (int d = 0; d < 3; ++d) g.dims[d] = std::max(1, static_cast<int>(std::floor((hi[d] - lo[d]) / g.cell)) + 1);
  g.lo = lo;
  std::vector<std::uint32_t> cellOf(members.size());
  for (std::size_t k = 0; k < members.size(); ++k) {
    int c[3];
    for (int d = 0; d < 3; ++d)
      c[d] = std::min(g.dims[d] - 1, static_cast<int>((p.x[members[k]][d] - lo[d]) / g.cell));
    cellOf[k] = static_cast<std::uint32_t>(g.index(c[0], c[1], c[2]));
  }
  g.fill(members, cellOf);
}

template <class Visit>
void NeighborList::forCandidates(const Particles& p, std::size_t i, Visit&& visit) const {
  const Vec3 xi = p.x[i];
  const double ri = p.radius[i] + skin;
  for (const CellGrid& g : open_) {
    if (g.items.empty()) continue;
    const double reach = ri + g.rmax;
    g.forCellsOverlapping(xi - Vec3{reach, reach, reach}, xi + Vec3{reach, reach, reach},
                          [&](const std::uint32_t* first, const std::uint32_t* last) {
                            for (; first != last; ++first) {
                              const std::uint32_t j = *first;
                              if (j <= i) continue;
                              const double cut = ri + p.radius[j];
                              if (norm2(xi - p.x[j]) < cut * cut) visit(j);
                            }
                          });
  }
}

void NeighborList::particlesNearBox(const Vec3& lo, const Vec3& hi, std::vector<std::uint32_t>& out) const {
  out.clear();
  for (const CellGrid& g : open_) {
    if (g.items.empty()) continue;
    const double grow = g.rmax + skin;
    g.forCellsOverlapping(lo - Vec3{grow, grow, grow}, hi + Vec3{grow, grow, grow},
                          [&](const std::uint32_t* first, const std::uint32_t* last) { out.insert(out.end(), first, last); });
  }
}

void NeighborList::binPeriodic(const Particles& p, const PeriodicCell& cell, double size) {
  const std::size_t n = p.size();
  const Vec3 w{cell.width(0), cell.width(1), cell.width(2)};
  for (int d = 0; d < 3; ++d)
    if (!(size <= 0.5 * w[d])) {
      std::ostringstream m;
      m << "periodic cell too small: width " << w[d] << " m across face pair " << d
        << " is less than twice the contact cut-off " << size << " m (params.periodic.cell)";
      throw std::invalid_argument(m.str());
    }
  // Cells at least the cut-off wide; fewer (larger) ones in a cell much wider than the particles need.
  size = cappedCellSize(size, n, [&w](double s) {
    return std::max(1.0, std::floor(w.x / s)) * std::max(1.0, std::floor(w.y / s)) * std::max(1.0, std::floor(w.z / s));
  });
  CellGrid& g = periodic_;
  for (int d = 0; d < 3; ++d) g.dims[d] = std::max(1, static_cast<int>(std::floor(w[d] / size)));
  const Mat3 hInv = inverse(cell.h);
  frac_.resize(n);
  cellOf_.resize(n);
  std::vector<std::uint32_t> members(n);
  for (std::size_t i = 0; i < n; ++i) {
    members[i] = static_cast<std::uint32_t>(i);
    frac_[i] = mul(hInv, p.x[i]);
    int c[3];
    for (int d = 0; d < 3; ++d) {
      // Clamped before the cast (a diverged state may be far outside, or NaN: cell 0).
      const double f = std::floor(frac_[i][d] * g.dims[d]);
      c[d] = f >= g.dims[d] - 1.0 ? g.dims[d] - 1 : f > 0.0 ? static_cast<int>(f) : 0;
    }
    cellOf_[i] = static_cast<std::uint32_t>(g.index(c[0], c[1], c[2]));
  }
  g.fill(members, cellOf_);
}

template <class Visit>
void NeighborList::forPeriodicCandidates(const Particles& p, const PeriodicCell& cell, std::size_t i,
                                         Visit&& visit) const {
  const CellGrid& g = periodic_;
  const int* dims = g.dims;
  const std::uint32_t c = cellOf_[i];
  const int cc[3] = {static_cast<int>(c % static_cast<std::uint32_t>(dims[0])),
                     static_cast<int>((c / static_cast<std::uint32_t>(dims[0])) % static_cast<std::uint32_t>(dims[1])),
                     static_cast<int>(c / static_cast<std::uint32_t>(dims[0] * dims[1]))};
  const Vec3 xi = p.x[i];
  const double ri = p.radius[i] + skin;
  // Visit each (cell, image) once: with fewer than 3 cells along an axis the
  // offsets -1, 0, +1 reach the same cell through different images.
  for (int oz = -1; oz <= 1; ++oz)
    for (int oy = -1; oy <= 1; ++oy)
      for (int ox = -1; ox <= 1; ++ox) {
        const int off[3] = {ox, oy, oz};
        int cell3[3];
        std::array<std::int8_t, 3> img{};
        for (int d = 0; d < 3; ++d) {
          int v = cc[d] + off[d];
          img[static_cast<std::size_t>(d)] = static_cast<std::int8_t>(v < 0 ? -1 : (v >= dims[d] ? 1 : 0));
          v -= img[static_cast<std::size_t>(d)] * dims[d];
          cell3[d] = v;
        }
        const Vec3 shift = cell.shift(img);
        const std::size_t idx = g.index(cell3[0], cell3[1], cell3[2]);
        for (std::uint32_t s = g.start[idx]; s < g.start[idx + 1]; ++s) {
          const std::uint32_t j = g.items[s];
          if (j <= i) continue;
          const double cut = ri + p.radius[j];
          if (norm2(xi - p.x[j] - shift) < cut * cut) visit(j, img);
        }
      }
}

void NeighborList::build(const Particles& p, const PeriodicCell* cell) {
  const bool periodic = cell && cell->enabled;
  if (periodic) {
    double rmax = 0.0;
    for (double r : p.radius) rmax = std::max(rmax, r);
    binPeriodic(p, *cell, std::max(2.0 * rmax + skin, 1e-300));
    buildRows(p, [&](std::size_t i, auto&& visit) { forPeriodicCandidates(p, *cell, i, visit); }, true);
    xRef = frac_;
    hRef = cell->h;
  } else {
    binOpen(p);
    buildRows(p, [&](std::size_t i, auto&& visit) {
      forCandidates(p, i, [&](std::uint32_t j) { visit(j, std::array<std::int8_t, 3>{}); });
    }, false);
    xRef = p.x;
  }
  ++builds;
}

void NeighborList::setExclusions(std::size_t n, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs) {
  exclStart.assign(n + 1, 0);
  for (const auto& [a, b] : pairs) ++exclStart[std::min(a, b) + 1];
  for (std::size_t i = 0; i < n; ++i) exclStart[i + 1] += exclStart[i];
  exclPartner.resize(pairs.size());
  std::vector<std::uint32_t> fill(exclStart.begin(), exclStart.end() - 1);
  for (const auto& [a, b] : pairs) exclPartner[fill[std::min(a, b)]++] = std::max(a, b);
  for (std::size_t i = 0; i < n; ++i) std::sort(exclPartner.begin() + exclStart[i], exclPartner.begin() + exclStart[i + 1]);
  rowStart.clear();  // the next step rebuilds
}

template <class Candidates>
void NeighborList::buildRows(const Particles& p, Candidates&& allCandidates, bool periodic) {
  const std::size_t n = p.size();
  const bool excluding = exclStart.size() == n + 1;
  auto candidates = [&](std::size_t i, auto&& visit) {
    allCandidates(i, [&](std::uint32_t j, const std::array<std::int8_t, 3>& im) {
      if (excluding && std::binary_search(exclPartner.begin() + exclStart[i], exclPartner.begin() + exclStart[i + 1], j))
        return;
      visit(j, im);
    });
  };

  // One search per particle: each block of rows collects its partners on its
  // own, and the blocks are copied into place once their sizes are known (a
  // count pass and a fill pass searched every particle's cells twice).
  constexpr std::size_t kBlock = 256;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  blocks_.resize(blocks);
  std::vector<std::uint32_t> start(n + 1, 0);
#pragma omp parallel for schedule(dynamic, 1) if (n > kParallelMin)
  for (std::size_t b = 0; b < blocks; ++b) {
    RowBlock& out = blocks_[b];
    out.partner.clear();
    out.image.clear();
    static thread_local std::vector<std::pair<std::uint32_t, std::array<std::int8_t, 3>>> row;
    for (std::size_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
      row.clear();
      candidates(i, [&](std::uint32_t j, const std::array<std::int8_t, 3>& im) { row.emplace_back(j, im); });
      // Rows are short: sort them (deterministic order independent of cell layout).
      std::sort(row.begin(), row.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
      for (const auto& [j, im] : row) {
        out.partner.push_back(j);
        if (periodic) out.image.push_back(im);
      }
      start[i + 1] = static_cast<std::uint32_t>(row.size());
    }
  }
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> part(start[n]);
  std::vector<Vec3> hist(start[n]);
  std::vector<std::uint8_t> touch(start[n], 0);
  std::vector<std::array<std::int8_t, 3>> img(periodic ? start[n] : 0);
  const bool carry = rowStart.size() == n + 1;
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (std::size_t b = 0; b < blocks; ++b) {
    const RowBlock& in = blocks_[b];
    const std::size_t first = b * kBlock, last = std::min(n, (b + 1) * kBlock);
    std::copy(in.partner.begin(), in.partner.end(), part.begin() + start[first]);
    std::copy(in.image.begin(), in.image.end(), img.begin() + (periodic ? start[first] : 0));
    if (!carry) continue;
    // Each pair's history carried over from the old row.
    for (std::size_t i = first; i < last; ++i) {
      std::uint32_t o = rowStart[i];
      for (std::uint32_t m = start[i]; m < start[i + 1]; ++m) {
        while (o < rowStart[i + 1] && partner[o] < part[m]) ++o;
        if (o < rowStart[i + 1] && partner[o] == part[m]) {
          hist[m] = shear[o];
          touch[m] = touching[o];
        }
      }
    }
  }
  rowStart = std::move(start);
  partner = std::move(part);
  shear = std::move(hist);
  touching = std::move(touch);
  image = std::move(img);
  indexPairs(n);
}

void NeighborList::indexPairs(std::size_t n) {
  revStart.assign(n + 1, 0);
  for (std::uint32_t j : partner) ++revStart[j + 1];
  for (std::size_t i = 0; i < n; ++i) revStart[i + 1] += revStart[i];
  revPair.resize(partner.size());
  pairRow.resize(partner.size());
  std::vector<std::uint32_t> fill(revStart.begin(), revStart.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t k = rowStart[i]; k < rowStart[i + 1]; ++k) {
      revPair[fill[partner[k]]++] = k;
      pairRow[k] = static_cast<std::uint32_t>(i);
    }
}

}  // namespace cosim::dem
