#pragma once
// Work collected by a branchy loop into lanes (structure of arrays) and done
// by one loop without branches, which the compiler vectorises: the pair
// loop's contact batch, the opening pass's turn batch.
#include <array>
#include <cstddef>

namespace cosim::dem {

/// A loop compiled for AVX-512 and AVX2 besides the baseline, the widest the
/// CPU has picked at load time. The core is built without FMA contraction, so
/// every clone gives the baseline's results bit for bit, and with 256-bit
/// vectors in the AVX-512 clone (dem_solver/CMakeLists.txt). (The outlined body
/// of an OpenMP loop does not inherit it: put it on a function the loop calls.)
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define COSIM_DEM_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define COSIM_DEM_SIMD_CLONES
#endif

/// N lanes and how many are used. A lane is written unconditionally and kept
/// only if asked (keepIf): a branch on whether to keep it would mispredict.
template <std::size_t N>
struct LaneBatch {
  static constexpr std::size_t kSize = N;
  template <class T>
  using Lane = std::array<T, N>;
  std::size_t count = 0;
  bool full() const { return count == kSize; }
  void keepIf(bool keep) { count += keep ? 1 : 0; }
};

}  // namespace cosim::dem
