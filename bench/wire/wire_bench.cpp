// wire_bench: round-trip time and throughput of the wire between two real
// processes over real sockets.
//
// The parent binds a ROUTER exactly as the coupler does (RouterSocket on the
// endpoint bindEndpoint gives); a forked child connects a DEALER (DealerSocket)
// and echoes every `advance` request's payload back in an `advanced` reply. One
// round trip is timed from the start of building the request to the decoded
// reply in hand, i.e. everything the coupler pays per exchange except the
// solver's compute: build + copy in, send, the peer's decode + build + copy,
// send back, receive + decode. Payload checks happen outside the timed window.
//
// Children are forked before the parent creates any ZeroMQ context (a context
// does not survive fork); each learns its endpoint through a pipe once the
// parent has bound. A child dies with its parent (PR_SET_PDEATHSIG) and leaves
// on a `shutdown` body; the parent always reaps it.
//
// The shm transport is the shared-memory data path (shm_link.hpp) as the
// coupler and a solver on one host use it: the parent creates the segment and
// the doorbell in a private run directory, the child maps them by name, and
// requests and replies are built in the lanes and read in place.
//
// --experiment heap|floor replaces the table by an A/B comparison measured in
// alternating blocks (see the Experiments comment below): what a change to the
// wire library's memory handling or framing would gain.
#include <malloc.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cosim/util/cpu_affinity.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/endpoint.hpp"
#include "cosim/wire/message.hpp"
#include "cosim/wire/shm_link.hpp"
#include "cosim/wire/sockets.hpp"

namespace {

namespace wire = cosim::wire;
namespace proto = cosim::proto;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Which = proto::Envelope::Body::Which;

constexpr const char* kPeerName = "echo";
constexpr const char* kArrayName = "payload";
// Envelope, Advance(d), CouplingData, the NamedArray list and its name take a
// few dozen words; this margin keeps any payload in the first segment.
constexpr std::size_t kEnvelopeWords = 256;
constexpr auto kPoll = std::chrono::milliseconds(200);
constexpr double kReplyTimeoutS = 60.0;
constexpr double kExitTimeoutS = 10.0;

// Targets of the wire: small-message ipc round trip and bulk throughput; the
// shared-memory path's, against the kernel floor measured in the same run.
constexpr double kSmallIpcMedianUs = 50.0;
constexpr double kBulkGBps = 2.0;
constexpr double kSmallShmFloorFactor = 2.0;
constexpr double kBulkShmGBps = 5.0;
const double kShmSpinS = wire::ShmOptions{}.spinS;  // the scene's default transport.shm_spin_us
constexpr const char* kShmPrefix = "shm:";
constexpr std::size_t kSmallMaxBytes = 1024;
constexpr std::size_t kBulkMinBytes = std::size_t{16} << 20;

struct Case {
  std::size_t bytes;
  int roundTrips;
};

const std::array<Case, 4> kCases = {
    {{0, 2000}, {1024, 2000}, {std::size_t{1} << 20, 200}, {std::size_t{16} << 20, 30}}};
// Streamed requests in flight at once (the peer acknowledges each).
constexpr int kStreamWindow = 4;

/// Where the parent and its echo peer run: where the OS puts them, or both
/// (every thread) on the one CPU the parent is on, as a scene's
/// `placement: {processes: packed}` does.
enum class Placement { spread, packed };

struct Options {
  bool quick = false;
  std::vector<Placement> placements{Placement::spread, Placement::packed};
  bool requireTargets = false;
  std::string experiment;  // instead of the table: "heap" or "floor" (see below)
};

struct Row {
  std::string transport;
  std::size_t bytes = 0;
  int roundTrips = 0;
  double medianUs = 0.0, p10Us = 0.0, p90Us = 0.0;
  double buildUs = 0.0;  // median time to build the request (allocation + payload copy)
  double streamGBps = 0.0;  // one-way payload throughput with requests streamed (0: not measured)
  Placement placement = Placement::spread;
};

double secondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::size_t wordsFor(std::size_t payloadBytes) { return payloadBytes / 8 + kEnvelopeWords; }

// Experiments (--experiment heap|floor) compare two ways of doing a round trip
// in alternating blocks, so that both see the same machine load. What the peer
// is to do travels in Advance.steps.
//
// heap: glibc serves a large buffer from fresh mmap pages, and every 4 KiB of it
// costs a page fault (the kernel zeroes it) on first touch, on both sides, for
// every message; buffers kept on the heap cost a memset in calloc but no faults.
// glibc raises its mmap threshold to the size of a freed mmap'd buffer, so by
// default repeated 16 MiB messages mostly reuse heap memory; but the raise stops
// at 32 MiB (DEFAULT_MMAP_THRESHOLD_MAX): for a 64 MiB message the default IS
// fresh pages.
//
// floor: the wire's round trip against raw ZeroMQ frames of the same payload
// (sent zero-copy from the caller's buffer, echoed as received): the difference
// is what Cap'n Proto building, copying and decoding cost on top of ZeroMQ.
constexpr std::size_t kBeyondDynamicBytes = std::size_t{64} << 20;
enum class PeerMode : std::uint32_t { unchanged = 1, freshPages = 2, keptOnHeap = 3, rawNext = 4, sink = 5 };

void applyHeapMode(PeerMode mode) {
  if (mode != PeerMode::freshPages && mode != PeerMode::keptOnHeap) return;
  const bool keep = mode == PeerMode::keptOnHeap;
  // 128 KiB is glibc's start value for both thresholds.
  const int mmapThreshold = keep ? (256 << 20) : (128 << 10);
  const int trimThreshold = keep ? (1 << 30) : (128 << 10);
  if (::mallopt(M_MMAP_THRESHOLD, mmapThreshold) != 1 || ::mallopt(M_TRIM_THRESHOLD, trimThreshold) != 1)
    throw std::runtime_error("mallopt failed");
}

// ---------------------------------------------------------------- echo peer

std::string readLine(int fd) {
  std::string text;
  char c = 0;
  while (::read(fd, &c, 1) == 1 && c != '\n') text.push_back(c);
  return text;  // empty: the parent closed the pipe without a run for us
}

/// The acknowledgement of a streamed request: its first and last value and
/// its length, which the sender checks.
using MessageFactory = std::function<wire::OutMessage(std::size_t words)>;

wire::OutMessage heapMessage(std::size_t words) { return wire::OutMessage(words); }

wire::OutMessage sinkReply(proto::Envelope::Reader request, const MessageFactory& make) {
  wire::OutMessage reply = make(64);
  auto env = reply.envelope();
  env.setSeq(request.getSeq());
  env.setReplyTo(request.getSeq());
  auto advanced = env.getBody().initAdvanced();
  const auto inputs = request.getBody().getAdvance().getInputs().getArrays();
  const auto values = inputs.size() == 1 ? wire::view(inputs[0].getValues()) : std::span<const double>();
  const double summary[3] = {values.empty() ? 0.0 : values.front(), values.empty() ? 0.0 : values.back(),
                             static_cast<double>(values.size())};
  wire::addArray(advanced.initOutputs().initArrays(1), 0, kArrayName, 1, summary);
  return reply;
}

/// The `advanced` reply: the request's arrays copied back as outputs.
wire::OutMessage echoReply(proto::Envelope::Reader request, std::size_t requestBytes, const MessageFactory& make) {
  wire::OutMessage reply = make(wordsFor(requestBytes));
  auto env = reply.envelope();
  env.setSeq(request.getSeq());
  env.setReplyTo(request.getSeq());
  const auto advance = request.getBody().getAdvance();
  auto advanced = env.getBody().initAdvanced();
  advanced.setTime(advance.getTime() + advance.getDt() * advance.getSteps());
  advanced.setStep(advance.getExchange());
  const auto inputs = advance.getInputs().getArrays();
  auto outputs = advanced.initOutputs().initArrays(inputs.size());
  for (unsigned i = 0; i < inputs.size(); ++i) {
    const auto name = inputs[i].getName();
    wire::addArray(outputs, i, std::string_view(name.cStr(), name.size()), inputs[i].getComponents(),
                   wire::view(inputs[i].getValues()));
  }
  return reply;
}

wire::OutMessage bodyOnly(Which which, std::uint64_t replyTo, const MessageFactory& make = heapMessage) {
  wire::OutMessage m = make(64);
  auto env = m.envelope();
  env.setReplyTo(replyTo);
  if (which == Which::HELLO) {
    auto hello = env.getBody().initHello();
    hello.setInstance(kPeerName);
    hello.setSolverKind("echo");
    hello.setPid(static_cast<std::uint32_t>(::getpid()));
  } else {
    env.getBody().setShutdownDone();
  }
  return m;
}

/// Echoes one raw multipart message as received (ZeroMQ sends the frames it
/// allocated on receipt, without another copy).
void echoRaw(zmq::socket_t& socket) {
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  if (zmq::poll(&item, 1, std::chrono::milliseconds(static_cast<int>(kReplyTimeoutS * 1000))) <= 0)
    throw std::runtime_error("echo peer: no raw message for 60 s");
  auto frames = wire::receiveMultipart(socket);
  for (std::size_t i = 0; i < frames.size(); ++i)
    if (!socket.send(frames[i], i + 1 < frames.size() ? zmq::send_flags::sndmore : zmq::send_flags::none))
      throw std::runtime_error("echo peer: raw send timed out");
}

/// What the echo peer does with one request: its reply, or nullopt for
/// shutdown (answered). Throws on a request the peer has no answer for.
std::optional<wire::OutMessage> answer(const wire::InMessage& in, const MessageFactory& make) {
  const auto env = in.envelope();
  const auto which = env.getBody().which();
  if (which == Which::SHUTDOWN) return std::nullopt;
  if (which != Which::ADVANCE) throw std::runtime_error("echo peer: unexpected body '" + wire::bodyName(env) + "'");
  const auto steps = env.getBody().getAdvance().getSteps();
  if (steps < 1 || steps > 5) throw std::runtime_error("echo peer: steps " + std::to_string(steps) + " is no mode");
  const auto mode = static_cast<PeerMode>(steps);
  applyHeapMode(mode);
  if (mode == PeerMode::sink) return sinkReply(env, make);
  return echoReply(env, in.sizeInBytes(), make);
}

/// Echoes requests through a shared-memory link ("shm:SEGMENT DOORBELL") until `shutdown`.
int serveEchoShared(const std::string& line) {
  const auto space = line.find(' ');
  auto link = wire::ShmLink::open(line.substr(std::strlen(kShmPrefix), space - std::strlen(kShmPrefix)),
                                  line.substr(space + 1));
  const MessageFactory make = [&link](std::size_t words) { return link->message(words); };
  for (;;) {
    if (!wire::waitForDoorbell(link->incomingBell(), kShmSpinS, kReplyTimeoutS, [&] { return link->hasIncoming(); }))
      throw std::runtime_error("echo peer: nothing from the parent for 60 s");
    auto item = link->take();
    if (item->kind != wire::LaneItem::Kind::message) throw std::runtime_error("echo peer: no message in the lane");
    auto reply = answer(*item->message, make);
    const std::uint64_t seq = item->message->envelope().getSeq();
    item.reset();  // let go of the request before answering, as a solver does
    const bool done = !reply;
    if (!link->post(done ? bodyOnly(Which::SHUTDOWN_DONE, seq, make) : *reply))
      throw std::runtime_error("echo peer: a reply did not fit the shared-memory lane");
    if (done) return 0;
  }
}

/// Echoes requests until `shutdown`; 0 on a clean exit.
int serveEcho(const std::string& endpoint) {
  if (endpoint.rfind(kShmPrefix, 0) == 0) return serveEchoShared(endpoint);
  {
    wire::DealerSocket dealer(endpoint, kPeerName);
    dealer.send(bodyOnly(Which::HELLO, 0));  // lets the ROUTER learn our routing id
    for (;;) {
      auto received = dealer.receive(std::chrono::milliseconds(static_cast<int>(kReplyTimeoutS * 1000)));
      if (!received) throw std::runtime_error("echo peer: nothing from the parent for 60 s");
      if (!received->message) throw std::runtime_error("echo peer: malformed request: " + received->error);
      const auto env = received->message->envelope();
      auto reply = answer(*received->message, heapMessage);
      if (!reply) {
        dealer.send(bodyOnly(Which::SHUTDOWN_DONE, env.getSeq()));
        break;
      }
      dealer.send(*reply);
      if (static_cast<PeerMode>(env.getBody().getAdvance().getSteps()) == PeerMode::rawNext) echoRaw(dealer.raw());
    }
  }  // the DEALER closes here; terminating the context waits for the last reply to leave
  wire::context().close();
  return 0;
}

/// The child's whole life. Never returns.
[[noreturn]] void childMain(pid_t parent, int readFd) {
  // Die with the parent; if it is already gone, the signal would never come.
  if (::prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || ::getppid() != parent) ::_exit(3);
  int rc = 1;
  try {
    const std::string endpoint = readLine(readFd);
    rc = endpoint.empty() ? 0 : serveEcho(endpoint);
  } catch (const std::exception& e) {
    std::cerr << "wire_bench: echo peer " << ::getpid() << ": " << e.what() << "\n";
  }
  // _exit: no static destructors or stdio flushes duplicated from the parent.
  ::_exit(rc);
}

// ---------------------------------------------------------- child handling

/// A forked echo peer; killed and reaped if still running when destroyed.
class EchoChild {
 public:
  /// Forks now. closeInChild: descriptors of earlier children's pipes, which
  /// this child must not keep open.
  static EchoChild fork(const std::vector<int>& closeInChild) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
    std::cout.flush();
    std::fflush(nullptr);
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
    if (pid == 0) {
      ::close(fds[1]);
      for (int fd : closeInChild) ::close(fd);
      childMain(parent, fds[0]);
    }
    ::close(fds[0]);
    return EchoChild(pid, fds[1]);
  }

  EchoChild(EchoChild&& o) noexcept : pid_(o.pid_), writeFd_(o.writeFd_) {
    o.pid_ = -1;
    o.writeFd_ = -1;
  }
  EchoChild& operator=(EchoChild&&) = delete;
  EchoChild(const EchoChild&) = delete;
  EchoChild& operator=(const EchoChild&) = delete;
  ~EchoChild() {
    closePipe();
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }

  int writeFd() const { return writeFd_; }
  pid_t pid() const { return pid_; }

  void sendEndpoint(const std::string& endpoint) {
    const std::string line = endpoint + "\n";
    if (::write(writeFd_, line.data(), line.size()) != static_cast<ssize_t>(line.size())) {
      checkAlive();  // the likely reason, with the child's exit status
      throw std::runtime_error(std::string("cannot pass the endpoint to the echo peer: ") + std::strerror(errno));
    }
    closePipe();
  }

  /// Throws when the child has exited (it must only leave on shutdown).
  void checkAlive() {
    int status = 0;
    if (pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("echo peer died early (" + describe(status) + ")");
    }
  }

  /// Waits for a clean exit; kills the child and throws after the timeout.
  void reap(double timeoutS) {
    const auto t0 = Clock::now();
    int status = 0;
    while (::waitpid(pid_, &status, WNOHANG) == 0) {
      if (secondsSince(t0) > timeoutS)
        throw std::runtime_error("echo peer did not exit within " + std::to_string(timeoutS) + " s");
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    pid_ = -1;
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw std::runtime_error("echo peer ended badly (" + describe(status) + ")");
  }

 private:
  EchoChild(pid_t pid, int writeFd) : pid_(pid), writeFd_(writeFd) {}
  void closePipe() {
    if (writeFd_ >= 0) ::close(writeFd_);
    writeFd_ = -1;
  }
  static std::string describe(int status) {
    if (WIFEXITED(status)) return "exit code " + std::to_string(WEXITSTATUS(status));
    if (WIFSIGNALED(status)) return "signal " + std::to_string(WTERMSIG(status));
    return "status " + std::to_string(status);
  }

  pid_t pid_;
  int writeFd_;
};

// ------------------------------------------------------------- the parent

/// The next message from the echo peer; throws on timeout, garbage or a dead child.
wire::InMessage awaitMessage(wire::RouterSocket& router, EchoChild& child) {
  const auto t0 = Clock::now();
  for (;;) {
    if (auto r = router.receive(kPoll)) {
      if (!r->message) throw std::runtime_error("malformed message from the echo peer: " + r->error);
      if (r->identity != kPeerName) throw std::runtime_error("message from unknown peer '" + r->identity + "'");
      return std::move(*r->message);
    }
    child.checkAlive();
    if (secondsSince(t0) > kReplyTimeoutS) throw std::runtime_error("no reply from the echo peer for 60 s");
  }
}

void send(wire::RouterSocket& router, const wire::OutMessage& message) {
  if (!router.send(kPeerName, message)) throw std::runtime_error("echo peer not connected");
}

/// The parent's end of one transport: where a request is built, how it is
/// sent, how the reply comes back.
struct Channel {
  MessageFactory message;
  std::function<void(const wire::OutMessage&)> send;
  std::function<wire::InMessage()> await;
};

Channel socketChannel(wire::RouterSocket& router, EchoChild& child) {
  return {heapMessage, [&router](const wire::OutMessage& m) { send(router, m); },
          [&router, &child] { return awaitMessage(router, child); }};
}

/// The next item of a shared-memory lane; throws on timeout, garbage or a dead child.
wire::InMessage awaitShared(wire::ShmLink& link, EchoChild& child) {
  const auto t0 = Clock::now();
  for (;;) {
    const double waitS = std::chrono::duration<double>(kPoll).count();
    if (wire::waitForDoorbell(link.incomingBell(), kShmSpinS, waitS, [&] { return link.hasIncoming(); })) {
      auto item = link.take();
      if (item->kind != wire::LaneItem::Kind::message)
        throw std::runtime_error("the echo peer's lane holds no message: " + item->error);
      return std::move(*item->message);
    }
    child.checkAlive();
    if (secondsSince(t0) > kReplyTimeoutS) throw std::runtime_error("no reply from the echo peer for 60 s");
  }
}

Channel sharedChannel(wire::ShmLink& link, EchoChild& child) {
  return {[&link](std::size_t words) { return link.message(words); },
          [&link](const wire::OutMessage& m) {
            if (!link.post(m)) throw std::runtime_error("a request did not fit the shared-memory lane");
          },
          [&link, &child] { return awaitShared(link, child); }};
}

wire::OutMessage advanceRequest(Channel& channel, std::uint64_t seq, std::span<const double> payload, PeerMode mode) {
  wire::OutMessage m = channel.message(wordsFor(payload.size_bytes()));
  auto env = m.envelope();
  env.setSeq(seq);
  auto advance = env.getBody().initAdvance();
  advance.setSteps(static_cast<std::uint32_t>(mode));
  advance.setDt(1e-6);
  advance.setTime(1e-6 * static_cast<double>(seq));
  advance.setExchange(seq);
  wire::addArray(advance.initInputs().initArrays(1), 0, kArrayName, 1, payload);
  return m;
}

void checkEcho(const wire::InMessage& reply, std::uint64_t seq, std::span<const double> payload) {
  const auto env = reply.envelope();
  if (env.getBody().which() != Which::ADVANCED)
    throw std::runtime_error("expected 'advanced', got '" + wire::bodyName(env) + "'");
  if (env.getReplyTo() != seq)
    throw std::runtime_error("reply to " + std::to_string(env.getReplyTo()) + ", expected " + std::to_string(seq));
  const auto arrays = env.getBody().getAdvanced().getOutputs().getArrays();
  if (arrays.size() != 1 || arrays[0].getName() != kArrayName)
    throw std::runtime_error("reply lacks the echoed array");
  const auto values = wire::view(arrays[0].getValues());
  if (values.size() != payload.size() ||
      (!payload.empty() && std::memcmp(values.data(), payload.data(), payload.size_bytes()) != 0))
    throw std::runtime_error("echoed payload differs from the one sent (seq " + std::to_string(seq) + ")");
}

/// Linear interpolation between order statistics; sorted must be sorted.
double percentile(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const auto lo = static_cast<std::size_t>(pos);
  const auto hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (pos - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

std::vector<double> makePayload(std::size_t bytes) {
  std::vector<double> payload(bytes / sizeof(double));
  for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = 0.5 * static_cast<double>(i) + 0.25;
  return payload;
}

/// Round-trip and request-building times of one sample set, in microseconds.
struct Samples {
  std::vector<double> rttUs, buildUs;
  void sort() {
    std::sort(rttUs.begin(), rttUs.end());
    std::sort(buildUs.begin(), buildUs.end());
  }
};

/// One checked round trip; its times are added to `into` when given.
void roundTrip(Channel& channel, std::uint64_t& seq, std::vector<double>& payload, PeerMode mode, Samples* into) {
  ++seq;
  if (!payload.empty()) payload[0] = static_cast<double>(seq);  // every payload distinct
  const auto t0 = Clock::now();
  auto request = advanceRequest(channel, seq, payload, mode);
  const auto t1 = Clock::now();
  channel.send(request);
  const auto reply = channel.await();
  const auto t2 = Clock::now();
  checkEcho(reply, seq, payload);
  if (!into) return;
  into->rttUs.push_back(std::chrono::duration<double, std::micro>(t2 - t0).count());
  into->buildUs.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
}

/// Warm-up, then `count` timed round trips of `bytes` payload.
Row measure(Channel& channel, const std::string& transport, std::size_t bytes, int count, std::uint64_t& seq) {
  auto payload = makePayload(bytes);
  const int warmup = std::max(2, count / 10);
  for (int i = 0; i < warmup; ++i) roundTrip(channel, seq, payload, PeerMode::unchanged, nullptr);
  Samples s;
  for (int i = 0; i < count; ++i) roundTrip(channel, seq, payload, PeerMode::unchanged, &s);
  s.sort();
  return {transport,
          bytes,
          count,
          percentile(s.rttUs, 0.5),
          percentile(s.rttUs, 0.1),
          percentile(s.rttUs, 0.9),
          percentile(s.buildUs, 0.5)};
}

/// Streaming throughput, the way ZeroMQ's own local_thr/remote_thr measure it:
/// `count` requests of `bytes` built and sent back to back with up to
/// kStreamWindow unacknowledged; the peer decodes each one and acknowledges it
/// with its first and last value and length (checked). Timed from the first
/// build to the last acknowledgement; one-way payload GB/s.
double streamGBps(Channel& channel, std::uint64_t& seq, std::size_t bytes, int count) {
  auto payload = makePayload(bytes);
  std::vector<std::uint64_t> inFlight;
  auto acknowledge = [&]() {
    const auto reply = channel.await();
    const auto env = reply.envelope();
    if (inFlight.empty() || env.getReplyTo() != inFlight.front())
      throw std::runtime_error("stream: acknowledgement out of order (" + std::to_string(env.getReplyTo()) + ")");
    const auto summary = wire::view(env.getBody().getAdvanced().getOutputs().getArrays()[0].getValues());
    const double first = static_cast<double>(inFlight.front());
    if (summary.size() != 3 || summary[0] != first || summary[1] != payload.back() ||
        summary[2] != static_cast<double>(payload.size()))
      throw std::runtime_error("stream: the peer did not see the payload that was sent");
    inFlight.erase(inFlight.begin());
  };
  const auto t0 = Clock::now();
  for (int i = 0; i < count; ++i) {
    if (static_cast<int>(inFlight.size()) == kStreamWindow) acknowledge();
    payload[0] = static_cast<double>(++seq);
    channel.send(advanceRequest(channel, seq, payload, PeerMode::sink));
    inFlight.push_back(seq);
  }
  while (!inFlight.empty()) acknowledge();
  return static_cast<double>(bytes) * count / secondsSince(t0) / 1e9;
}

/// A raw round trip: [identity][payload], the payload frame pointing into
/// `payload` (no copy, no free: it outlives the send, which completes before
/// the echo can arrive). The peer is told first, untimed.
void rawRoundTrip(wire::RouterSocket& router, EchoChild& child, std::uint64_t& seq, std::vector<double>& payload,
                  Samples* into) {
  std::vector<double> none;
  auto channel = socketChannel(router, child);
  roundTrip(channel, seq, none, PeerMode::rawNext, nullptr);
  if (!payload.empty()) payload[0] = static_cast<double>(seq) + 0.5;
  auto& socket = router.raw();
  const auto t0 = Clock::now();
  zmq::message_t id(kPeerName, std::strlen(kPeerName));
  zmq::message_t body(payload.data(), payload.size() * sizeof(double), nullptr, nullptr);
  if (!socket.send(id, zmq::send_flags::sndmore) || !socket.send(body, zmq::send_flags::none))
    throw std::runtime_error("raw send timed out");
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  while (zmq::poll(&item, 1, kPoll) <= 0) child.checkAlive();
  const auto frames = wire::receiveMultipart(socket);
  const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
  if (frames.size() != 2 || frames[1].size() != payload.size() * sizeof(double) ||
      (!payload.empty() && std::memcmp(frames[1].data(), payload.data(), frames[1].size()) != 0))
    throw std::runtime_error("raw echo differs from what was sent");
  if (!into) return;
  into->rttUs.push_back(us);
  into->buildUs.push_back(0.0);  // nothing to build
}

/// One way of doing a round trip; `trip` records into its Samples when given.
struct Arm {
  std::string label;
  std::function<void(std::uint64_t& seq, std::vector<double>& payload, Samples* into)> trip;
};

std::vector<Arm> experimentArms(const std::string& name, wire::RouterSocket& router, EchoChild& child) {
  auto wireTrip = [&router, &child](PeerMode mode) {
    return [&router, &child, mode](std::uint64_t& seq, std::vector<double>& payload, Samples* into) {
      applyHeapMode(mode);
      auto channel = socketChannel(router, child);
      roundTrip(channel, seq, payload, mode, into);
    };
  };
  if (name == "heap") return {{"fresh", wireTrip(PeerMode::freshPages)}, {"kept", wireTrip(PeerMode::keptOnHeap)}};
  return {{"wire", wireTrip(PeerMode::unchanged)},
          {"raw", [&router, &child](std::uint64_t& seq, std::vector<double>& payload, Samples* into) {
             rawRoundTrip(router, child, seq, payload, into);
           }}};
}

/// One row per arm for one payload size, the arms alternating in blocks. A
/// block's first round trip is not counted: the peer allocated its receive
/// buffer under the previous arm's mode.
std::vector<Row> measureArms(const std::vector<Arm>& arms, const std::string& transport, std::size_t bytes,
                             int blocks, std::uint64_t& seq) {
  constexpr int kBlock = 4;
  auto payload = makePayload(bytes);
  std::vector<Samples> s(arms.size());
  for (int b = 0; b < blocks * static_cast<int>(arms.size()); ++b) {
    const auto a = static_cast<std::size_t>(b) % arms.size();
    for (int i = 0; i < kBlock; ++i) arms[a].trip(seq, payload, i == 0 ? nullptr : &s[a]);
  }
  std::vector<Row> rows;
  for (std::size_t a = 0; a < arms.size(); ++a) {
    s[a].sort();
    rows.push_back({transport + " " + arms[a].label, bytes, static_cast<int>(s[a].rttUs.size()),
                    percentile(s[a].rttUs, 0.5), percentile(s[a].rttUs, 0.1), percentile(s[a].rttUs, 0.9),
                    percentile(s[a].buildUs, 0.5)});
  }
  return rows;
}

void shutdownPeer(Channel& channel, EchoChild& child, std::uint64_t seq) {
  wire::OutMessage m = channel.message(64);
  auto env = m.envelope();
  env.setSeq(seq);
  env.getBody().initShutdown().setReason("benchmark finished");
  channel.send(m);
  const auto reply = channel.await();
  if (reply.envelope().getBody().which() != Which::SHUTDOWN_DONE)
    throw std::runtime_error("expected 'shutdownDone', got '" + wire::bodyName(reply.envelope()) + "'");
  child.reap(kExitTimeoutS);
}

/// A private directory for the ipc socket, removed on destruction.
class TempRunDir {
 public:
  TempRunDir() {
    std::string dir = (fs::temp_directory_path() / "wire-bench-XXXXXX").string();
    if (::mkdtemp(dir.data()) == nullptr) throw std::runtime_error("mkdtemp for the run directory failed");
    path_ = dir;
  }
  ~TempRunDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempRunDir(const TempRunDir&) = delete;
  TempRunDir& operator=(const TempRunDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

/// The table's rows for one transport, or the experiment's.
std::vector<Row> runCases(Channel& channel, const std::string& transport, const Options& options,
                          std::uint64_t& seq) {
  std::vector<Row> rows;
  for (const auto& c : kCases) {
    const int count = options.quick ? std::max(1, c.roundTrips / 10) : c.roundTrips;
    rows.push_back(measure(channel, transport, c.bytes, count, seq));
    if (c.bytes > 0) {
      (void)streamGBps(channel, seq, c.bytes, kStreamWindow);  // warm-up
      rows.back().streamGBps = streamGBps(channel, seq, c.bytes, 2 * count);
    }
  }
  return rows;
}

/// The experiment's rows for one transport (sockets only).
std::vector<Row> runExperiment(wire::RouterSocket& router, EchoChild& child, const std::string& transport,
                               const Options& options, std::uint64_t& seq) {
  std::vector<Row> rows;
  for (const auto& c : kCases) {
    const int count = options.quick ? std::max(1, c.roundTrips / 10) : c.roundTrips;
    if (options.experiment == "floor" || c.bytes >= (std::size_t{1} << 20)) {  // heap: only large buffers differ
      const auto ab = measureArms(experimentArms(options.experiment, router, child), transport, c.bytes,
                                  std::max(2, count / 4), seq);
      rows.insert(rows.end(), ab.begin(), ab.end());
    }
  }
  if (options.experiment == "heap") {  // beyond glibc's 32 MiB cap the default is fresh pages
    const auto ab = measureArms(experimentArms(options.experiment, router, child), transport, kBeyondDynamicBytes,
                                options.quick ? 2 : 4, seq);
    rows.insert(rows.end(), ab.begin(), ab.end());
  }
  return rows;
}

std::vector<Row> runTransport(wire::TransportOptions::Kind kind, EchoChild& child, const Options& options,
                              Placement placement) {
  const std::string transport = kind == wire::TransportOptions::Kind::ipc ? "ipc" : "tcp";
  // Packed: this process is already on its one CPU (main). The peer's main
  // thread follows before it learns the endpoint, so the I/O thread its
  // ZeroMQ context starts then inherits the CPU.
  if (placement == Placement::packed) cosim::util::restrictThreadsOf(child.pid(), cosim::util::allowedCpus());
  TempRunDir runDir;
  wire::TransportOptions t;
  t.kind = kind;
  std::vector<Row> rows;
  {
    wire::RouterSocket router(wire::bindEndpoint(t, runDir.path()));
    child.sendEndpoint(wire::connectableEndpoint(router.endpoint()));
    const auto hello = awaitMessage(router, child);
    if (hello.envelope().getBody().which() != Which::HELLO)
      throw std::runtime_error("expected 'hello', got '" + wire::bodyName(hello.envelope()) + "'");
    std::uint64_t seq = 0;
    auto channel = socketChannel(router, child);
    rows = options.experiment.empty() ? runCases(channel, transport, options, seq)
                                      : runExperiment(router, child, transport, options, seq);
    for (auto& r : rows) r.placement = placement;
    shutdownPeer(channel, child, ++seq);
    wire::removeIpcEndpoint(router.endpoint());
  }
  return rows;
}

/// The shared-memory rows: the segment and doorbell as the coupler creates them.
std::vector<Row> runShared(EchoChild& child, const Options& options, Placement placement) {
  if (placement == Placement::packed) cosim::util::restrictThreadsOf(child.pid(), cosim::util::allowedCpus());
  TempRunDir runDir;
  std::vector<Row> rows;
  {
    wire::CouplerDoorbell doorbell((runDir.path() / "doorbell").string());
    auto link = wire::ShmLink::create((runDir.path() / kPeerName).string(), wire::ShmOptions{}.laneBytes, doorbell);
    child.sendEndpoint(kShmPrefix + link->path() + " " + doorbell.path());
    std::uint64_t seq = 0;
    auto channel = sharedChannel(*link, child);
    rows = runCases(channel, "shm", options, seq);
    for (auto& r : rows) r.placement = placement;
    shutdownPeer(channel, child, ++seq);
  }
  return rows;
}

/// The kernel's own floor for a small round trip between two processes: an
/// 8-byte ping-pong over a Unix socketpair, no ZeroMQ. On a VM an idle vCPU
/// halts, and waking it costs more than the wire's own work; this says how
/// much of a small round trip is that. Median microseconds.
double socketpairFloorUs(int trips) {
  int sv[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0) throw std::runtime_error("socketpair failed");
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  char byte[8] = {};
  if (pid == 0) {  // no ZeroMQ here: read/write and _exit only
    ::close(sv[0]);
    while (::read(sv[1], byte, sizeof byte) == static_cast<ssize_t>(sizeof byte))
      if (::write(sv[1], byte, sizeof byte) != static_cast<ssize_t>(sizeof byte)) break;
    ::_exit(0);
  }
  ::close(sv[1]);
  std::vector<double> us;
  for (int i = 0; i < trips; ++i) {
    const auto t0 = Clock::now();
    if (::write(sv[0], byte, sizeof byte) != static_cast<ssize_t>(sizeof byte) ||
        ::read(sv[0], byte, sizeof byte) != static_cast<ssize_t>(sizeof byte))
      break;
    us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  ::close(sv[0]);
  ::waitpid(pid, nullptr, 0);
  if (us.empty()) throw std::runtime_error("socketpair ping-pong failed");
  std::sort(us.begin(), us.end());
  return percentile(us, 0.5);
}

// ------------------------------------------------------------------ report

std::string sizeLabel(std::size_t bytes) {
  if (bytes == 0) return "0 B";
  if (bytes % (std::size_t{1} << 20) == 0) return std::to_string(bytes >> 20) + " MiB";
  if (bytes % 1024 == 0) return std::to_string(bytes >> 10) + " KiB";
  return std::to_string(bytes) + " B";
}

double gbps(const Row& r) { return 2.0 * static_cast<double>(r.bytes) / (r.medianUs * 1e-6) / 1e9; }

/// The row's target as text and whether it is met; empty text when none applies.
std::string placementName(Placement p) { return p == Placement::packed ? "packed" : "spread"; }

/// The row's target as text and whether it is met; empty text when none
/// applies. Both targets are judged on ipc, the default transport; tcp rows
/// are printed for comparison.
std::pair<std::string, bool> target(const Row& r, double floorUs) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  if (r.transport == "shm") {
    if (r.bytes <= kSmallMaxBytes) {
      s << "median <= " << kSmallShmFloorFactor << " x floor (" << kSmallShmFloorFactor * floorUs << " us)";
      return {s.str(), r.medianUs <= kSmallShmFloorFactor * floorUs};
    }
    if (r.bytes >= kBulkMinBytes) {
      s << ">= " << kBulkShmGBps << " GB/s";
      return {s.str(), gbps(r) >= kBulkShmGBps};
    }
    return {"", true};
  }
  if (r.transport != "ipc") return {"", true};  // tcp and experiment arms are not judged
  if (r.bytes <= kSmallMaxBytes) {
    s << "median <= " << kSmallIpcMedianUs << " us";
    return {s.str(), r.medianUs <= kSmallIpcMedianUs};
  }
  if (r.bytes >= kBulkMinBytes) {
    s << ">= " << kBulkGBps << " GB/s";
    return {s.str(), gbps(r) >= kBulkGBps};
  }
  return {"", true};
}

std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

/// Prints the table; returns, per placement measured, whether its rows meet every target.
std::map<Placement, bool> printTable(const std::vector<Row>& rows, const std::map<Placement, double>& floorUs) {
  std::map<Placement, bool> allMet;
  std::cout << std::left << std::setw(10) << "transport" << std::setw(10) << "placement" << std::right
            << std::setw(9) << "payload" << std::setw(8) << "trips" << std::setw(12) << "median us" << std::setw(11)
            << "p10 us" << std::setw(11) << "p90 us" << std::setw(10) << "GB/s" << std::setw(10) << "build us"
            << std::setw(12) << "stream GB/s" << "   target\n";
  for (const auto& r : rows) {
    const auto [what, met] = target(r, floorUs.at(r.placement));
    std::ostringstream tp;
    if (r.bytes > 0) tp << std::fixed << std::setprecision(3) << gbps(r);
    else tp << "-";
    std::cout << std::left << std::setw(10) << r.transport << std::setw(10) << placementName(r.placement)
              << std::right << std::setw(9) << sizeLabel(r.bytes) << std::setw(8) << r.roundTrips << std::fixed
              << std::setprecision(1) << std::setw(12) << r.medianUs << std::setw(11) << r.p10Us << std::setw(11)
              << r.p90Us << std::setw(10) << tp.str() << std::setw(10) << r.buildUs;
    std::ostringstream st;
    if (r.streamGBps > 0) st << std::fixed << std::setprecision(3) << r.streamGBps;
    else st << "-";
    std::cout << std::setw(12) << st.str();
    if (!what.empty()) std::cout << "   " << what << ": " << (met ? "met" : "MISSED");
    std::cout << "\n";
    allMet.try_emplace(r.placement, true);
    allMet[r.placement] = allMet[r.placement] && met;
  }
  return allMet;
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") o.quick = true;
    else if (a == "--require-targets") o.requireTargets = true;
    else if (a == "--placement" && i + 1 < argc) {
      const std::string p = argv[++i];
      if (p == "spread") o.placements = {Placement::spread};
      else if (p == "packed") o.placements = {Placement::packed};
      else if (p == "both") o.placements = {Placement::spread, Placement::packed};
      else throw std::invalid_argument("--placement takes 'spread', 'packed' or 'both', not '" + p + "'");
    }
    else if (a == "--experiment" && i + 1 < argc) {
      o.experiment = argv[++i];
      if (o.experiment != "heap" && o.experiment != "floor")
        throw std::invalid_argument("--experiment takes 'heap' or 'floor', not '" + o.experiment + "'");
    }
    else if (a == "--help" || a == "-h") {
      std::cout << "usage: wire_bench [--quick] [--require-targets] [--placement spread|packed|both]\n"
                   "                  [--experiment heap|floor]\n"
                   "  --quick            a tenth of the round trips\n"
                   "  --require-targets  exit 2 unless one placement meets every target\n"
                   "  --placement P      spread: where the OS puts the processes; packed: the parent\n"
                   "                     and its peer (all threads) on one CPU, as a scene's\n"
                   "                     `placement: {processes: packed}`; both (default): one after\n"
                   "                     the other\n"
                   "  --experiment heap  instead of the table, interleaved in blocks: large buffers\n"
                   "                     on fresh pages (glibc's start thresholds) against buffers\n"
                   "                     kept on the heap (mallopt), 1, 16 and 64 MiB\n"
                   "  --experiment floor instead of the table, interleaved in blocks: the wire\n"
                   "                     against raw ZeroMQ frames of the same payload, all sizes\n";
      std::exit(0);
    } else {
      throw std::invalid_argument("unknown argument '" + a + "' (try --help)");
    }
  }
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options options = parse(argc, argv);
    wire::keepLargeBuffersOnHeap();  // as the coupler and every solver do (inherited by the peers)
    // Every peer (ipc and tcp, per placement) is forked before this process
    // creates its ZeroMQ context.
    std::vector<EchoChild> children;
    std::vector<int> pipes;
    constexpr std::size_t kPeersPerPlacement = 3;  // ipc, tcp, shm
    for (std::size_t i = 0; i < kPeersPerPlacement * options.placements.size(); ++i) {
      children.push_back(EchoChild::fork(pipes));
      pipes.push_back(children.back().writeFd());
    }
    // A peer that died before reading its endpoint must fail the run with a
    // message, not kill this process with SIGPIPE.
    std::signal(SIGPIPE, SIG_IGN);

    std::cout << "wire_bench: ROUTER (this process, pid " << ::getpid() << ") <-> DEALER echo peers (forked)\n"
              << "round trip = build request + send + peer decode/echo/send + receive + decode; "
              << "GB/s = 2 x payload / median (1 GB = 1e9 B)\n"
              << "stream GB/s = one-way payload throughput, requests built and sent back to back with "
              << kStreamWindow << " in flight, each decoded and acknowledged by the peer\n"
              << "placement spread: where the OS puts the processes; packed: this process and the peer, every "
                 "thread, on one CPU\n"
              << "load average before: " << loadAverage() << "; " << std::thread::hardware_concurrency()
              << " hardware threads" << (options.quick ? "; --quick" : "")
              << (options.experiment.empty() ? "" : "; --experiment " + options.experiment)
              << "\n"
              << "build us = median time the parent spends building the request (allocation + payload copy)\n\n";
    std::vector<Row> rows;
    std::map<Placement, double> floorUs;
    for (std::size_t p = 0; p < options.placements.size(); ++p) {
      const auto placement = options.placements[p];
      if (placement == Placement::packed) cosim::util::restrictProcessTo({cosim::util::currentCpu()});
      floorUs[placement] = socketpairFloorUs(options.quick ? 200 : 2000);
      auto* peers = &children[kPeersPerPlacement * p];
      for (const auto kind : {wire::TransportOptions::Kind::ipc, wire::TransportOptions::Kind::tcp}) {
        auto more = runTransport(kind, peers[kind == wire::TransportOptions::Kind::tcp ? 1 : 0], options, placement);
        rows.insert(rows.end(), more.begin(), more.end());
      }
      if (options.experiment.empty()) {
        auto more = runShared(peers[2], options, placement);
        rows.insert(rows.end(), more.begin(), more.end());
      }
    }

    const auto allMet = printTable(rows, floorUs);
    std::cout << "\nkernel floor, 8-byte socketpair ping-pong without ZeroMQ, median:";
    for (const auto& [placement, us] : floorUs)
      std::cout << " " << placementName(placement) << " " << std::fixed << std::setprecision(1) << us << " us";
    std::cout << "\nload average after: " << loadAverage() << "\n";
    bool anyMet = false;
    if (!options.experiment.empty()) {
      std::cout << "targets: not judged in experiments\n";
    } else {
      std::cout << "targets (ipc: " << sizeLabel(kSmallMaxBytes) << " and less, median <= " << kSmallIpcMedianUs
                << " us; " << sizeLabel(kBulkMinBytes) << ", >= " << kBulkGBps << " GB/s; shm: " << sizeLabel(kSmallMaxBytes)
                << " and less, median <= " << kSmallShmFloorFactor << " x the kernel floor; " << sizeLabel(kBulkMinBytes)
                << ", >= " << kBulkShmGBps << " GB/s):";
      for (const auto& [placement, met] : allMet) {
        std::cout << " " << placementName(placement) << " " << (met ? "all met" : "some MISSED");
        anyMet = anyMet || met;
      }
      std::cout << "\n";
    }
    return options.requireTargets && options.experiment.empty() && !anyMet ? 2 : 0;
  } catch (const std::exception& e) {
    std::cerr << "wire_bench: " << e.what() << "\n";
    return 1;
  }
}
