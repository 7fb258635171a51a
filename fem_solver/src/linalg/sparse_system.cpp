#include "cosim/fem/linalg/sparse_system.hpp"

#include <algorithm>

namespace cosim::fem {

namespace {

/// Nodes sharing an element with each node, itself included (CSR, sorted).
void nodeNeighbours(const Mesh& mesh, std::vector<std::size_t>& start, std::vector<Index>& neighbours) {
  const std::size_t nn = mesh.numNodes();
  std::vector<std::size_t> elemStart(nn + 1, 0), elems(8 * mesh.numElements());
  for (const Hex& h : mesh.elements)
    for (Index n : h) ++elemStart[n + 1];
  for (std::size_t n = 0; n < nn; ++n) elemStart[n + 1] += elemStart[n];
  std::vector<std::size_t> cursor(elemStart.begin(), elemStart.end() - 1);
  for (std::size_t e = 0; e < mesh.numElements(); ++e)
    for (Index n : mesh.elements[e]) elems[cursor[n]++] = e;
  start.assign(nn + 1, 0);
  neighbours.clear();
  std::vector<Index> list;
  for (std::size_t n = 0; n < nn; ++n) {
    list.clear();
    for (std::size_t k = elemStart[n]; k < elemStart[n + 1]; ++k)
      list.insert(list.end(), mesh.elements[elems[k]].begin(), mesh.elements[elems[k]].end());
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    neighbours.insert(neighbours.end(), list.begin(), list.end());
    start[n + 1] = neighbours.size();
  }
}

}  // namespace

void SparseSystem::build(const Mesh& mesh, const std::vector<int>& dofMap, int numFree) {
  // Pattern from the node graph (a column holds the dofs of the nodes that
  // share an element with its node), not from 576 triplets per element: at
  // 1e5 dofs that is 17 million triplets and as many bytes of sorting traffic.
  std::vector<std::size_t> start;
  std::vector<Index> neighbours;
  nodeNeighbours(mesh, start, neighbours);
  // Rows of each free column; a periodic slave's column merges into its master's.
  std::vector<std::vector<int>> rows(static_cast<std::size_t>(numFree));
  for (std::size_t d = 0; d < dofMap.size(); ++d) {
    if (dofMap[d] < 0) continue;
    std::vector<int>& column = rows[static_cast<std::size_t>(dofMap[d])];
    const std::size_t n = d / 3;
    for (std::size_t k = start[n]; k < start[n + 1]; ++k)
      for (std::size_t i = 0; i < 3; ++i)
        if (const int r = dofMap[3 * neighbours[k] + i]; r >= 0) column.push_back(r);
  }
  std::vector<int> outer(static_cast<std::size_t>(numFree) + 1, 0);
  for (std::size_t c = 0; c < rows.size(); ++c) {
    std::sort(rows[c].begin(), rows[c].end());
    rows[c].erase(std::unique(rows[c].begin(), rows[c].end()), rows[c].end());
    outer[c + 1] = outer[c] + static_cast<int>(rows[c].size());
  }
  matrix_.resize(numFree, numFree);
  matrix_.resizeNonZeros(outer.back());
  std::copy(outer.begin(), outer.end(), matrix_.outerIndexPtr());
  for (std::size_t c = 0; c < rows.size(); ++c) std::copy(rows[c].begin(), rows[c].end(), matrix_.innerIndexPtr() + outer[c]);
  setZero();
  auto elementDofs = [&](std::size_t e, int* dofs) {
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i)
        dofs[3 * a + i] = dofMap[3 * mesh.elements[e][static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)];
  };
  slots_.assign(mesh.numElements() * 576, -1);
  const int* inner = matrix_.innerIndexPtr();
  int dofs[24];
  for (std::size_t e = 0; e < mesh.numElements(); ++e) {
    elementDofs(e, dofs);
    for (int r = 0; r < 24; ++r)
      for (int c = 0; c < 24; ++c) {
        if (dofs[r] < 0 || dofs[c] < 0) continue;
        const int* begin = inner + outer[static_cast<std::size_t>(dofs[c])];
        const int* end = inner + outer[static_cast<std::size_t>(dofs[c]) + 1];
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
