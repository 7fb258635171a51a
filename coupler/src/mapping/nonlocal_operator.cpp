#include "cosim/coupler/mapping/nonlocal_operator.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <random>
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

NonlocalOperator::NonlocalOperator(std::span<const double> positions, double radius, double localFraction) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("nonlocal radius must be positive, got " + std::to_string(radius));
  if (!(localFraction >= 0.0 && localFraction < 1.0))
    throw std::invalid_argument("nonlocal local fraction must lie in [0, 1), got " + std::to_string(localFraction));
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
    // Eq. A.4: normalised over Q_I (never empty: x_I itself has weight 1),
    // then blended with the point itself: (1 - beta) alpha*_IJ + beta delta_IJ.
    for (std::size_t k = begin; k < weight_.size(); ++k)
      weight_[k] = (1.0 - localFraction) * weight_[k] / total + (neighbour_[k] == i ? localFraction : 0.0);
    rowSum_.push_back(total);
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

double NonlocalOperator::smallestEigenvalue() const {
  const std::size_t n = points();
  if (n == 0) return 1.0;
  const auto size = static_cast<Eigen::Index>(n);
  // S = D^1/2 A D^-1/2 is symmetric: S_IJ = A_IJ sqrt(D_I / D_J).
  std::vector<double> root(n);
  for (std::size_t i = 0; i < n; ++i) root[i] = std::sqrt(rowSum_[i]);
  const auto applySymmetric = [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    for (std::size_t i = 0; i < n; ++i) {
      double s = 0.0;
      for (std::uint32_t k = rowStart_[i]; k < rowStart_[i + 1]; ++k) s += weight_[k] * v[neighbour_[k]] / root[neighbour_[k]];
      out[static_cast<Eigen::Index>(i)] = s * root[i];
    }
  };
  const Eigen::Index steps = std::min<Eigen::Index>(size, 150);
  Eigen::MatrixXd basis(size, steps);
  Eigen::VectorXd diagonal(steps), offDiagonal(steps), w(size);
  // A fixed pseudo-random start: the uniform field is an eigenvector (1) and would stop Lanczos at once.
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd q(size);
  for (auto& v : q) v = u(rng);
  q.normalize();
  Eigen::Index m = 0;
  for (; m < steps; ++m) {
    basis.col(m) = q;
    applySymmetric(q, w);
    diagonal[m] = q.dot(w);
    // Full reorthogonalisation against every earlier vector (twice is enough).
    for (int pass = 0; pass < 2; ++pass) w -= basis.leftCols(m + 1) * (basis.leftCols(m + 1).transpose() * w);
    offDiagonal[m] = w.norm();
    if (offDiagonal[m] <= 1e-12) {  // an invariant subspace: its Ritz values are exact
      ++m;
      break;
    }
    q = w / offDiagonal[m];
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ritz;
  ritz.computeFromTridiagonal(diagonal.head(m), offDiagonal.head(std::max<Eigen::Index>(m - 1, 0)),
                              Eigen::EigenvaluesOnly);
  return ritz.eigenvalues().minCoeff();
}

double NonlocalOperator::localFractionFor(double lowest, double beta, double target) {
  const double pure = (lowest - beta) / (1.0 - beta);
  // (1 - beta') pure + beta' = target.
  return pure >= target ? 0.0 : (target - pure) / (1.0 - pure);
}

double NonlocalOperator::meanNeighbours() const {
  return points() == 0 ? 0.0 : static_cast<double>(neighbour_.size()) / static_cast<double>(points());
}

}  // namespace cosim::coupler
