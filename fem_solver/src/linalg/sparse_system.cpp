#include "cosim/fem/linalg/sparse_system.hpp"

#include <algorithm>

namespace cosim::fem {

void SparseSystem::build(const Mesh& mesh, const std::vector<int>& dofMap, int numFree) {
  std::vector<Eigen::Triplet<double, int>> triplets;
  triplets.reserve(mesh.numElements() * 576);
  auto elementDofs = [&](std::size_t e, int* dofs) {
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i)
        dofs[3 * a + i] = dofMap[3 * mesh.elements[e][static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)];
  };
  int dofs[24];
  for (std::size_t e = 0; e < mesh.numElements(); ++e) {
    elementDofs(e, dofs);
    for (int r = 0; r < 24; ++r)
      for (int c = 0; c < 24; ++c)
        if (dofs[r] >= 0 && dofs[c] >= 0) triplets.emplace_back(dofs[r], dofs[c], 0.0);
  }
  matrix_.resize(numFree, numFree);
  matrix_.setFromTriplets(triplets.begin(), triplets.end());
  matrix_.makeCompressed();
  slots_.assign(mesh.numElements() * 576, -1);
  const int* outer = matrix_.outerIndexPtr();
  const int* inner = matrix_.innerIndexPtr();
  for (std::size_t e = 0; e < mesh.numElements(); ++e) {
    elementDofs(e, dofs);
    for (int r = 0; r < 24; ++r)
      for (int c = 0; c < 24; ++c) {
        if (dofs[r] < 0 || dofs[c] < 0) continue;
        const int* begin = inner + outer[dofs[c]];
        const int* end = inner + outer[dofs[c] + 1];
        const int* pos = std::lower_bound(begin, end, dofs[r]);
        slots_[576 * e + static_cast<std::size_t>(24 * r + c)] = static_cast<int>(pos - inner);
      }
  }
}

void SparseSystem::setZero() { std::fill_n(matrix_.valuePtr(), matrix_.nonZeros(), 0.0); }

void SparseSystem::add(std::size_t element, const Mat24& Ke, double scale) {
  double* values = matrix_.valuePtr();
  const int* slot = slots_.data() + 576 * element;
  const double* k = Ke.data();  // row-major: entry 24 r + c
  for (int n = 0; n < 576; ++n)
    if (slot[n] >= 0) values[slot[n]] += scale * k[n];
}

}  // namespace cosim::fem
