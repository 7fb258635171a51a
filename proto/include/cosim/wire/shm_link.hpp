#pragma once
// The shared-memory data path between the coupler and a solver on one host.
//
// One file per solver holds two lanes: lane 0 carries requests (the coupler
// writes, the solver reads), lane 1 replies. A lane is an arena of Cap'n Proto
// segments that its writer allocates and builds messages in directly, and a
// queue of descriptors (which segments make up the n-th message). The reader
// maps the same file and reads the segments in place: nothing is copied on
// either side. When the reader lets go of a message it marks its descriptor
// released, and the writer reuses those segments for later messages.
//
// Wake-ups go through a futex word (an event count, Doorbell): the writer
// publishes the descriptor, then rings; a reader that found nothing after a
// bounded spin sleeps on the word. Lane 0's doorbell lives in the solver's
// file; all solvers ring the coupler's one doorbell (CouplerDoorbell), so that
// the coupler sleeps on a single word while it waits for several replies.
//
// A message that does not fit (the arena cannot grow, more segments than a
// descriptor holds, no free descriptor) travels on ZeroMQ as before; its
// descriptor then says "on ZeroMQ" so that the reader keeps the order.
// ZeroMQ keeps everything else: hello, welcome, heartbeats, peers on other
// hosts. Faults stay with the heartbeats and the coupler's watchdog.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "cosim/wire/message.hpp"

namespace cosim::wire {

/// A futex word: rings counts the posts, sleepers the readers asleep on it.
struct Doorbell {
  std::atomic<std::uint32_t> rings{0};
  std::atomic<std::uint32_t> sleepers{0};
};

/// How the coupler decides the data path of a solver (scene key transport.data).
struct ShmOptions {
  enum class Mode { automatic, shm, zmq };
  Mode mode = Mode::automatic;
  std::string directory;                         // where segments are created (the run's shm/)
  std::uint64_t laneBytes = std::uint64_t{1} << 30;  // address space of one lane (the file stays as large as what is held)
  double spinS = 20e-6;                          // busy-wait before sleeping on a doorbell
};

/// One item taken from a lane.
struct LaneItem {
  enum class Kind { message, malformed, onZmq } kind = Kind::message;
  std::optional<InMessage> message;  // kind message
  std::string error;                 // kind malformed: what is wrong
  std::size_t bytes = 0;
};

/// A memory-mapped file with one doorbell, which every solver rings after
/// posting a reply. The coupler creates it; the solvers map it by name.
class CouplerDoorbell {
 public:
  explicit CouplerDoorbell(const std::string& path);
  ~CouplerDoorbell();
  CouplerDoorbell(const CouplerDoorbell&) = delete;
  CouplerDoorbell& operator=(const CouplerDoorbell&) = delete;
  Doorbell& bell() { return *bell_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  Doorbell* bell_ = nullptr;
};

class ShmLink {
 public:
  /// The coupler's end: creates the segment file (it must not exist).
  /// Throws std::runtime_error naming the file and the system's reason.
  static std::shared_ptr<ShmLink> create(const std::string& segment, std::uint64_t laneBytes,
                                         CouplerDoorbell& doorbell);
  /// The solver's end: maps a segment and the coupler's doorbell by name.
  static std::shared_ptr<ShmLink> open(const std::string& segment, const std::string& doorbell);
  ~ShmLink();
  ShmLink(const ShmLink&) = delete;
  ShmLink& operator=(const ShmLink&) = delete;

  /// A message built in this end's outgoing lane (on the heap when it is full).
  OutMessage message(std::size_t firstSegmentWords = 1024);
  /// Publishes a message and rings the reader. True when it travels here;
  /// false when it is not one of this lane's (built elsewhere, or spilled to
  /// the heap, or no free descriptor): the lane then says that it follows on
  /// ZeroMQ, where the caller sends it next.
  bool post(const OutMessage& message);
  /// The next incoming item, if any.
  std::optional<LaneItem> take();
  /// Something is waiting to be taken.
  bool hasIncoming() const;
  /// The doorbell this end sleeps on while waiting for incoming items.
  Doorbell& incomingBell();

  /// Removes the segment's name (the mappings stay): once the solver has
  /// mapped it, nothing is left to clean up on any exit.
  void unlinkFile();
  const std::string& path() const;

  /// The mapped file (layout: shm_layout.hpp) and a lane's arena in it: what
  /// tests and the fuzz target write to play a corrupt other end.
  void* mappedHeader() const;
  capnp::word* arena(unsigned lane) const;

  struct Impl;

 private:
  explicit ShmLink(std::shared_ptr<Impl> impl);
  std::shared_ptr<Impl> impl_;
};

/// Waits up to timeoutS for `ready()`: spins spinS, then sleeps on the bell
/// (rung by every post). Returns ready()'s last answer.
template <typename Ready>
bool waitForDoorbell(Doorbell& bell, double spinS, double timeoutS, Ready&& ready);

/// Rings a doorbell: wakes its sleepers, if any (one system call only then).
void ringDoorbell(Doorbell& bell);
/// Sleeps until the bell no longer shows `seen` or timeoutS passed.
void sleepOnDoorbell(Doorbell& bell, std::uint32_t seen, double timeoutS);
/// Busy-waits up to spinS for ready(); the spin of waitForDoorbell.
bool spinFor(double spinS, const std::function<bool()>& ready);

template <typename Ready>
bool waitForDoorbell(Doorbell& bell, double spinS, double timeoutS, Ready&& ready) {
  if (ready()) return true;
  if (spinS > 0 && spinFor(std::min(spinS, timeoutS), ready)) return true;
  const std::uint32_t seen = bell.rings.load();
  if (ready()) return true;
  sleepOnDoorbell(bell, seen, timeoutS);
  return ready();
}

}  // namespace cosim::wire
