#pragma once
// Thread helpers that keep reductions deterministic: each thread sums its
// static share, and the shares are added in thread order afterwards.
#include <cstddef>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace cosim::dem {

/// A loop compiled for AVX-512 and AVX2 besides the baseline, the widest the
/// CPU has picked at load time. The core is built without FMA contraction, so
/// every clone gives the baseline's results bit for bit. (The outlined body of
/// an OpenMP loop does not inherit it: put it on a function the loop calls.)
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define COSIM_DEM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define COSIM_DEM_SIMD_CLONES
#endif

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
