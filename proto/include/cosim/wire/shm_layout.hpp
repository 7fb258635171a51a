#pragma once
// The layout of a shared-memory segment file (shm_link.hpp): the contract
// between the coupler's end and the solver's, like the schemas are for the
// messages. Every field both ends touch is here; version changes with it.
//
//   [SegmentHeader, kHeaderBytes][lane 0 arena, laneWords][lane 1 arena, laneWords]
//
// Lane 0 carries requests (coupler -> solver), lane 1 replies. An arena holds
// Cap'n Proto segments; a Slot describes one message by the offsets and
// lengths of its segments. Offsets are in 8-byte words from the arena's start.
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "cosim/wire/shm_link.hpp"

namespace cosim::wire::shm_layout {

constexpr char kMagic[8] = {'C', 'O', 'S', 'I', 'M', 'S', 'H', 'M'};
constexpr std::uint32_t kLayoutVersion = 1;
constexpr unsigned kSlots = 64;        // messages a reader may hold at once, per lane
constexpr unsigned kMaxSegments = 16;  // segments of one message in the lane
constexpr std::size_t kHeaderBytes = 64 * 1024;

/// One message's place in the arena, as its writer published it.
struct alignas(64) Slot {
  std::atomic<std::uint32_t> released;  // 1: free (the reader let go, or never used)
  std::uint32_t segmentCount;           // 0: the message travels on ZeroMQ
  std::uint64_t offsets[kMaxSegments];  // in words from the arena's start
  std::uint64_t words[kMaxSegments];
};

struct alignas(64) LaneHeader {
  std::atomic<std::uint64_t> posted;      // descriptors published; message n is in slots[n % kSlots]
  std::atomic<std::uint64_t> grownWords;  // arena words the file holds (allocated by the writer)
  alignas(64) Doorbell bell;              // lane 0's reader sleeps here (lane 1's on the coupler's doorbell)
  alignas(64) Slot slots[kSlots];
};

struct SegmentHeader {
  char magic[8];
  std::uint32_t version;
  std::uint32_t slots;
  std::uint64_t laneWords;
  LaneHeader lanes[2];
};
static_assert(sizeof(SegmentHeader) <= kHeaderBytes);
static_assert(std::atomic<std::uint32_t>::is_always_lock_free && std::atomic<std::uint64_t>::is_always_lock_free);

}  // namespace cosim::wire::shm_layout
