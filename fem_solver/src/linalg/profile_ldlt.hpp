#pragma once
// Envelope (profile, "skyline") L D L^T of a symmetric sparse matrix in
// reverse Cuthill-McKee order (George & Liu 1981, Ch. 4). Row i of L is
// stored densely from its first nonzero column on, so both triangular solves
// run over contiguous memory: the forward one as dot products (four partial
// sums, since one running sum is bound by the add latency), the backward one
// as axpys. On a slender mesh (a beam a few elements thick) the envelope
// holds about as many entries as AMD's sparse factor, and the solve is 2-3x
// faster than Eigen's SimplicialLDLT (`fem_bench solvers`). On compact 3D
// meshes the envelope grows much faster than the sparse factor, so `direct`
// chooses it only where the envelope holds at most 1.5 times the sparse
// factor's entries (docs/fem.md).
#include <cstddef>
#include <vector>

#include "cosim/fem/linalg/sparse_system.hpp"

namespace cosim::fem {

class ProfileLdlt {
 public:
  /// Reverse Cuthill-McKee order of A's graph and the envelope of its lower
  /// triangle in that order. A: square, symmetric, both triangles stored.
  void analyse(const SparseSystem::Matrix& A);
  /// Entries of L below the diagonal inside the envelope.
  std::size_t envelopeSize() const { return offset_.empty() ? 0 : offset_.back(); }
  /// L D L^T = P A P^T without pivoting; returns the (unpermuted) index of
  /// the first pivot at or below relPivot of the largest, or -1.
  int factorize(const SparseSystem::Matrix& A, double relPivot);
  /// x = A^{-1} b (x may not alias b).
  void solve(const double* b, double* x) const;

 private:
  std::vector<int> newOf_, oldOf_;        // permutation: new index of old dof, old dof of new index
  std::vector<int> first_;                // first column of row i's envelope (new numbering)
  std::vector<std::size_t> offset_;       // row i's entries at offset_[i] .. offset_[i + 1]
  std::vector<double> lower_, pivots_;    // L's envelope rows, D
  mutable std::vector<double> work_;      // the permuted right-hand side
};

}  // namespace cosim::fem
