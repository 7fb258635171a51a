#pragma once
// Thread helpers that keep reductions deterministic: each thread sums its
// static share, and the shares are added in thread order afterwards.
#include <cstddef>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace cosim::dem {

/// Below this many particles a loop runs serially: fork/join costs more than it saves.
inline constexpr std::size_t kParallelMin = 1024;

inline int threadCount() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

/// Threads of the enclosing parallel region (1 outside one, or when it runs serially).
inline int teamSize() {
#ifdef _OPENMP
  return omp_get_num_threads();
#else
  return 1;
#endif
}

inline int threadIndex() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

}  // namespace cosim::dem
