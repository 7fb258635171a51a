#include "cosim/coupler/mapping/nonlocal_operator.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

namespace cosim::coupler {
namespace {

using Cell = std::tuple<std::int64_t, std::int64_t, std::int64_t>;

Cell cellOf(const double* x, double size) {
  return {static_cast<std::int64_t>(std::floor(x[0] / size)), static_cast<std::int64_t>(std::floor(x[1] / size)),
          static_cast<std::int64_t>(std::floor(x[2] / size))};
}

/// Liu 2016 Eq. A.3: the bell-shaped weight.
double bell(double r, double radius) {
  if (r > radius) return 0.0;
  const double s = 1.0 - r * r / (radius * radius);
  return s * s;
}

}  // namespace

NonlocalOperator::NonlocalOperator(std::span<const double> positions, double radius) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("nonlocal radius must be positive, got " + std::to_string(radius));
  if (positions.size() % 3 != 0)
    throw std::invalid_argument("nonlocal operator: " + std::to_string(positions.size()) + " coordinates, not 3 per point");
  const std::size_t n = positions.size() / 3;
  // Points binned in cubes of size R: Q_I lies in the 27 cubes around x_I.
  std::map<Cell, std::vector<std::uint32_t>> bins;
  for (std::size_t p = 0; p < n; ++p) bins[cellOf(&positions[3 * p], radius)].push_back(static_cast<std::uint32_t>(p));
  rowStart_.reserve(n + 1);
  rowStart_.push_back(0);
  for (std::size_t i = 0; i < n; ++i) {
    const double* xi = &positions[3 * i];
    const auto [cx, cy, cz] = cellOf(xi, radius);
    const std::size_t begin = neighbour_.size();
    double total = 0.0;
    for (std::int64_t a = cx - 1; a <= cx + 1; ++a)
      for (std::int64_t b = cy - 1; b <= cy + 1; ++b)
        for (std::int64_t c = cz - 1; c <= cz + 1; ++c) {
          const auto bin = bins.find({a, b, c});
          if (bin == bins.end()) continue;
          for (std::uint32_t j : bin->second) {
            const double* xj = &positions[3 * static_cast<std::size_t>(j)];
            const double w = bell(std::hypot(xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]), radius);
            if (w <= 0.0) continue;
            neighbour_.push_back(j);
            weight_.push_back(w);
            total += w;
          }
        }
    // Eq. A.4: normalised over Q_I (never empty: x_I itself has weight 1).
    for (std::size_t k = begin; k < weight_.size(); ++k) weight_[k] /= total;
    rowStart_.push_back(static_cast<std::uint32_t>(neighbour_.size()));
  }
}

void NonlocalOperator::apply(std::span<const double> in, std::size_t components, std::span<double> out) const {
  const std::size_t n = points();
  if (in.size() != components * n || out.size() != components * n)
    throw std::invalid_argument("nonlocal operator over " + std::to_string(n) + " points got " +
                                std::to_string(in.size()) + " values in and " + std::to_string(out.size()) + " out (" +
                                std::to_string(components) + " per point expected)");
  for (std::size_t i = 0; i < n; ++i) {
    double* o = &out[components * i];
    std::fill(o, o + components, 0.0);
    for (std::uint32_t k = rowStart_[i]; k < rowStart_[i + 1]; ++k) {
      const double* v = &in[components * neighbour_[k]];
      for (std::size_t c = 0; c < components; ++c) o[c] += weight_[k] * v[c];
    }
  }
}

double NonlocalOperator::meanNeighbours() const {
  return points() == 0 ? 0.0 : static_cast<double>(neighbour_.size()) / static_cast<double>(points());
}

}  // namespace cosim::coupler
