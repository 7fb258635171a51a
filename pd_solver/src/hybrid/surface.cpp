// Hybrid surface particles, Hartmann 2022 Sec. 3.1.
#include <cmath>
#include <algorithm>
#include <numbers>

#include "cosim/pd/hybrid.hpp"

namespace cosim::pd {

std::vector<std::uint32_t> surfaceParticles(const Particles& p, std::size_t begin, std::size_t end,
                                            double spacing) {
  // Count partners within 1.5 h by brute force over a sorted sweep along x:
  // only particles with |dx| <= 1.5 h are inspected.
  std::vector<std::uint32_t> order;
  for (std::size_t i = begin; i < end; ++i) order.push_back(static_cast<std::uint32_t>(i));
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return p.reference[3 * a] < p.reference[3 * b];
  });
  const double r = 1.5 * spacing, r2 = r * r;
  std::vector<int> count(end - begin, 0);
  for (std::size_t a = 0; a < order.size(); ++a) {
    const std::uint32_t i = order[a];
    for (std::size_t c = a + 1; c < order.size(); ++c) {
      const std::uint32_t j = order[c];
      const double dx = p.reference[3 * j] - p.reference[3 * i];
      if (dx > r) break;
      const double dy = p.reference[3 * j + 1] - p.reference[3 * i + 1];
      const double dz = p.reference[3 * j + 2] - p.reference[3 * i + 2];
      if (dx * dx + dy * dy + dz * dz <= r2) {
        ++count[i - begin];
        ++count[j - begin];
      }
    }
  }
  std::vector<std::uint32_t> out;
  for (std::size_t i = begin; i < end; ++i)
    if (count[i - begin] < 18) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

double quasiRadius(double volume) {
  return std::cbrt(3.0 * volume / (4.0 * std::numbers::pi));  // Hartmann 2022 Eq. 39
}

bool surfaceNormal(const Particles& p, const Bonds& b, std::size_t particle, double normal[3]) {
  const std::size_t il = particle - b.begin;
  double s[3] = {0, 0, 0}, full = 0.0;
  for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
    const double wv = b.volumeFraction[k] * p.volume[b.neighbor[k]];
    full += wv * b.length[k];
    for (int a = 0; a < 3; ++a)
      s[a] -= wv * (p.reference[3 * b.neighbor[k] + a] - p.reference[3 * particle + a]);
  }
  const double len = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  // Balanced families (interior particles) have a first moment at round-off level.
  if (!(len > 1e-8 * full)) return false;
  for (int a = 0; a < 3; ++a) normal[a] = s[a] / len;
  return true;
}

}  // namespace cosim::pd
