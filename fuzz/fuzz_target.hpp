#pragma once
// One fuzz target per file: it defines LLVMFuzzerTestOneInput (libFuzzer's
// entry) and cosim::fuzz::seeds(), inputs that reach its structure, written
// into the seed corpus by `fuzz_replay_<target> --write-seeds DIR`.
#include <cstddef>
#include <cstdint>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace cosim::fuzz {
std::vector<std::vector<std::uint8_t>> seeds();
}  // namespace cosim::fuzz
