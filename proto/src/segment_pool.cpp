#include "cosim/wire/segment_pool.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <new>

namespace cosim::wire {
namespace {

// Enough for a few exchanges' worth of large messages in flight; beyond this
// a returned segment is freed rather than kept.
constexpr std::size_t kProcessPoolBytes = std::size_t{256} << 20;
// Cap'n Proto addresses a segment with 29-bit word offsets.
constexpr std::size_t kMaxSegmentWords = (std::size_t{1} << 29) - 1;

// Cap'n Proto's structures go to the first segment; a payload bigger than
// this goes to its own segment (see PayloadScope).
constexpr std::size_t kMaxFirstSegmentWords = PooledMessageBuilder::kOwnSegmentWords;

capnp::word* allocateWords(std::size_t words, bool zeroed) {
  void* p = zeroed ? std::calloc(words, sizeof(capnp::word)) : std::malloc(words * sizeof(capnp::word));
  if (p == nullptr) throw std::bad_alloc();
  return static_cast<capnp::word*>(p);
}

// The payload announced on this thread (PayloadScope): its list's words, 0 for none.
thread_local std::size_t t_payloadWords = 0;

}  // namespace

SegmentPool& SegmentPool::instance() {
  // Never destroyed: ZeroMQ's I/O thread may hand a segment back during exit.
  static SegmentPool* pool = new SegmentPool(kProcessPoolBytes);
  return *pool;
}

SegmentPool::SegmentPool(std::size_t maxFreeBytes) : maxFreeBytes_(maxFreeBytes) {}

SegmentPool::~SegmentPool() {
  for (auto& s : free_) std::free(s.words);
}

std::optional<SegmentPool::Segment> SegmentPool::takeFitting(std::size_t words, bool payload) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto best = free_.end();
  for (auto it = free_.begin(); it != free_.end(); ++it)
    if (it->payload == payload && it->capacity >= words && it->capacity <= 2 * words &&
        (best == free_.end() || it->capacity < best->capacity))
      best = it;
  if (best == free_.end()) {
    ++allocated_;
    return std::nullopt;
  }
  const Segment s = *best;
  free_.erase(best);
  freeBytes_ -= s.capacity * sizeof(capnp::word);
  ++reused_;
  return s;
}

SegmentPool::Segment SegmentPool::acquire(std::size_t words) {
  if (words >= kMinPooledWords)
    if (auto s = takeFitting(words, false)) return *s;
  return {allocateWords(words, true), words, false};
}

SegmentPool::Segment SegmentPool::acquireForPayload(std::size_t words) {
  if (words >= kMinPooledWords)
    if (auto s = takeFitting(words, true)) return *s;
  return {allocateWords(words, false), words, true};
}

void SegmentPool::release(Segment segment, std::size_t usedWords) {
  if (segment.words == nullptr) return;
  const std::size_t bytes = segment.capacity * sizeof(capnp::word);
  if (segment.capacity >= kMinPooledWords) {
    // Zero outside the lock: this is the work the next sender no longer does.
    if (!segment.payload) std::memset(segment.words, 0, std::min(usedWords, segment.capacity) * sizeof(capnp::word));
    std::lock_guard<std::mutex> lock(mutex_);
    if (freeBytes_ + bytes <= maxFreeBytes_) {
      free_.push_back(segment);
      freeBytes_ += bytes;
      return;
    }
  }
  std::free(segment.words);
}

SegmentPool::Stats SegmentPool::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {reused_, allocated_, freeBytes_, free_.size()};
}

PooledMessageBuilder::PooledMessageBuilder(std::size_t firstSegmentWords, SegmentPool& pool)
    : pool_(pool), nextWords_(std::clamp<std::size_t>(firstSegmentWords, 64, kMaxFirstSegmentWords)) {}

PooledMessageBuilder::PayloadScope::PayloadScope(std::size_t words) { t_payloadWords = words; }
PooledMessageBuilder::PayloadScope::~PayloadScope() { t_payloadWords = 0; }
bool PooledMessageBuilder::PayloadScope::announces(std::size_t minimumSize) {
  // The announced payload's list plus the one-word landing pad of the far
  // pointer to it (Cap'n Proto writes that word, the caller every other).
  return t_payloadWords >= kOwnSegmentWords && minimumSize == t_payloadWords + 1;
}

PooledMessageBuilder::~PooledMessageBuilder() {
  // What the arena wrote into each segment; the rest is still zero.
  const auto used = getSegmentsForOutput();
  for (auto& s : segments_) {
    std::size_t words = s.capacity;
    for (const auto& u : used)
      if (u.begin() == s.words) words = u.size();
    pool_.release(s, words);
  }
}

kj::ArrayPtr<capnp::word> PooledMessageBuilder::allocateSegment(unsigned minimumSize) {
  if (PayloadScope::announces(minimumSize)) {
    segments_.push_back(pool_.acquireForPayload(minimumSize));
    return {segments_.back().words, minimumSize};
  }
  const std::size_t words = std::max<std::size_t>(minimumSize, nextWords_);
  // Grow like Cap'n Proto's own builder: each new segment as large as all before.
  nextWords_ += words;
  segments_.push_back(pool_.acquire(words));
  return {segments_.back().words, std::min(segments_.back().capacity, kMaxSegmentWords)};
}

}  // namespace cosim::wire
