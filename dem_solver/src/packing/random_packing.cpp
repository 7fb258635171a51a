#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <unordered_map>

#include "cosim/dem/packing/packing.hpp"

namespace cosim::dem {

SphereSet randomPacking(const Vec3& lo, const Vec3& hi, double rmin, double rmax, std::size_t count,
                        std::uint64_t seed, std::size_t maxAttempts) {
  if (!(rmin > 0.0) || rmax < rmin) throw std::invalid_argument("random packing needs 0 < rmin <= rmax");
  for (int d = 0; d < 3; ++d)
    if (hi[d] - lo[d] < 2.0 * rmax) throw std::invalid_argument("random packing box smaller than a sphere");
  if (maxAttempts == 0) maxAttempts = 1000 * count + 1000;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // Hash grid with cells of one largest diameter: overlaps are checked only
  // against the 27 surrounding cells, so the packing is O(N).
  const double cell = 2.0 * rmax;
  auto key = [&](const Vec3& x, int dx, int dy, int dz) {
    const auto c = [&](int d, int o) { return static_cast<std::int64_t>(std::floor((x[d] - lo[d]) / cell)) + o; };
    return (c(0, dx) * 73856093) ^ (c(1, dy) * 19349663) ^ (c(2, dz) * 83492791);
  };
  std::unordered_multimap<std::int64_t, std::size_t> grid;
  SphereSet s;
  for (std::size_t attempt = 0; attempt < maxAttempts && s.radii.size() < count; ++attempt) {
    const double r = rmin + (rmax - rmin) * unit(rng);
    Vec3 x;
    for (int d = 0; d < 3; ++d) x[d] = lo[d] + r + (hi[d] - lo[d] - 2.0 * r) * unit(rng);
    bool free = true;
    for (int dz = -1; dz <= 1 && free; ++dz)
      for (int dy = -1; dy <= 1 && free; ++dy)
        for (int dx = -1; dx <= 1 && free; ++dx) {
          const auto range = grid.equal_range(key(x, dx, dy, dz));
          for (auto it = range.first; it != range.second; ++it) {
            const double rs = r + s.radii[it->second];
            if (norm2(x - s.centres[it->second]) < rs * rs) {
              free = false;
              break;
            }
          }
        }
    if (!free) continue;
    grid.emplace(key(x, 0, 0, 0), s.radii.size());
    s.centres.push_back(x);
    s.velocities.push_back({});
    s.radii.push_back(r);
    s.origin.push_back("random");
  }
  return s;
}

}  // namespace cosim::dem
