#include "cosim/wire/shm_link.hpp"

#include <fcntl.h>
#include <sched.h>
#include <linux/futex.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <new>
#include <stdexcept>
#include <vector>

#include "cosim/wire/clock.hpp"
#include "cosim/wire/segment_pool.hpp"
#include "cosim/wire/shm_layout.hpp"

namespace cosim::wire {
namespace {

using namespace shm_layout;

constexpr std::size_t kWord = sizeof(capnp::word);
// An arena grows by at least this much at a time (and at least doubles).
constexpr std::uint64_t kMinGrowthWords = (std::uint64_t{1} << 20) / kWord;
// Cap'n Proto addresses a segment with 29-bit word offsets.
constexpr std::size_t kMaxSegmentWords = (std::size_t{1} << 29) - 1;
constexpr std::size_t kMaxFirstSegmentWords = PooledMessageBuilder::kOwnSegmentWords;

std::string systemError(const std::string& what, const std::string& path) {
  return what + " '" + path + "': " + std::strerror(errno);
}

void* mapFile(int fd, std::size_t bytes, const std::string& path) {
  void* p = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (p == MAP_FAILED) throw std::runtime_error(systemError("cannot map", path));
  return p;
}

// The doorbell file: one Doorbell at its start.
constexpr std::size_t kDoorbellBytes = 4096;

long futex(std::atomic<std::uint32_t>* word, int op, std::uint32_t value, const timespec* timeout) {
  return ::syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(word), op, value, timeout, nullptr, 0);
}


struct Extent {
  std::uint64_t offset = 0;  // words from the arena's start
  std::uint64_t words = 0;
  std::uint64_t used = 0;    // words a message wrote (a payload: all)
  bool payload = false;      // overwritten completely: its words are not zero
};

/// Free space of an arena by offset, neighbours merged.
class FreeExtents {
 public:
  void add(std::uint64_t offset, std::uint64_t words) {
    auto next = free_.lower_bound(offset);
    if (next != free_.end() && offset + words == next->first) {
      words += next->second;
      next = free_.erase(next);
    }
    if (next != free_.begin()) {
      auto prev = std::prev(next);
      if (prev->first + prev->second == offset) {
        prev->second += words;
        return;
      }
    }
    free_.emplace(offset, words);
  }
  /// The lowest extent of at least `words`, cut to size.
  std::optional<std::uint64_t> take(std::uint64_t words) {
    for (auto it = free_.begin(); it != free_.end(); ++it) {
      if (it->second < words) continue;
      const std::uint64_t at = it->first, rest = it->second - words;
      free_.erase(it);
      if (rest > 0) free_.emplace(at + words, rest);
      return at;
    }
    return std::nullopt;
  }

 private:
  std::map<std::uint64_t, std::uint64_t> free_;
};

}  // namespace

void ringDoorbell(Doorbell& bell) {
  bell.rings.fetch_add(1);
  if (bell.sleepers.load() > 0) futex(&bell.rings, FUTEX_WAKE, INT_MAX, nullptr);
}

void sleepOnDoorbell(Doorbell& bell, std::uint32_t seen, double timeoutS) {
  if (!(timeoutS > 0)) return;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(timeoutS);
  ts.tv_nsec = static_cast<long>((timeoutS - std::floor(timeoutS)) * 1e9);
  bell.sleepers.fetch_add(1);
  // Returns at once when a post rang after `seen` was read (EAGAIN).
  futex(&bell.rings, FUTEX_WAIT, seen, &ts);
  bell.sleepers.fetch_sub(1);
}

bool spinFor(double spinS, const std::function<bool()>& ready) {
  // Between looks the waiter yields: where the peer it waits for shares its
  // CPU (the scheduler likes to put a woken process beside its waker), the
  // peer runs at once instead of after the spin; with a CPU of its own the
  // yield returns at once.
  const double until = monotonicSeconds() + spinS;
  while (true) {
    if (ready()) return true;
    ::sched_yield();
    if (monotonicSeconds() >= until) return ready();
  }
}

CouplerDoorbell::CouplerDoorbell(const std::string& path) : path_(path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(systemError("cannot create the doorbell", path));
  void* p = nullptr;
  try {
    if (::posix_fallocate(fd, 0, kDoorbellBytes) != 0) throw std::runtime_error("cannot size the doorbell '" + path + "'");
    p = mapFile(fd, kDoorbellBytes, path);
  } catch (...) {
    ::close(fd);
    ::unlink(path.c_str());
    throw;
  }
  ::close(fd);
  bell_ = new (p) Doorbell();
}

CouplerDoorbell::~CouplerDoorbell() {
  ::munmap(bell_, kDoorbellBytes);
  ::unlink(path_.c_str());
}

struct ShmLink::Impl {
  std::string path;
  bool owner = false;  // the coupler's end: unlinks the file
  bool linked = true;
  int fd = -1;
  std::size_t mappedBytes = 0;
  SegmentHeader* header = nullptr;
  std::uint64_t laneWords = 0;
  unsigned out = 0, in = 1;      // lane indices
  Doorbell* outBell = nullptr;   // rung after a post
  Doorbell* inBell = nullptr;    // slept on
  void* doorbellMapping = nullptr;  // the solver's mapping of the coupler's doorbell

  // The writer's bookkeeping of its lane (ZeroMQ's I/O thread may destroy a
  // builder of a spilled message, hence the mutex). Zeroed space is kept
  // apart from space a payload overwrote, so that zeroing happens only where
  // Cap'n Proto's structures need it and a payload reuses a payload's place.
  std::mutex mutex;
  FreeExtents zeroed, dirty;
  std::uint64_t grown = 0;                      // words of the arena backed by the file
  std::vector<Extent> held[kSlots];             // what each posted message occupies
  std::uint64_t posted = 0;                     // == header->lanes[out].posted
  bool cannotGrow = false;

  // The reader's position in the other lane.
  std::uint64_t consumed = 0;
  std::uint64_t inWordsSeen = 0;  // the incoming lane's words the file held when last looked at

  /// Words of the incoming lane the file holds (at least those seen before: it never shrinks).
  std::uint64_t inLaneWordsInFile() {
    if (inWordsSeen == laneWords) return inWordsSeen;
    struct stat st {};
    if (::fstat(fd, &st) != 0) return inWordsSeen;
    const auto start = kHeaderBytes + in * laneWords * kWord;
    const auto size = static_cast<std::uint64_t>(st.st_size);
    inWordsSeen = std::max(inWordsSeen, size <= start ? 0 : std::min(laneWords, (size - start) / kWord));
    return inWordsSeen;
  }

  ~Impl() {
    if (header) ::munmap(header, mappedBytes);
    if (doorbellMapping) ::munmap(doorbellMapping, kDoorbellBytes);
    if (fd >= 0) ::close(fd);
    if (owner && linked) ::unlink(path.c_str());
  }

  LaneHeader& outLane() { return header->lanes[out]; }
  LaneHeader& inLane() { return header->lanes[in]; }
  capnp::word* arena(unsigned lane) {
    return reinterpret_cast<capnp::word*>(reinterpret_cast<char*>(header) + kHeaderBytes) + lane * laneWords;
  }

  capnp::word* outArena() { return arena(out); }

  /// Space a message no longer needs: what it wrote is zeroed again, except
  /// for a payload, which the next payload overwrites anyway.
  void giveBack(const Extent& e) {
    if (e.payload) return dirty.add(e.offset, e.words);
    std::memset(outArena() + e.offset, 0, e.used * kWord);
    zeroed.add(e.offset, e.words);
  }

  /// Takes back what the reader has let go of.
  void reclaim() {
    for (unsigned s = 0; s < kSlots; ++s) {
      if (held[s].empty() || outLane().slots[s].released.load(std::memory_order_acquire) == 0) continue;
      for (const auto& e : held[s]) giveBack(e);
      held[s].clear();
    }
  }

  bool grow(std::uint64_t words) {
    if (cannotGrow) return false;
    std::uint64_t target = std::max({grown + words, 2 * grown, grown + kMinGrowthWords});
    target = std::min(target, laneWords);
    if (target < grown + words) return false;
    const off_t at = static_cast<off_t>(kHeaderBytes + (out * laneWords + grown) * kWord);
    // fallocate never shrinks the file (the other lane's writer grows it too),
    // and a full file system is an error here, not a SIGBUS later.
    if (::posix_fallocate(fd, at, static_cast<off_t>((target - grown) * kWord)) != 0) {
      cannotGrow = true;
      return false;
    }
    zeroed.add(grown, target - grown);
    grown = target;
    outLane().grownWords.store(grown, std::memory_order_release);
    return true;
  }

  /// Words of the lane's arena, zeroed unless for a payload; nullopt when full.
  std::optional<std::uint64_t> allocate(std::uint64_t words, bool payload) {
    std::lock_guard<std::mutex> lock(mutex);
    reclaim();
    if (payload) {
      if (auto at = dirty.take(words)) return at;
      if (auto at = zeroed.take(words)) return at;
    } else {
      if (auto at = zeroed.take(words)) return at;
      if (auto at = dirty.take(words)) {
        std::memset(outArena() + *at, 0, words * kWord);
        return at;
      }
    }
    if (!grow(words)) return std::nullopt;
    return zeroed.take(words);
  }

  void release(const std::vector<Extent>& extents) {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& e : extents) giveBack(e);
  }
};

namespace {

/// A MessageBuilder whose segments come from a lane's arena. A segment the
/// arena cannot give comes from the heap, and the message then travels on ZeroMQ.
class LaneMessageBuilder final : public capnp::MessageBuilder {
 public:
  LaneMessageBuilder(std::shared_ptr<ShmLink::Impl> lane, std::size_t firstSegmentWords)
      : lane_(std::move(lane)), nextWords_(std::clamp<std::size_t>(firstSegmentWords, 64, kMaxFirstSegmentWords)) {}
  ~LaneMessageBuilder() override {
    if (!posted_) lane_->release(extentsAsWritten());
    for (auto* p : heap_) std::free(p);
  }

  kj::ArrayPtr<capnp::word> allocateSegment(unsigned minimumSize) override {
    const bool payload = PooledMessageBuilder::PayloadScope::announces(minimumSize);
    std::size_t words = minimumSize;
    if (!payload) {
      words = std::max<std::size_t>(minimumSize, nextWords_);
      nextWords_ += words;  // grow like Cap'n Proto's own builder
    }
    words = std::min(words, kMaxSegmentWords);
    if (inLane_ && extents_.size() < kMaxSegments) {
      if (auto at = lane_->allocate(words, payload)) {
        extents_.push_back({*at, words, words, payload});
        return {lane_->outArena() + *at, words};
      }
    }
    inLane_ = false;
    void* p = std::calloc(words, kWord);
    if (p == nullptr) throw std::bad_alloc();
    heap_.push_back(p);
    return {static_cast<capnp::word*>(p), words};
  }

  /// The extents with the words Cap'n Proto wrote into each.
  std::vector<Extent> extentsAsWritten() {
    std::vector<Extent> out = extents_;
    const auto segments = getSegmentsForOutput();
    for (auto& e : out) {
      if (e.payload) continue;
      e.used = 0;
      for (const auto& s : segments)
        if (s.begin() == lane_->outArena() + e.offset) e.used = s.size();
    }
    return out;
  }

  const ShmLink::Impl* lane() const { return lane_.get(); }
  bool inLane() const { return inLane_; }
  void markPosted() { posted_ = true; }

 private:
  std::shared_ptr<ShmLink::Impl> lane_;
  std::size_t nextWords_;
  bool inLane_ = true;
  bool posted_ = false;
  std::vector<Extent> extents_;
  std::vector<void*> heap_;
};

}  // namespace

ShmLink::ShmLink(std::shared_ptr<Impl> impl) : impl_(std::move(impl)) {}
ShmLink::~ShmLink() = default;

std::shared_ptr<ShmLink> ShmLink::create(const std::string& segment, std::uint64_t laneBytes,
                                         CouplerDoorbell& doorbell) {
  auto impl = std::make_shared<Impl>();
  impl->path = segment;
  impl->owner = true;
  impl->laneWords = laneBytes / kWord;
  impl->fd = ::open(segment.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (impl->fd < 0) {
    impl->linked = false;
    throw std::runtime_error(systemError("cannot create the shared-memory segment", segment));
  }
  if (::posix_fallocate(impl->fd, 0, kHeaderBytes) != 0)
    throw std::runtime_error("cannot size the shared-memory segment '" + segment + "' (file system full?)");
  impl->mappedBytes = kHeaderBytes + 2 * impl->laneWords * kWord;
  impl->header = static_cast<SegmentHeader*>(mapFile(impl->fd, impl->mappedBytes, segment));
  auto* h = new (impl->header) SegmentHeader();
  h->version = kLayoutVersion;
  h->slots = kSlots;
  h->laneWords = impl->laneWords;
  for (auto& lane : h->lanes)
    for (auto& slot : lane.slots) slot.released.store(1);
  std::atomic_thread_fence(std::memory_order_release);
  std::memcpy(h->magic, kMagic, sizeof(kMagic));
  impl->out = 0;
  impl->in = 1;
  impl->outBell = &h->lanes[0].bell;
  impl->inBell = &doorbell.bell();
  return std::shared_ptr<ShmLink>(new ShmLink(std::move(impl)));
}

std::shared_ptr<ShmLink> ShmLink::open(const std::string& segment, const std::string& doorbell) {
  auto impl = std::make_shared<Impl>();
  impl->path = segment;
  impl->fd = ::open(segment.c_str(), O_RDWR | O_CLOEXEC);
  if (impl->fd < 0) throw std::runtime_error(systemError("cannot open the shared-memory segment", segment));
  struct stat st {};
  if (::fstat(impl->fd, &st) != 0 || static_cast<std::size_t>(st.st_size) < kHeaderBytes)
    throw std::runtime_error("'" + segment + "' is not a shared-memory segment (too short)");
  auto* probe = static_cast<SegmentHeader*>(mapFile(impl->fd, kHeaderBytes, segment));
  const bool valid = std::memcmp(probe->magic, kMagic, sizeof(kMagic)) == 0 && probe->version == kLayoutVersion &&
                     probe->slots == kSlots;
  const std::uint64_t laneWords = probe->laneWords;
  ::munmap(probe, kHeaderBytes);
  if (!valid) throw std::runtime_error("'" + segment + "' is not a shared-memory segment of this layout");
  impl->laneWords = laneWords;
  impl->mappedBytes = kHeaderBytes + 2 * laneWords * kWord;
  impl->header = static_cast<SegmentHeader*>(mapFile(impl->fd, impl->mappedBytes, segment));
  const int bellFd = ::open(doorbell.c_str(), O_RDWR | O_CLOEXEC);
  if (bellFd < 0) throw std::runtime_error(systemError("cannot open the coupler's doorbell", doorbell));
  struct stat bst {};
  try {
    if (::fstat(bellFd, &bst) != 0 || static_cast<std::size_t>(bst.st_size) < kDoorbellBytes)
      throw std::runtime_error("'" + doorbell + "' is not a doorbell (too short)");
    impl->doorbellMapping = mapFile(bellFd, kDoorbellBytes, doorbell);
  } catch (...) {
    ::close(bellFd);
    throw;
  }
  ::close(bellFd);
  impl->out = 1;
  impl->in = 0;
  impl->outBell = static_cast<Doorbell*>(impl->doorbellMapping);
  impl->inBell = &impl->header->lanes[0].bell;
  return std::shared_ptr<ShmLink>(new ShmLink(std::move(impl)));
}

OutMessage ShmLink::message(std::size_t firstSegmentWords) {
  return OutMessage(std::make_shared<LaneMessageBuilder>(impl_, firstSegmentWords));
}

bool ShmLink::post(const OutMessage& message) {
  auto* builder = dynamic_cast<LaneMessageBuilder*>(&message.builder());
  Impl& l = *impl_;
  LaneHeader& lane = l.outLane();
  const unsigned slot = static_cast<unsigned>(l.posted % kSlots);
  Slot& s = lane.slots[slot];
  {
    std::lock_guard<std::mutex> lock(l.mutex);
    l.reclaim();
    if (s.released.load(std::memory_order_acquire) == 0) return false;  // the reader holds kSlots messages: ZeroMQ, unannounced
  }
  const bool here = builder != nullptr && builder->lane() == impl_.get() && builder->inLane();
  s.segmentCount = 0;
  if (here) {
    const auto segments = message.builder().getSegmentsForOutput();
    for (unsigned i = 0; i < segments.size(); ++i) {
      const auto offset = static_cast<std::uint64_t>(segments[i].begin() - l.arena(l.out));
      s.offsets[i] = offset;
      s.words[i] = segments[i].size();
    }
    s.segmentCount = static_cast<std::uint32_t>(segments.size());
    {
      std::lock_guard<std::mutex> lock(l.mutex);
      l.held[slot] = builder->extentsAsWritten();
    }
    builder->markPosted();
  }
  s.released.store(0, std::memory_order_relaxed);
  lane.posted.store(++l.posted, std::memory_order_seq_cst);
  ringDoorbell(*l.outBell);
  return here;
}

bool ShmLink::hasIncoming() const {
  return impl_->inLane().posted.load(std::memory_order_acquire) > impl_->consumed;
}

Doorbell& ShmLink::incomingBell() { return *impl_->inBell; }

std::optional<LaneItem> ShmLink::take() {
  Impl& l = *impl_;
  LaneHeader& lane = l.inLane();
  const std::uint64_t posted = lane.posted.load(std::memory_order_acquire);
  if (posted <= l.consumed) return std::nullopt;
  if (posted - l.consumed > kSlots) {
    const std::uint64_t claimed = posted - l.consumed;
    l.consumed = posted;
    return LaneItem{LaneItem::Kind::malformed, std::nullopt,
                    "the lane claims " + std::to_string(claimed) + " messages at once", 0};
  }
  Slot& s = lane.slots[l.consumed % kSlots];
  ++l.consumed;
  LaneItem item;
  const std::uint32_t count = s.segmentCount;
  if (count == 0) {
    s.released.store(1, std::memory_order_release);
    item.kind = LaneItem::Kind::onZmq;
    return item;
  }
  const std::uint64_t grown = lane.grownWords.load(std::memory_order_acquire);
  std::vector<kj::ArrayPtr<const capnp::word>> segments;
  std::string problem;
  if (count > kMaxSegments) problem = "a descriptor of " + std::to_string(count) + " segments";
  for (std::uint32_t i = 0; problem.empty() && i < count; ++i) {
    const std::uint64_t offset = s.offsets[i], words = s.words[i];
    if (words == 0 || offset > grown || words > grown - offset) {
      problem = "segment " + std::to_string(i) + " (" + std::to_string(words) + " words at " +
                std::to_string(offset) + ") lies outside the lane's " + std::to_string(grown) + " words";
      break;
    }
    // The writer's word is not enough: words beyond the end of the file
    // would be a SIGBUS here, not a malformed message.
    if (offset + words > l.inWordsSeen && offset + words > l.inLaneWordsInFile()) {
      problem = "segment " + std::to_string(i) + " (" + std::to_string(words) + " words at " +
                std::to_string(offset) + ") lies beyond the end of the segment file";
      break;
    }
    segments.emplace_back(l.arena(l.in) + offset, words);
    item.bytes += words * kWord;
  }
  if (!problem.empty()) {
    s.released.store(1, std::memory_order_release);
    item.kind = LaneItem::Kind::malformed;
    item.error = problem;
    return item;
  }
  // The message holds the mapping; letting go of it frees its descriptor.
  std::shared_ptr<void> hold(nullptr, [impl = impl_, &s](void*) { s.released.store(1, std::memory_order_release); });
  try {
    item.message.emplace(InMessage::fromSegments(std::move(segments), std::move(hold)));
  } catch (const MalformedMessage& e) {
    item.kind = LaneItem::Kind::malformed;
    item.error = e.what();
  }
  return item;
}

void ShmLink::unlinkFile() {
  if (impl_->owner && impl_->linked) ::unlink(impl_->path.c_str());
  impl_->linked = false;
}

const std::string& ShmLink::path() const { return impl_->path; }
void* ShmLink::mappedHeader() const { return impl_->header; }
capnp::word* ShmLink::arena(unsigned lane) const { return impl_->arena(lane); }

}  // namespace cosim::wire
