#pragma once
// Helpers for the energy-method surface correction (Le & Bobaru 2018,
// Madenci & Oterkus 2014): per-particle factors for uniaxial strain along x, y
// and z, relative to the same sum over a complete family, combined per bond on
// the ellipsoid through the three factors.
#include <cmath>
#include <vector>

#include "cosim/pd/bonds.hpp"

namespace cosim::pd::detail {

/// Bond factor for unit direction n from per-axis factors g (ellipsoid rule).
inline double ellipsoidFactor(const double n[3], const double g[3]) {
  double s = 0.0;
  for (int k = 0; k < 3; ++k) s += (n[k] / g[k]) * (n[k] / g[k]);
  return s > 0.0 ? 1.0 / std::sqrt(s) : 1.0;
}

/// The complete family of a particle in an unbounded simple-cubic lattice of
/// spacing h, with the same partial-volume rule as buildBonds: the reference
/// a surface particle's truncated family is corrected towards.
struct FullFamily {
  std::vector<double> xi;      // 3 per bond
  std::vector<double> length;
  std::vector<double> volume;  // beta h^3
};

inline FullFamily fullLatticeFamily(double h, double horizon, PartialVolume rule) {
  FullFamily f;
  const int n = static_cast<int>(std::ceil(horizon / h + 0.5)) + 1;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k) {
        if (i == 0 && j == 0 && k == 0) continue;
        const double x[3] = {i * h, j * h, k * h};
        const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        const double beta = partialVolumeFraction(r, horizon, h, rule);
        if (beta <= 0.0) continue;
        f.xi.insert(f.xi.end(), x, x + 3);
        f.length.push_back(r);
        f.volume.push_back(beta * h * h * h);
      }
  return f;
}

}  // namespace cosim::pd::detail
