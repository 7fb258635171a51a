#pragma once
// How much a seekable input stream still holds: readers bound the counts they
// read by it, so that a corrupt count is refused before it allocates.
#include <cstdint>
#include <istream>

namespace cosim::util {

/// Bytes from the stream's position to its end; `unknown` when it cannot seek.
/// The position is left where it was.
inline std::uint64_t bytesLeft(std::istream& in, std::uint64_t unknown) {
  const auto at = in.tellg();
  if (at == std::istream::pos_type(-1) || !in.seekg(0, std::ios::end)) {
    in.clear();
    return unknown;
  }
  const auto end = in.tellg();
  in.seekg(at);
  return end >= at ? static_cast<std::uint64_t>(end - at) : 0;
}

}  // namespace cosim::util
