// Fixed neighbour lists (CSR) by binning reference positions into cells of
// edge delta + h/2, so only the 27 surrounding cells are searched.
#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "cosim/pd/bonds.hpp"

namespace cosim::pd {

Bonds buildBonds(const Particles& p, std::size_t begin, std::size_t end, double horizon,
                 double spacing, PartialVolume rule) {
  auto partialVolume = [rule](double r, double delta, double h) { return partialVolumeFraction(r, delta, h, rule); };
  Bonds bonds;
  bonds.begin = begin;
  const std::size_t n = end - begin;
  const double reach = horizon + 0.5 * spacing;
  double lo[3] = {1e300, 1e300, 1e300};
  for (std::size_t i = begin; i < end; ++i)
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], p.reference[3 * i + k]);
  auto cellOf = [&](std::size_t i, int k) {
    return static_cast<long>(std::floor((p.reference[3 * i + k] - lo[k]) / reach));
  };
  auto key = [](long a, long b, long c) {
    return (static_cast<unsigned long long>(a) << 42) ^ (static_cast<unsigned long long>(b) << 21) ^
           static_cast<unsigned long long>(c);
  };
  std::unordered_map<unsigned long long, std::vector<std::uint32_t>> cells;
  for (std::size_t i = begin; i < end; ++i)
    cells[key(cellOf(i, 0), cellOf(i, 1), cellOf(i, 2))].push_back(static_cast<std::uint32_t>(i));

  bonds.offset.assign(n + 1, 0);
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(n);
#pragma omp parallel for schedule(dynamic, 64) if (end - begin > static_cast<std::size_t>(kOmpMinParticles))
  for (std::size_t i = begin; i < end; ++i) {
    auto& row = rows[i - begin];
    const long c[3] = {cellOf(i, 0), cellOf(i, 1), cellOf(i, 2)};
    for (long a = c[0] - 1; a <= c[0] + 1; ++a)
      for (long b = c[1] - 1; b <= c[1] + 1; ++b)
        for (long d = c[2] - 1; d <= c[2] + 1; ++d) {
          if (a < 0 || b < 0 || d < 0) continue;
          const auto it = cells.find(key(a, b, d));
          if (it == cells.end()) continue;
          for (const std::uint32_t j : it->second) {
            if (j == i) continue;
            double r2 = 0.0;
            for (int k = 0; k < 3; ++k) {
              const double dx = p.reference[3 * j + k] - p.reference[3 * i + k];
              r2 += dx * dx;
            }
            const double r = std::sqrt(r2);
            if (partialVolume(r, horizon, spacing) > 0.0) row.emplace_back(j, r);
          }
        }
    // Sorted rows make the summation order, and so the result, independent of
    // the hash map's iteration order.
    std::sort(row.begin(), row.end());
  }
  for (std::size_t i = 0; i < n; ++i) bonds.offset[i + 1] = bonds.offset[i] + rows[i].size();
  const std::size_t total = bonds.offset[n];
  bonds.neighbor.resize(total);
  bonds.length.resize(total);
  bonds.volumeFraction.resize(total);
  bonds.broken.assign(total, 0);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t b = bonds.offset[i];
    for (const auto& [j, r] : rows[i]) {
      bonds.neighbor[b] = j;
      bonds.length[b] = r;
      bonds.volumeFraction[b] = partialVolume(r, horizon, spacing);
      ++b;
    }
  }
  return bonds;
}

}  // namespace cosim::pd
