#pragma once
// The coupler's side of the conversation with its solver peers over one
// ROUTER socket: hellos, welcome or refusal, requests with sequence numbers and
// deadlines, replies matched to requests, heartbeats both ways, and the
// diagnosis of a peer that dies or falls silent.
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/wire/shm_link.hpp"
#include "cosim/wire/sockets.hpp"

namespace cosim::wire {

struct PeerInfo {
  std::string name;
  std::string kind;
  std::string version;
  std::string host;
  std::uint32_t pid = 0;
  std::uint16_t protocolMajor = 0;
  std::uint16_t protocolMinor = 0;
  std::vector<std::string> capabilities;
};

struct LinkOptions {
  double heartbeatIntervalS = 0.5;
  double heartbeatTimeoutS = 10.0;
  double requestTimeoutS = 3600.0;
  ShmOptions shm;  // the data path of solvers on this host (no directory: ZeroMQ only)
};

/// A peer failed: died, fell silent, missed a deadline or answered with an
/// error. what() says which peer, when (the session's context) and what was
/// last heard from it.
class PeerFault : public std::runtime_error {
 public:
  PeerFault(std::string peer, const std::string& message, bool gone = false)
      : std::runtime_error(message), peer_(std::move(peer)), gone_(gone) {}
  const std::string& peer() const { return peer_; }
  /// The peer died, fell silent or cannot be reached: it will not answer
  /// again. Otherwise it answered wrongly (an error reply, a malformed or
  /// misaddressed message), which says something about the run itself.
  bool gone() const { return gone_; }

 private:
  std::string peer_;
  bool gone_ = false;
};

/// Traffic figures per peer, for the run report.
struct PeerTraffic {
  std::uint64_t messagesSent = 0;
  std::uint64_t messagesReceived = 0;
  std::uint64_t bytesSent = 0;
  std::uint64_t bytesReceived = 0;
};

/// A reply and when it arrived (monotonic seconds), for timing splits.
struct Reply {
  InMessage message;
  double receivedAt = 0.0;
};

class PeerSession {
 public:
  PeerSession(RouterSocket& socket, LinkOptions options);

  /// Called while waiting; may throw PeerFault (e.g. when a child process died).
  void setWatchdog(std::function<void()> watchdog) { watchdog_ = std::move(watchdog); }
  /// Where the run is ("exchange 37, t = 0.037 s"); quoted in fault messages.
  void setContext(std::string context) { context_ = std::move(context); }

  /// Waits until every expected peer has said hello. Unknown names are
  /// refused. Throws PeerFault naming who is missing after timeoutS.
  void awaitHellos(const std::vector<std::string>& expected, double timeoutS);
  const PeerInfo& info(const std::string& peer) const;
  void welcome(const std::string& peer);
  void refuse(const std::string& peer, const std::string& reason);

  /// A message to build for `peer`: in its shared-memory lane when it has one.
  OutMessage message(const std::string& peer, std::size_t firstSegmentWords = 1024);
  /// Requests and replies of `peer` travel through shared memory.
  bool sharedMemory(const std::string& peer) const { return peerRef(peer).link != nullptr; }

  /// Sends a request (sets seq), returns its seq. timeoutS <= 0: the default.
  std::uint64_t request(const std::string& peer, OutMessage& message, double timeoutS = 0.0);
  /// Waits for the reply to seq; an error reply throws PeerFault.
  Reply awaitReply(const std::string& peer, std::uint64_t seq);
  /// Waits for several replies at once (peers compute in parallel meanwhile).
  std::vector<Reply> awaitReplies(const std::vector<std::pair<std::string, std::uint64_t>>& pending);
  /// The run carries on without this peer (it died or hung and its work moved
  /// elsewhere): its pending requests are forgotten, it gets no heartbeats and
  /// is not watched, and whatever it still sends is dropped.
  void dropPeer(const std::string& peer);

  /// Asks every welcomed peer (but those in skip: known dead or hung) to shut
  /// down and waits up to timeoutS for their answers.
  void shutdownAll(const std::string& reason, double timeoutS, const std::set<std::string>& skip = {});

  /// Sends heartbeats that are due and takes in whatever arrived, up to timeout.
  void pump(std::chrono::milliseconds timeout);

  std::string lastHeard(const std::string& peer) const;
  const PeerTraffic& traffic(const std::string& peer) const;
  std::vector<std::string> peers() const;

 private:
  struct Peer {
    PeerInfo info;
    bool welcomed = false;
    bool dropped = false;  // dropPeer: the run goes on without it
    std::uint64_t nextSeq = 1;
    double lastHeardAt = 0.0;
    std::string lastHeardWhat = "nothing";
    std::map<std::uint64_t, double> deadlines;   // pending requests
    std::map<std::uint64_t, std::string> kinds;  // pending request kinds
    std::map<std::uint64_t, proto::Envelope::Body::Which> answers;  // the reply kind each pending request wants
    std::map<std::uint64_t, Reply> replies;
    PeerTraffic traffic;
    std::shared_ptr<ShmLink> link;  // the shared-memory data path, when welcomed onto it
    bool linkConfirmed = false;     // the solver has answered through it (its file is unlinked)
  };

  Peer& peerRef(const std::string& name);
  const Peer& peerRef(const std::string& name) const;
  void take(Received&& received);
  void onHello(const std::string& name, InMessage&& message);
  void checkLiveness();
  void sendHeartbeats();
  /// Takes in what arrives within `wait`, from the socket and the lanes.
  void receiveSome(std::chrono::milliseconds wait);
  void takeFromLanes();
  /// Why `p` cannot use shared memory; empty when it can.
  std::string shmObstacle(const Peer& p) const;
  /// Creates p's segment when the scene and the peer allow; false for ZeroMQ.
  bool offerSharedMemory(const std::string& name, Peer& p);
  [[noreturn]] void fault(const std::string& peer, const std::string& what, bool gone = false) const;

  RouterSocket& socket_;
  LinkOptions options_;
  std::unique_ptr<CouplerDoorbell> doorbell_;  // created with the first shared-memory peer
  std::map<std::string, Peer> peers_;
  std::set<std::string> expected_;
  std::function<void()> watchdog_;
  std::string context_ = "before time zero";  // "at exchange 37 (t = 0.037 s)"
  double nextHeartbeat_ = 0.0;
  std::uint64_t heartbeatSeq_ = 0;
};

}  // namespace cosim::wire
