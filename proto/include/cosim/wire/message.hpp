#pragma once
// Framing of one Envelope on a ZeroMQ multipart message.
//
// Frames: [header][segment 0]...[segment n-1]. The header is 8 bytes: the magic
// "CSM1" and the segment count (uint32, little endian). Segments travel as
// separate frames so that nothing is copied on either side: the sender hands
// the builder's segments to ZeroMQ (freed when ZeroMQ is done with them), the
// receiver reads the frames in place through a SegmentArrayMessageReader.
// Payloads beyond Cap'n Proto's default 64 MiB traversal limit are read with a
// limit derived from the actual message size (a reader cannot be made to
// traverse more than a few times what it received).

#include <capnp/message.h>
#include <zmq.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cosim/wire/segment_pool.hpp"
#include "session.capnp.h"

namespace cosim::wire {

/// An Envelope under construction. Owns its builder; moving is cheap.
class OutMessage {
 public:
  /// firstSegmentWords sizes the first allocation; pass the expected payload
  /// size in 8-byte words to keep a large message in one segment.
  explicit OutMessage(std::size_t firstSegmentWords = 1024);
  /// A message built by another kind of builder (a shared-memory lane's).
  explicit OutMessage(std::shared_ptr<capnp::MessageBuilder> builder);
  proto::Envelope::Builder envelope();
  capnp::MessageBuilder& builder() const { return *builder_; }
  /// The ZeroMQ frames that carry this message, sharing its memory.
  std::vector<zmq::message_t> frames() const;
  std::size_t sizeInBytes() const;

 private:
  std::shared_ptr<capnp::MessageBuilder> builder_;
};

/// A received Envelope; keeps the frames it points into alive.
class InMessage {
 public:
  proto::Envelope::Reader envelope() const { return root_; }
  std::size_t sizeInBytes() const { return bytes_; }

  /// Decodes frames (header + segments). Throws MalformedMessage with a
  /// description of what is wrong; never reads out of bounds.
  static InMessage decode(std::vector<zmq::message_t>&& frames);
  /// Reads segments in place (a shared-memory lane's); `hold` lives as long
  /// as the message and lets go of the memory when it is destroyed. Throws
  /// MalformedMessage like decode.
  static InMessage fromSegments(std::vector<kj::ArrayPtr<const capnp::word>>&& segments, std::shared_ptr<void> hold);

  /// Writes the envelope to a file in Cap'n Proto's standard stream format
  /// (what `capnp decode` reads), e.g. to keep a solver's last reply in a checkpoint.
  void save(const std::string& path) const;
  /// Reads a file written by save(); throws MalformedMessage naming the file.
  static InMessage load(const std::string& path);

 private:
  InMessage() = default;
  /// Reads the Envelope of segments_ (bytes_ set); throws MalformedMessage.
  void readSegments();
  std::vector<zmq::message_t> frames_;
  std::vector<kj::ArrayPtr<const capnp::word>> segments_;
  std::shared_ptr<void> hold_;
  std::vector<std::unique_ptr<capnp::word[]>> realigned_;
  kj::Array<capnp::word> fileWords_;
  std::unique_ptr<capnp::MessageReader> reader_;
  proto::Envelope::Reader root_;
  std::size_t bytes_ = 0;
};

struct MalformedMessage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Keeps large message buffers on the heap instead of fresh mmap'd pages:
/// glibc maps every allocation above its (at most 32 MiB) threshold anew, and
/// each new page faults on first touch. Measured by bench/wire (--experiment
/// heap) at 64 MiB: round trips 17-36 % faster. Call once at process start;
/// the price is that a process keeps its peak heap.
void keepLargeBuffersOnHeap();

/// Human-readable name of the envelope's body ("advance", "hello" ...).
std::string bodyName(proto::Envelope::Reader env);

}  // namespace cosim::wire
