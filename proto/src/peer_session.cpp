#include "cosim/wire/peer_session.hpp"

#include <sys/resource.h>
#include <sys/statfs.h>

#include <cstdio>

#include <algorithm>
#include <filesystem>

#include "cosim/wire/clock.hpp"
#include "cosim/wire/endpoint.hpp"
#include "cosim/wire/log.hpp"

namespace cosim::wire {
namespace {
using Which = proto::Envelope::Body::Which;
constexpr const char* kHeartbeatSuffix = "#hb";
constexpr const char* kShmCapability = "shm-data";
// While replies come through shared memory the coupler sleeps on its doorbell
// and looks at the socket (heartbeats, hellos) at least this often.
constexpr std::chrono::milliseconds kSocketLookMs{10};
// ... and while some pending reply comes by ZeroMQ, it looks at the lanes this often.
constexpr std::chrono::milliseconds kLaneLookMs{1};

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.2f s", s);
  return buf;
}

bool isReplyKind(Which w) {
  return w == Which::SETUP_DONE || w == Which::ADVANCED || w == Which::FIELDS ||
         w == Which::CHECKPOINT_DONE || w == Which::RESTORED || w == Which::SHUTDOWN_DONE ||
         w == Which::CELLS_ADOPTED || w == Which::ERROR;
}

/// The reply kind that answers a request kind (besides an error, which answers any).
Which answerTo(Which request) {
  switch (request) {
    case Which::SETUP: return Which::SETUP_DONE;
    case Which::ADVANCE: return Which::ADVANCED;
    case Which::FIELDS_REQUEST: return Which::FIELDS;
    case Which::CHECKPOINT: return Which::CHECKPOINT_DONE;
    case Which::RESTORE: return Which::RESTORED;
    case Which::SHUTDOWN: return Which::SHUTDOWN_DONE;
    case Which::ADOPT_CELLS: return Which::CELLS_ADOPTED;
    default: return Which::ERROR;
  }
}

/// The name of the network file system `dir` is on; empty for a local one.
std::string networkFileSystem(const std::string& dir) {
  struct statfs st {};
  if (::statfs(dir.c_str(), &st) != 0) return {};
  switch (static_cast<unsigned long>(st.f_type)) {
    case 0x6969: return "NFS";
    case 0xFF534D42: case 0xFE534D42: return "CIFS/SMB";
    case 0x0BD00BD0: return "Lustre";
    case 0x47504653: return "GPFS";
    case 0x013111A8: return "IBRIX";
    case 0x00C36400: return "CephFS";
    case 0x65735546: return "a FUSE file system";
    default: return {};
  }
}

/// Both lanes of every solver are mapped in the coupler: under an address
/// space limit (ulimit -v, which solvers inherit) a lane takes at most a
/// sixteenth of it, a solver's two an eighth.
std::uint64_t laneBytesWithin(std::uint64_t laneBytes) {
  struct rlimit limit {};
  if (::getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return laneBytes;
  return std::max<std::uint64_t>(std::uint64_t{1} << 20, std::min<std::uint64_t>(laneBytes, limit.rlim_cur / 16));
}

OutMessage errorMessage(proto::Error::Code code, const std::string& text, std::uint64_t replyTo) {
  OutMessage m;
  auto env = m.envelope();
  env.setReplyTo(replyTo);
  auto e = env.getBody().initError();
  e.setCode(code);
  e.setMessage(text);
  return m;
}
}  // namespace

PeerSession::PeerSession(RouterSocket& socket, LinkOptions options)
    : socket_(socket), options_(options) {}

PeerSession::Peer& PeerSession::peerRef(const std::string& name) {
  auto it = peers_.find(name);
  if (it == peers_.end()) throw std::out_of_range("no peer named '" + name + "'");
  return it->second;
}
const PeerSession::Peer& PeerSession::peerRef(const std::string& name) const {
  auto it = peers_.find(name);
  if (it == peers_.end()) throw std::out_of_range("no peer named '" + name + "'");
  return it->second;
}

const PeerInfo& PeerSession::info(const std::string& peer) const { return peerRef(peer).info; }
const PeerTraffic& PeerSession::traffic(const std::string& peer) const { return peerRef(peer).traffic; }

std::vector<std::string> PeerSession::peers() const {
  std::vector<std::string> names;
  for (const auto& [name, p] : peers_) names.push_back(name);
  return names;
}

std::string PeerSession::lastHeard(const std::string& peer) const {
  auto it = peers_.find(peer);
  if (it == peers_.end()) return "nothing (it never said hello)";
  return it->second.lastHeardWhat + ", " + seconds(monotonicSeconds() - it->second.lastHeardAt) + " ago";
}

void PeerSession::fault(const std::string& peer, const std::string& what, bool gone) const {
  std::string who = "peer '" + peer + "'";
  if (auto it = peers_.find(peer); it != peers_.end() && it->second.info.pid != 0)
    who += " (" + it->second.info.kind + ", pid " + std::to_string(it->second.info.pid) + " on " +
           it->second.info.host + ")";
  throw PeerFault(peer, who + ", " + context_ + ": " + what + "; last heard: " + lastHeard(peer), gone);
}

void PeerSession::onHello(const std::string& name, InMessage&& message) {
  auto h = message.envelope().getBody().getHello();
  Peer p;
  p.info.name = name;
  p.info.kind = h.getSolverKind();
  p.info.version = h.getVersion();
  p.info.host = h.getHost();
  p.info.pid = h.getPid();
  p.info.protocolMajor = h.getProtocolMajor();
  p.info.protocolMinor = h.getProtocolMinor();
  for (auto c : h.getCapabilities()) p.info.capabilities.emplace_back(c.cStr());
  p.lastHeardAt = monotonicSeconds();
  p.lastHeardWhat = "hello";
  p.nextSeq = 1;
  if (peers_.count(name)) log::warn("peer '" + name + "' said hello again; starting its session anew");
  peers_[name] = std::move(p);
}

void PeerSession::take(Received&& r) {
  std::string name = r.identity;
  const bool heartbeatChannel =
      name.size() > 3 && name.compare(name.size() - 3, 3, kHeartbeatSuffix) == 0;
  if (heartbeatChannel) name.resize(name.size() - 3);
  if (!r.message) {
    if (peers_.count(name))  // a registered peer's defect: nothing it sends can be trusted after it
      fault(name, "sent a malformed message (" + std::to_string(r.bytes) + " bytes): " + r.error);
    log::warn("dropped a malformed message from '" + r.identity + "' (" + std::to_string(r.bytes) +
              " bytes): " + r.error);
    socket_.send(r.identity, errorMessage(proto::Error::Code::MALFORMED, "malformed message: " + r.error, 0));
    return;
  }
  auto env = r.message->envelope();
  const auto which = env.getBody().which();
  if (!heartbeatChannel && which == Which::HELLO) {
    if (!expected_.count(name)) {
      std::string known;
      for (const auto& e : expected_) known += (known.empty() ? "" : ", ") + e;
      log::warn("refused hello from unknown instance '" + name + "'");
      socket_.send(r.identity, errorMessage(proto::Error::Code::UNEXPECTED,
                                            "this run has no solver instance '" + name +
                                                "' (it expects: " + known + ")", env.getSeq()));
      return;
    }
    if (auto known = peers_.find(name); known != peers_.end() && known->second.welcomed) {
      const auto h = env.getBody().getHello();
      fault(name, "said hello again mid-run (pid " + std::to_string(h.getPid()) + " on " + h.getHost().cStr() +
                      "): the process restarted, or a second process uses its name");
    }
    onHello(name, std::move(*r.message));
    peers_[name].traffic.messagesReceived++;
    peers_[name].traffic.bytesReceived += r.bytes;
    return;
  }
  auto it = peers_.find(name);
  if (it == peers_.end()) {
    log::warn("dropped '" + bodyName(env) + "' from '" + r.identity + "', which has not said hello");
    if (!heartbeatChannel)
      socket_.send(r.identity, errorMessage(proto::Error::Code::UNEXPECTED, "say hello first", env.getSeq()));
    return;
  }
  Peer& p = it->second;
  if (p.dropped) return;  // the run went on without it: nothing it says matters now
  p.traffic.messagesReceived++;
  p.traffic.bytesReceived += r.bytes;
  p.lastHeardAt = monotonicSeconds();
  if (which == Which::HEARTBEAT) {
    p.lastHeardWhat = env.getBody().getHeartbeat().getBusy() ? "heartbeat (computing)" : "heartbeat (idle)";
    return;
  }
  const auto replyTo = env.getReplyTo();
  p.lastHeardWhat = "'" + bodyName(env) + "'" + (replyTo ? " in reply to seq " + std::to_string(replyTo) : "");
  if (isReplyKind(which) && p.deadlines.count(replyTo)) {
    const Which expected = p.answers.at(replyTo);
    if (which != Which::ERROR && which != expected)
      fault(name, "answered '" + p.kinds.at(replyTo) + "' (seq " + std::to_string(replyTo) + ") with '" +
                      bodyName(env) + "'");
    p.deadlines.erase(replyTo);
    p.answers.erase(replyTo);
    p.replies.emplace(replyTo, Reply{std::move(*r.message), monotonicSeconds()});
    return;
  }
  if (which == Which::ERROR) {
    auto e = env.getBody().getError();
    if (e.getFatal()) fault(name, std::string("reported a fatal error: ") + e.getMessage().cStr());
    log::warn("peer '" + name + "' reported: " + e.getMessage().cStr());
    return;
  }
  if (isReplyKind(which) && p.welcomed) {
    // Every request has one reply and waits for it until its deadline, so a
    // reply without a waiting request is a defect of the peer, not a late one.
    if (replyTo == 0 || replyTo >= p.nextSeq)
      fault(name, "sent '" + bodyName(env) + "' in reply to seq " + std::to_string(replyTo) +
                      ", a request it was never sent");
    fault(name, "answered seq " + std::to_string(replyTo) + " a second time ('" + bodyName(env) + "')");
  }
  log::warn("dropped '" + bodyName(env) + "' from '" + name + "' (seq " + std::to_string(env.getSeq()) +
            ", reply to " + std::to_string(replyTo) + "): no request is waiting for it");
}

void PeerSession::sendHeartbeats() {
  const double now = monotonicSeconds();
  if (now < nextHeartbeat_) return;
  nextHeartbeat_ = now + options_.heartbeatIntervalS;
  for (auto& [name, p] : peers_) {
    if (!p.welcomed) continue;
    OutMessage m(64);
    auto env = m.envelope();
    env.setSeq(++heartbeatSeq_);
    env.getBody().initHeartbeat().setSentAtS(now);
    socket_.send(name + kHeartbeatSuffix, m);  // an unreachable peer shows up as silence
  }
}

void PeerSession::checkLiveness() {
  const double now = monotonicSeconds();
  for (const auto& [name, p] : peers_) {
    if (!p.welcomed) continue;
    if (now - p.lastHeardAt > options_.heartbeatTimeoutS)
      fault(name, "silent for " + seconds(now - p.lastHeardAt) + " (heartbeat timeout " +
                      seconds(options_.heartbeatTimeoutS) + ")", true);
    for (const auto& [seq, deadline] : p.deadlines)
      if (now > deadline)
        fault(name, "no reply to '" + p.kinds.at(seq) + "' (seq " + std::to_string(seq) + ") within its deadline", true);
  }
}

void PeerSession::pump(std::chrono::milliseconds timeout) {
  sendHeartbeats();
  const double untilBeat = std::max(0.0, nextHeartbeat_ - monotonicSeconds());
  auto wait = std::min(timeout, std::chrono::milliseconds(static_cast<long>(untilBeat * 1000.0) + 1));
  receiveSome(wait);
  checkLiveness();
  if (watchdog_) watchdog_();
}

void PeerSession::receiveSome(std::chrono::milliseconds wait) {
  using std::chrono::milliseconds;
  if (!doorbell_) {
    for (auto r = socket_.receive(wait); r; r = socket_.receive(milliseconds(0))) take(std::move(*r));
    return;
  }
  bool zmqPending = false;
  for (const auto& [name, p] : peers_) zmqPending = zmqPending || (!p.link && !p.deadlines.empty());
  if (zmqPending) {
    if (auto r = socket_.receive(std::min(wait, kLaneLookMs))) take(std::move(*r));
  } else {
    const double waitS = std::chrono::duration<double>(std::min(wait, kSocketLookMs)).count();
    waitForDoorbell(doorbell_->bell(), options_.shm.spinS, waitS, [this] {
      for (const auto& [name, p] : peers_)
        if (p.link && p.link->hasIncoming()) return true;
      return false;
    });
  }
  takeFromLanes();
  for (auto r = socket_.receive(milliseconds(0)); r; r = socket_.receive(milliseconds(0))) take(std::move(*r));
}

void PeerSession::takeFromLanes() {
  for (auto& [name, p] : peers_) {
    if (!p.link) continue;
    while (auto item = p.link->take()) {
      if (item->kind == LaneItem::Kind::onZmq) continue;  // the socket has it (drained next)
      if (!p.linkConfirmed) {
        p.link->unlinkFile();  // mapped on both ends now: nothing to clean up on any exit
        p.linkConfirmed = true;
      }
      Received r;
      r.identity = name;
      r.bytes = item->bytes;
      if (item->kind == LaneItem::Kind::malformed) r.error = "in shared memory: " + item->error;
      else r.message = std::move(item->message);
      take(std::move(r));
    }
  }
}

std::string PeerSession::shmObstacle(const Peer& p) const {
  if (options_.shm.directory.empty()) return "the run has no directory for segments";
  if (const std::string fs = networkFileSystem(options_.shm.directory); !fs.empty())
    return "the run directory is on " + fs + ", whose shared mappings the file server would see every write of";
  const auto& caps = p.info.capabilities;
  if (std::find(caps.begin(), caps.end(), kShmCapability) == caps.end())
    return "its binary does not offer '" + std::string(kShmCapability) + "'";
  if (p.info.host != thisHostName())
    return "it runs on host '" + p.info.host + "', the coupler on '" + thisHostName() + "'";
  return {};
}

bool PeerSession::offerSharedMemory(const std::string& name, Peer& p) {
  const auto mode = options_.shm.mode;
  if (mode == ShmOptions::Mode::zmq) return false;
  // Why not: a peer the path is not for (debug), or a segment that could not
  // be made for one it is for (warned: the run is slower than it should be).
  std::string why = shmObstacle(p);
  bool failed = false;
  if (why.empty()) {
    try {
      if (!doorbell_) doorbell_ = std::make_unique<CouplerDoorbell>(options_.shm.directory + "/doorbell");
      p.link = ShmLink::create(options_.shm.directory + "/" + name, laneBytesWithin(options_.shm.laneBytes),
                               *doorbell_);
      return true;
    } catch (const std::exception& e) {
      why = e.what();
      failed = true;
    }
  }
  if (mode == ShmOptions::Mode::shm)
    fault(name, "cannot use shared memory (transport.data: shm): " + why);
  const std::string text = "peer '" + name + "' talks over ZeroMQ: " + why;
  failed ? log::warn(text) : log::debug(text);
  return false;
}

void PeerSession::awaitHellos(const std::vector<std::string>& expected, double timeoutS) {
  expected_.insert(expected.begin(), expected.end());
  const double deadline = monotonicSeconds() + timeoutS;
  while (true) {
    std::vector<std::string> missing;
    for (const auto& e : expected)
      if (!peers_.count(e)) missing.push_back(e);
    if (missing.empty()) return;
    if (monotonicSeconds() > deadline)
      fault(missing.front(), "no hello within " + seconds(timeoutS) + " on " + socket_.endpoint());
    pump(std::chrono::milliseconds(100));
  }
}

void PeerSession::welcome(const std::string& peer) {
  Peer& p = peerRef(peer);
  OutMessage m(64);
  auto env = m.envelope();
  env.setSeq(0);  // an answer to the hello, not a request: request seqs start at 1
  auto w = env.getBody().initWelcome();
  w.setProtocolMajor(proto::PROTOCOL_MAJOR);
  w.setProtocolMinor(proto::PROTOCOL_MINOR);
  w.setHeartbeatIntervalS(options_.heartbeatIntervalS);
  w.setHeartbeatTimeoutS(options_.heartbeatTimeoutS);
  if (offerSharedMemory(peer, p)) {
    w.setDataSegment(p.link->path());
    w.setDoorbell(doorbell_->path());
    w.setSpinS(options_.shm.spinS);
  }
  socket_.send(peer, m);
  p.welcomed = true;
  p.lastHeardAt = monotonicSeconds();
}

void PeerSession::refuse(const std::string& peer, const std::string& reason) {
  socket_.send(peer, errorMessage(proto::Error::Code::PROTOCOL_MISMATCH, reason, 0));
}

std::uint64_t PeerSession::request(const std::string& peer, OutMessage& message, double timeoutS) {
  Peer& p = peerRef(peer);
  auto env = message.envelope();
  const auto seq = p.nextSeq++;
  env.setSeq(seq);
  env.setReplyTo(0);
  const std::string kind = bodyName(env.asReader());
  // A message that is not in the peer's lane follows its "on ZeroMQ" descriptor there.
  if ((!p.link || !p.link->post(message)) && !socket_.send(peer, message))
    fault(peer, "cannot send '" + kind + "': not connected", true);
  p.traffic.messagesSent++;
  p.traffic.bytesSent += message.sizeInBytes();
  p.deadlines[seq] = monotonicSeconds() + (timeoutS > 0 ? timeoutS : options_.requestTimeoutS);
  p.kinds[seq] = kind;
  p.answers[seq] = answerTo(env.getBody().which());
  return seq;
}

OutMessage PeerSession::message(const std::string& peer, std::size_t firstSegmentWords) {
  const Peer& p = peerRef(peer);
  return p.link ? p.link->message(firstSegmentWords) : OutMessage(firstSegmentWords);
}

Reply PeerSession::awaitReply(const std::string& peer, std::uint64_t seq) {
  return std::move(awaitReplies({{peer, seq}}).front());
}

std::vector<Reply> PeerSession::awaitReplies(
    const std::vector<std::pair<std::string, std::uint64_t>>& pending) {
  // The replies are taken only once all are in: a fault of one peer while
  // waiting leaves the others' replies with the session, where a caller that
  // carries on without that peer (dropPeer) still finds them.
  while (true) {
    bool all = true;
    for (const auto& [peer, seq] : pending) {
      Peer& p = peerRef(peer);
      auto it = p.replies.find(seq);
      if (it == p.replies.end()) {
        all = false;
        continue;
      }
      auto env = it->second.message.envelope();
      if (env.getBody().which() == Which::ERROR)
        fault(peer, "answered '" + p.kinds[seq] + "' (seq " + std::to_string(seq) +
                        ") with an error: " + env.getBody().getError().getMessage().cStr());
    }
    if (all) break;
    pump(std::chrono::milliseconds(100));
  }
  std::vector<Reply> out;
  out.reserve(pending.size());
  for (const auto& [peer, seq] : pending) {
    Peer& p = peerRef(peer);
    auto it = p.replies.find(seq);
    out.push_back(std::move(it->second));
    p.replies.erase(it);
    p.kinds.erase(seq);
  }
  return out;
}

void PeerSession::dropPeer(const std::string& peer) {
  Peer& p = peerRef(peer);
  p.dropped = true;
  p.welcomed = false;  // no heartbeats, no liveness check, no shutdown; late messages are dropped
  p.deadlines.clear();
  p.kinds.clear();
  p.answers.clear();
  p.replies.clear();
}

void PeerSession::shutdownAll(const std::string& reason, double timeoutS, const std::set<std::string>& skip) {
  const double deadline = monotonicSeconds() + timeoutS;
  std::vector<std::pair<std::string, std::uint64_t>> pending;
  for (auto& [name, p] : peers_) {
    if (!p.welcomed || skip.count(name)) continue;
    OutMessage m = message(name, 64);
    m.envelope().getBody().initShutdown().setReason(reason);
    try {
      pending.emplace_back(name, request(name, m, timeoutS));
    } catch (const PeerFault& e) {
      log::warn(e.what());
    }
  }
  while (monotonicSeconds() < deadline) {
    bool all = true;
    for (const auto& [name, seq] : pending) all = all && peers_[name].replies.count(seq);
    if (all) break;
    try {
      receiveSome(std::chrono::milliseconds(50));
    } catch (const PeerFault& e) {
      log::warn(e.what());
    }
  }
  for (auto& [name, p] : peers_) {
    p.welcomed = false;
    p.deadlines.clear();
    p.answers.clear();
  }
}

}  // namespace cosim::wire
