#pragma once
// The nonlocal strain operator of GMH (Liu 2016 Eqs. 58-59, App. A): the
// strain increment a unit cell receives is the bell-weighted mean of the
// increments at the quadrature points within the interaction radius R,
//   <phi(x_I)>_R = sum_{J in Q_I} alpha*(x_I, xi_J) phi(xi_J),
//   alpha*(x_I, xi_J) = alpha(|x_I - xi_J|) / sum_{J in Q_I} alpha(|x_I - xi_J|),   (A.4)
//   alpha(r) = (1 - r^2 / R^2)^2 for r <= R, 0 beyond,                               (A.3)
//   Q_I = { xi_J : |x_I - xi_J| <= R }.                                              (A.5)
// Neighbour sets and weights are precomputed from the reference positions
// (Eq. A.5: "precomputed in the preprocessing stage"). R is an intrinsic
// length: it keeps a shear band's thickness from shrinking with the mesh.
// The staggered operator (Eq. A.6) may use a neighbour's increment of the
// previous or the current step; all increments of a coarse step reach the
// coupler together, so the current ones are used for every point.
//
// Stability. The bell kernel is not a positive-definite function: sampled
// on a mesh finer than about h = 0.6 R the operator gets negative eigenvalues
// (-0.055 on L5's 12x24 mesh with R = 6.75 mm, h = 3.3 mm). Strain patterns
// alternating from element to element then meet a negative stiffness
// B^T D A B, and an explicit run grows them exponentially. The local
// fraction beta blends the point's own increment back in (Eringen's two-
// phase form),  A_beta = (1 - beta) A + beta I,  whose eigenvalues are
// (1 - beta) lambda + beta; smallestEigenvalue() tells whether a mesh needs it.
#include <cstdint>
#include <span>
#include <vector>

namespace cosim::coupler {

class NonlocalOperator {
 public:
  /// positions: 3 per point (reference); radius R > 0; local fraction beta in [0, 1).
  NonlocalOperator(std::span<const double> positions, double radius, double localFraction = 0.0);
  std::size_t points() const { return rowStart_.empty() ? 0 : rowStart_.size() - 1; }
  /// out_I = sum_J alpha*_IJ in_J for fields of `components` values per point.
  void apply(std::span<const double> in, std::size_t components, std::span<double> out) const;
  /// The mean number of points in Q_I (each point counts itself).
  double meanNeighbours() const;
  /// The smallest eigenvalue of the operator. A = D^-1 W (W the symmetric
  /// bell weights, D their row sums) is similar to D^-1/2 W D^-1/2, so its
  /// eigenvalues are real; Lanczos with full reorthogonalisation over up to
  /// 150 vectors finds the lowest (exact when there are at most 150 points,
  /// otherwise an upper bound that converges from above).
  double smallestEigenvalue() const;
  /// The local fraction that lifts to `target` an operator whose smallest
  /// eigenvalue is `lowest` at local fraction `beta` (0 when the pure operator
  /// already reaches it): inverts (1 - beta) lambda + beta for the pure lambda.
  static double localFractionFor(double lowest, double beta, double target);
  std::span<const std::uint32_t> neighbours(std::size_t point) const {
    return {neighbour_.data() + rowStart_[point], neighbour_.data() + rowStart_[point + 1]};
  }
  std::span<const double> weights(std::size_t point) const {
    return {weight_.data() + rowStart_[point], weight_.data() + rowStart_[point + 1]};
  }

 private:
  std::vector<std::uint32_t> rowStart_, neighbour_;
  std::vector<double> weight_;
  std::vector<double> rowSum_;  // D: sum_J alpha(|x_I - xi_J|), the normalisation of Eq. A.4
};

}  // namespace cosim::coupler
