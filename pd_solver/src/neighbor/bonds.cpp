// Fixed neighbour lists (CSR) by binning reference positions into cells of
// edge delta + h/2, so only the 27 surrounding cells are searched.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <unordered_map>

#include "cosim/pd/bonds.hpp"

namespace cosim::pd {

Bonds buildBonds(const Particles& p, std::size_t begin, std::size_t end, double horizon,
                 double spacing, PartialVolume rule, const std::function<void(std::size_t)>& counted) {
  auto partialVolume = [rule](double r, double delta, double h) { return partialVolumeFraction(r, delta, h, rule); };
  Bonds bonds;
  bonds.begin = begin;
  const std::size_t n = end - begin;
  const double reach = horizon + 0.5 * spacing;
  double lo[3] = {1e300, 1e300, 1e300};
  for (std::size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p.reference[3 * i + k]);
  // Clamped, so that the cast stays defined for a cloud spread over more
  // cells than a long counts: its outermost particles share the last cell,
  // where every pair is still tested by its distance.
  auto cellOf = [&](std::size_t i, int k) {
    constexpr double kMaxCell = 1099511627776.0;  // 2^40
    return static_cast<long>(std::min(std::floor((p.reference[3 * i + k] - lo[k]) / reach), kMaxCell));
  };
  auto key = [](long a, long b, long c) {
    return (static_cast<unsigned long long>(a) << 42) ^ (static_cast<unsigned long long>(b) << 21) ^
           static_cast<unsigned long long>(c);
  };
  std::unordered_map<unsigned long long, std::vector<std::uint32_t>> cells;
  for (std::size_t i = begin; i < end; ++i)
    cells[key(cellOf(i, 0), cellOf(i, 1), cellOf(i, 2))].push_back(static_cast<std::uint32_t>(i));

  auto distance = [&p](std::size_t i, std::size_t j) {
    double r2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double dx = p.reference[3 * j + k] - p.reference[3 * i + k];
      r2 += dx * dx;
    }
    return std::sqrt(r2);
  };
  // Calls use(j) for every partner j of particle i; allocates nothing, so
  // nothing can throw inside the OpenMP regions below.
  auto forPartners = [&](std::size_t i, auto&& use) {
    const long c[3] = {cellOf(i, 0), cellOf(i, 1), cellOf(i, 2)};
    unsigned long long seen[27];  // keys of more than 2^21 cells a side can repeat
    int nSeen = 0;
    for (long a = c[0] - 1; a <= c[0] + 1; ++a)
      for (long b = c[1] - 1; b <= c[1] + 1; ++b)
        for (long d = c[2] - 1; d <= c[2] + 1; ++d) {
          if (a < 0 || b < 0 || d < 0) continue;
          const auto k = key(a, b, d);
          if (std::find(seen, seen + nSeen, k) != seen + nSeen) continue;
          seen[nSeen++] = k;
          const auto it = cells.find(k);
          if (it == cells.end()) continue;
          for (const std::uint32_t j : it->second)
            if (j != i && partialVolume(distance(i, j), horizon, spacing) > 0.0) use(j);
        }
  };
  const bool parallel = n > static_cast<std::size_t>(kOmpMinParticles);
  // Two passes: count each row, allocate the CSR arrays (outside any parallel
  // region, so a failed allocation is an ordinary exception), then fill.
  bonds.offset.assign(n + 1, 0);
#pragma omp parallel for schedule(dynamic, 64) if (parallel)
  for (std::size_t i = begin; i < end; ++i) {
    std::size_t count = 0;
    forPartners(i, [&count](std::uint32_t) { ++count; });
    bonds.offset[i - begin + 1] = count;
  }
  for (std::size_t i = 0; i < n; ++i) bonds.offset[i + 1] += bonds.offset[i];
  const std::size_t total = bonds.offset[n];
  if (counted) counted(total);
  bonds.neighbor.resize(total);
  bonds.length.resize(total);
  bonds.volumeFraction.resize(total);
  bonds.broken.assign(total, 0);
#pragma omp parallel for schedule(dynamic, 64) if (parallel)
  for (std::size_t i = begin; i < end; ++i) {
    const std::size_t first = bonds.offset[i - begin], last = bonds.offset[i - begin + 1];
    std::size_t b = first;
    forPartners(i, [&](std::uint32_t j) { bonds.neighbor[b++] = j; });
    // Sorted rows make the summation order, and so the result, independent of
    // the hash map's iteration order.
    std::sort(bonds.neighbor.begin() + static_cast<std::ptrdiff_t>(first),
              bonds.neighbor.begin() + static_cast<std::ptrdiff_t>(last));
    for (b = first; b < last; ++b) {
      bonds.length[b] = distance(i, bonds.neighbor[b]);
      bonds.volumeFraction[b] = partialVolume(bonds.length[b], horizon, spacing);
    }
  }
  return bonds;
}

}  // namespace cosim::pd
