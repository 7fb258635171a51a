#pragma once
// Buffer reuse for outgoing messages.
//
// Cap'n Proto builds into zeroed segments. A fresh 16 MiB segment costs a
// memset (calloc on reused heap memory) or 4096 page faults (fresh mmap pages)
// before a single payload byte is copied in, on the critical path of every
// exchange. The pool keeps the segments of sent messages and zeroes their used
// part when they come back. They come back when ZeroMQ has sent the last frame,
// i.e. on ZeroMQ's I/O thread while the sender waits for the peer's reply, so
// the next message of the same size starts from a zeroed, already mapped buffer.
//
// A large payload array (addArray) gets a segment of its own, which it fills
// completely: such a segment need not be zeroed at all, neither when it is
// allocated nor when it comes back, saving a pass over the payload on each
// side (a 16 MiB memset is about 1.4 ms here). Those "payload" segments are
// kept apart and never handed out for Cap'n Proto's structures.
//
// Only large segments are pooled: small ones are cheap to calloc and would
// otherwise pin big buffers. The pool is bounded in bytes; what does not fit is
// freed. It is thread-safe (release runs on the I/O thread) and never
// destroyed, so a frame freed during static destruction still has a pool.

#include <capnp/message.h>

#include <cstddef>
#include <mutex>
#include <optional>
#include <vector>

namespace cosim::wire {

class SegmentPool {
 public:
  /// Segments below this many words are not pooled (64 KiB).
  static constexpr std::size_t kMinPooledWords = std::size_t{1} << 13;

  struct Segment {
    capnp::word* words = nullptr;
    std::size_t capacity = 0;  // in words
    bool payload = false;      // contents not zeroed: for a payload that overwrites every word
  };
  struct Stats {
    std::size_t reused = 0, allocated = 0, freeBytes = 0, freeSegments = 0;
  };

  /// The process's pool.
  static SegmentPool& instance();

  explicit SegmentPool(std::size_t maxFreeBytes);
  SegmentPool(const SegmentPool&) = delete;
  SegmentPool& operator=(const SegmentPool&) = delete;
  ~SegmentPool();

  /// A zeroed segment of at least `words` words (at most twice that when reused).
  Segment acquire(std::size_t words);
  /// A segment of at least `words` words whose contents are undefined, for a
  /// payload that writes every one of them.
  Segment acquireForPayload(std::size_t words);
  /// Takes a segment back; only its first `usedWords` words may be non-zero
  /// (a payload segment is taken back as it is).
  void release(Segment segment, std::size_t usedWords);
  Stats stats() const;

 private:
  /// The smallest kept segment of the kind that fits without wasting more than half.
  std::optional<Segment> takeFitting(std::size_t words, bool payload);

  mutable std::mutex mutex_;
  std::vector<Segment> free_;
  std::size_t maxFreeBytes_;
  std::size_t freeBytes_ = 0;
  std::size_t reused_ = 0, allocated_ = 0;
};

/// A MessageBuilder whose segments come from a SegmentPool and go back to it
/// when the builder is destroyed.
class PooledMessageBuilder final : public capnp::MessageBuilder {
 public:
  PooledMessageBuilder(std::size_t firstSegmentWords, SegmentPool& pool = SegmentPool::instance());
  PooledMessageBuilder(const PooledMessageBuilder&) = delete;
  PooledMessageBuilder& operator=(const PooledMessageBuilder&) = delete;
  ~PooledMessageBuilder() override;

  kj::ArrayPtr<capnp::word> allocateSegment(unsigned minimumSize) override;

  /// Announces, on this thread, that the next list to be initialised is a
  /// payload of `words` words that the caller overwrites completely. Should
  /// Cap'n Proto ask for a new segment for exactly that list (and its far
  /// pointer's landing pad), it gets an unzeroed payload segment of exactly
  /// that size. Scoped; nothing else may be built while it lives.
  class PayloadScope {
   public:
    explicit PayloadScope(std::size_t words);
    ~PayloadScope();
    /// Cap'n Proto asks, on this thread, for the announced payload's segment.
    static bool announces(std::size_t minimumSize);
    PayloadScope(const PayloadScope&) = delete;
    PayloadScope& operator=(const PayloadScope&) = delete;
  };
  /// Payloads from this many words get a segment of their own.
  static constexpr std::size_t kOwnSegmentWords = SegmentPool::kMinPooledWords;

 private:
  SegmentPool& pool_;
  std::size_t nextWords_;
  std::vector<SegmentPool::Segment> segments_;
};

}  // namespace cosim::wire
