#pragma once
// Loops over the entries of global dof vectors (3 per node) for the explicit
// step, which is a dozen such passes around one element loop: serial, they
// would cap two threads at about 1.5 times one. The range is cut into fixed
// chunks, and sums add per-chunk partial sums in chunk order, so the
// rounding does not depend on the thread count.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace cosim::fem {

constexpr std::size_t kDofChunk = 16384;
// Below this many chunks a parallel region costs more than it saves.
constexpr long kParallelDofChunks = 4;

/// Calls f(d) for d in [0, n); returns the sum of what f returns (0 for void-like uses).
template <class F>
double sumOverDofs(std::size_t n, F&& f) {
  const long chunks = static_cast<long>((n + kDofChunk - 1) / kDofChunk);
  std::vector<double> partial(static_cast<std::size_t>(chunks), 0.0);
#pragma omp parallel for schedule(static) if (chunks >= kParallelDofChunks)
  for (long c = 0; c < chunks; ++c) {
    const std::size_t first = static_cast<std::size_t>(c) * kDofChunk, last = std::min(n, first + kDofChunk);
    double s = 0.0;
    for (std::size_t d = first; d < last; ++d) s += f(d);
    partial[static_cast<std::size_t>(c)] = s;
  }
  double total = 0.0;
  for (double s : partial) total += s;
  return total;
}

/// Calls f(d) for d in [0, n), in parallel chunks.
template <class F>
void forEachDof(std::size_t n, F&& f) {
  sumOverDofs(n, [&](std::size_t d) {
    f(d);
    return 0.0;
  });
}

}  // namespace cosim::fem
