#pragma once
// The deterministic data a mock solver emits: arbitrary finite doubles
// (negative zero, subnormals and huge values included), so that a transfer
// that changes a single bit is caught.
#include <bit>
#include <cstdint>
#include <vector>

namespace cosim::mock {

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

/// Value i of the pattern a mock with this seed emits at this exchange.
inline double patternValue(std::uint64_t seed, std::uint64_t exchange, std::uint64_t i) {
  std::uint64_t bits = splitmix64(splitmix64(seed * 0x100000001b3ull + exchange) ^ i);
  constexpr std::uint64_t exponent = 0x7ff0000000000000ull;
  if ((bits & exponent) == exponent) bits &= ~(1ull << 62);  // inf/NaN -> finite
  return std::bit_cast<double>(bits);
}

inline std::vector<double> pattern(std::uint64_t seed, std::uint64_t exchange, std::size_t length) {
  std::vector<double> v(length);
  for (std::size_t i = 0; i < length; ++i) v[i] = patternValue(seed, exchange, i);
  return v;
}

}  // namespace cosim::mock
