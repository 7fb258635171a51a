#include "cosim/wire/message.hpp"

#include <kj/exception.h>
#include <malloc.h>

#include <capnp/serialize.h>

#include <cstring>
#include <fstream>

namespace cosim::wire {
namespace {

constexpr char kMagic[4] = {'C', 'S', 'M', '1'};
constexpr std::size_t kHeaderBytes = 8;
// A reader may traverse at most this many times the words it received: enough
// for code that reads a list a few dozen times, still bounded against
// amplification by hostile pointers (many pointers to one object). A small
// message gets at least kTraversalFloorWords: with Cap'n Proto's default floor
// of 8 Mi words a message of a few hundred bytes can cost seconds of reading
// (fuzz/corpus/wire_decode/regress-* are such messages).
constexpr std::uint64_t kTraversalFactor = 64;
constexpr std::uint64_t kTraversalFloorWords = 1u << 20;

void releaseBuilder(void* /*data*/, void* hint) {
  delete static_cast<std::shared_ptr<capnp::MessageBuilder>*>(hint);
}

}  // namespace

OutMessage::OutMessage(std::size_t firstSegmentWords)
    : builder_(std::make_shared<PooledMessageBuilder>(firstSegmentWords)) {}

OutMessage::OutMessage(std::shared_ptr<capnp::MessageBuilder> builder) : builder_(std::move(builder)) {}

proto::Envelope::Builder OutMessage::envelope() {
  return builder_->getRoot<proto::Envelope>();
}

std::vector<zmq::message_t> OutMessage::frames() const {
  auto segments = builder_->getSegmentsForOutput();
  std::vector<zmq::message_t> out;
  out.reserve(segments.size() + 1);
  char header[kHeaderBytes];
  std::memcpy(header, kMagic, 4);
  const auto count = static_cast<std::uint32_t>(segments.size());
  std::memcpy(header + 4, &count, 4);
  out.emplace_back(header, kHeaderBytes);
  for (auto segment : segments) {
    auto bytes = segment.asBytes();
    // Zero-copy: ZeroMQ keeps the builder alive until it has sent this frame.
    out.emplace_back(const_cast<kj::byte*>(bytes.begin()), bytes.size(), &releaseBuilder,
                     new std::shared_ptr<capnp::MessageBuilder>(builder_));
  }
  return out;
}

std::size_t OutMessage::sizeInBytes() const {
  std::size_t total = 0;
  for (auto segment : builder_->getSegmentsForOutput()) total += segment.asBytes().size();
  return total;
}

InMessage InMessage::decode(std::vector<zmq::message_t>&& frames) {
  if (frames.empty()) throw MalformedMessage("empty message");
  const auto& header = frames.front();
  if (header.size() != kHeaderBytes || std::memcmp(header.data(), kMagic, 4) != 0)
    throw MalformedMessage("bad header frame (" + std::to_string(header.size()) +
                           " bytes, expected the 8-byte CSM1 header)");
  std::uint32_t count = 0;
  std::memcpy(&count, static_cast<const char*>(header.data()) + 4, 4);
  if (count == 0 || count != frames.size() - 1)
    throw MalformedMessage("header announces " + std::to_string(count) + " segments, " +
                           std::to_string(frames.size() - 1) + " arrived");
  InMessage in;
  in.frames_ = std::move(frames);
  in.segments_.reserve(count);
  for (std::size_t i = 1; i < in.frames_.size(); ++i) {
    auto& frame = in.frames_[i];
    if (frame.size() == 0 || frame.size() % sizeof(capnp::word) != 0)
      throw MalformedMessage("segment " + std::to_string(i - 1) + " has " +
                             std::to_string(frame.size()) + " bytes, not a positive multiple of 8");
    const std::size_t words = frame.size() / sizeof(capnp::word);
    const capnp::word* data = static_cast<const capnp::word*>(frame.data());
    if (reinterpret_cast<std::uintptr_t>(frame.data()) % alignof(capnp::word) != 0) {
      // ZeroMQ stores small frames inline or inside its batch buffer: copy
      // those few bytes to an aligned place rather than read unaligned words.
      auto copy = std::make_unique<capnp::word[]>(words);
      std::memcpy(copy.get(), frame.data(), frame.size());
      data = copy.get();
      in.realigned_.push_back(std::move(copy));
    }
    in.segments_.emplace_back(data, words);
  }
  in.readSegments();
  return in;
}

InMessage InMessage::fromSegments(std::vector<kj::ArrayPtr<const capnp::word>>&& segments,
                                  std::shared_ptr<void> hold) {
  if (segments.empty()) throw MalformedMessage("empty message");
  InMessage in;
  in.hold_ = std::move(hold);
  in.segments_ = std::move(segments);
  in.readSegments();
  return in;
}

void InMessage::readSegments() {
  bytes_ = 0;
  for (const auto& s : segments_) bytes_ += s.size() * sizeof(capnp::word);
  capnp::ReaderOptions options;
  const std::uint64_t totalWords = bytes_ / sizeof(capnp::word);
  options.traversalLimitInWords = std::max<std::uint64_t>(kTraversalFloorWords, totalWords * kTraversalFactor);
  try {
    // The reader keeps a pointer to the segment table: segments_ lives as long.
    reader_ = std::make_unique<capnp::SegmentArrayMessageReader>(
        kj::ArrayPtr<const kj::ArrayPtr<const capnp::word>>(segments_.data(), segments_.size()), options);
    root_ = reader_->getRoot<proto::Envelope>();
    // Walk every pointer once now, so that later reads cannot fail halfway
    // through a request's handling.
    (void)root_.totalSize();
    (void)root_.getBody().which();
  } catch (const kj::Exception& e) {
    throw MalformedMessage(std::string("not a valid Envelope: ") + e.getDescription().cStr());
  }
}

void keepLargeBuffersOnHeap() {
  mallopt(M_MMAP_THRESHOLD, 256 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
}

void InMessage::save(const std::string& path) const {
  capnp::MallocMessageBuilder copy(static_cast<unsigned>(bytes_ / sizeof(capnp::word) + 64));
  copy.setRoot(root_);
  const auto flat = capnp::messageToFlatArray(copy);
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(flat.begin()), static_cast<std::streamsize>(flat.asBytes().size()));
  if (!out) throw std::runtime_error(path + ": cannot write the message");
}

InMessage InMessage::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw MalformedMessage(path + ": cannot open");
  const auto size = static_cast<std::size_t>(in.tellg());
  if (size == 0 || size % sizeof(capnp::word) != 0)
    throw MalformedMessage(path + ": " + std::to_string(size) + " bytes is not a Cap'n Proto message");
  InMessage m;
  m.fileWords_ = kj::heapArray<capnp::word>(size / sizeof(capnp::word));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(m.fileWords_.begin()), static_cast<std::streamsize>(size));
  m.bytes_ = size;
  capnp::ReaderOptions options;
  options.traversalLimitInWords =
      std::max<std::uint64_t>(kTraversalFloorWords, size / sizeof(capnp::word) * kTraversalFactor);
  try {
    m.reader_ = std::make_unique<capnp::FlatArrayMessageReader>(m.fileWords_.asPtr(), options);
    m.root_ = m.reader_->getRoot<proto::Envelope>();
    (void)m.root_.totalSize();
  } catch (const kj::Exception& e) {
    throw MalformedMessage(path + ": not a valid Envelope: " + e.getDescription().cStr());
  }
  return m;
}

std::string bodyName(proto::Envelope::Reader env) {
  using W = proto::Envelope::Body::Which;
  switch (env.getBody().which()) {
    case W::HELLO: return "hello";
    case W::WELCOME: return "welcome";
    case W::SETUP: return "setup";
    case W::SETUP_DONE: return "setupDone";
    case W::ADVANCE: return "advance";
    case W::ADVANCED: return "advanced";
    case W::FIELDS_REQUEST: return "fieldsRequest";
    case W::FIELDS: return "fields";
    case W::CHECKPOINT: return "checkpoint";
    case W::CHECKPOINT_DONE: return "checkpointDone";
    case W::RESTORE: return "restore";
    case W::RESTORED: return "restored";
    case W::HEARTBEAT: return "heartbeat";
    case W::ERROR: return "error";
    case W::SHUTDOWN: return "shutdown";
    case W::SHUTDOWN_DONE: return "shutdownDone";
    case W::ADOPT_CELLS: return "adoptCells";
    case W::CELLS_ADOPTED: return "cellsAdopted";
  }
  return "unknown(" + std::to_string(static_cast<int>(env.getBody().which())) + ")";
}

}  // namespace cosim::wire
