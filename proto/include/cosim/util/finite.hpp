#pragma once
// The solvers check their state for infinities and NaNs after every advance.
// Most states are finite, so the check is a branch-free scan (this test ORed
// over the arrays, which the compiler vectorises); the per-value search that
// names the culprit runs only when the scan finds one.
#include <bit>
#include <cstdint>

namespace cosim::util {

/// True for an infinity or a NaN: every exponent bit set.
constexpr bool nonFinite(double value) {
  constexpr std::uint64_t exponent = 0x7ff0000000000000;
  return (std::bit_cast<std::uint64_t>(value) & exponent) == exponent;
}

}  // namespace cosim::util
