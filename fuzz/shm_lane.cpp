// Fuzz target: the request lane of a shared-memory segment as a corrupt or
// hostile coupler end could leave it, read by the solver's end (ShmLink::take,
// then every field of each message, as the solver host and the peer session
// do). The input overwrites the lane's descriptors, its count of posted
// messages, its count of arena words and the start of its arena. Each item
// must be a message, a malformed item or an "on ZeroMQ" item: never a crash, a
// read outside the segment file or a hang.
//
// Input layout: byte 0: messages claimed (0-69, beyond 64 is itself malformed);
// byte 1: bit 0 set claims 2^40 arena words; then the descriptors' bytes
// (slot after slot) and the rest the arena's first bytes.
#include <kj/exception.h>
#include <unistd.h>

#include <cstring>
#include <memory>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/shm_layout.hpp"
#include "cosim/wire/shm_link.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {
namespace wire = cosim::wire;
namespace layout = cosim::wire::shm_layout;

constexpr std::size_t kArenaBytes = 64 * 1024;  // of the input, at most

/// The segment, the coupler's end (which allocated the arena by posting a
/// message) and the start of the request lane, made once per process.
struct Segment {
  std::unique_ptr<wire::CouplerDoorbell> doorbell;
  std::shared_ptr<wire::ShmLink> coupler;
  std::string path;
  Segment() {
    const auto dir = cosim::fuzz::scratchDir();
    path = (dir / "segment").string();
    doorbell = std::make_unique<wire::CouplerDoorbell>((dir / "doorbell").string());
    coupler = wire::ShmLink::create(path, std::uint64_t{1} << 30, *doorbell);
    wire::OutMessage m = coupler->message(256);
    const std::vector<double> values(kArenaBytes / sizeof(double), 1.0);
    wire::addArray(m.envelope().getBody().initAdvance().initInputs().initArrays(1), 0, "u", 1, values);
    coupler->post(m);
    // The target's own view of the file, and the arena as the post left it,
    // restored before every input so that no input sees another's bytes.
    view = wire::ShmLink::open(path, doorbell->path());
    const auto* a = reinterpret_cast<const std::uint8_t*>(view->arena(0));
    pristine.assign(a, a + kPristineBytes);
  }
  static constexpr std::size_t kPristineBytes = 4 * kArenaBytes;  // the posted message lies within
  std::shared_ptr<wire::ShmLink> view;
  std::vector<std::uint8_t> pristine;
};

Segment& segment() {
  static Segment s;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2 || size > cosim::fuzz::kMaxInputBytes) return -1;
  auto& seg = segment();
  // A fresh reader each time: it starts at message 0.
  auto reader = wire::ShmLink::open(seg.path, seg.doorbell->path());
  auto& header = *static_cast<layout::SegmentHeader*>(reader->mappedHeader());
  auto& lane = header.lanes[0];
  std::memcpy(reader->arena(0), seg.pristine.data(), seg.pristine.size());
  const unsigned claimed = data[0] % 70;
  const std::uint64_t grown = lane.grownWords.load();
  if (data[1] & 1) lane.grownWords.store(std::uint64_t{1} << 40);
  std::size_t at = 2;
  for (unsigned k = 0; k < layout::kSlots && at < size; ++k) {
    auto& slot = lane.slots[k];
    const std::size_t n = std::min(sizeof(slot.offsets) + sizeof(slot.words) + sizeof(slot.segmentCount), size - at);
    std::uint8_t raw[sizeof(slot.offsets) + sizeof(slot.words) + sizeof(slot.segmentCount)] = {};
    std::memcpy(raw, data + at, n);
    at += n;
    std::memcpy(&slot.segmentCount, raw, sizeof(slot.segmentCount));
    std::memcpy(slot.offsets, raw + sizeof(slot.segmentCount), sizeof(slot.offsets));
    std::memcpy(slot.words, raw + sizeof(slot.segmentCount) + sizeof(slot.offsets), sizeof(slot.words));
    if (k + 1 >= claimed) break;
  }
  if (at < size) std::memcpy(reader->arena(0), data + at, std::min(size - at, kArenaBytes));
  lane.posted.store(claimed);
  for (unsigned k = 0; k <= claimed; ++k) {
    auto item = reader->take();
    if (!item) break;
    if (item->kind != wire::LaneItem::Kind::message) continue;
    try {
      cosim::fuzz::readEverywhere(item->message->envelope());
    } catch (const kj::Exception&) {
    }
  }
  lane.grownWords.store(grown);
  return 0;
}

namespace cosim::fuzz {

// Seeds: the lane as the coupler leaves it after posting one message (its
// descriptor and the start of its arena), and the same claiming several.
std::vector<std::vector<std::uint8_t>> seeds() {
  auto& seg = segment();
  auto& header = *static_cast<layout::SegmentHeader*>(seg.view->mappedHeader());
  const auto& slot = header.lanes[0].slots[0];
  std::vector<std::uint8_t> one{1, 0};
  auto append = [&](const void* p, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    one.insert(one.end(), b, b + n);
  };
  append(&slot.segmentCount, sizeof(slot.segmentCount));
  append(slot.offsets, sizeof(slot.offsets));
  append(slot.words, sizeof(slot.words));
  append(seg.view->arena(0), 4096);
  auto several = one;
  several[0] = 3;
  auto beyond = one;
  beyond[1] = 1;
  return {one, several, beyond};
}

}  // namespace cosim::fuzz
