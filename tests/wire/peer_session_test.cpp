// The coupler's peer session against a scripted solver on an in-process
// socket: every way a registered peer can break the request/reply contract
// (malformed, duplicate, misaddressed or wrongly kinded replies, a second
// hello mid-run) ends in a PeerFault that names the peer, and a hello from an
// instance the run does not have is refused with the names it expects. A peer
// that falls silent faults as gone; the run can drop it and still take the
// replies the other peers sent meanwhile.
#include <gtest/gtest.h>

#include <atomic>
#include <functional>
#include <string>
#include <thread>

#include "cosim/wire/peer_session.hpp"
#include "cosim/wire/sockets.hpp"

namespace cosim::wire {
namespace {
using Which = proto::Envelope::Body::Which;

std::string freshEndpoint() {
  static std::atomic<int> n{0};
  return "inproc://peer-session-test-" + std::to_string(n++);
}

/// A solver scripted by the test: it says hello and answers as told.
class ScriptedSolver {
 public:
  ScriptedSolver(const std::string& endpoint, const std::string& name) : socket_(endpoint, name) {}

  void hello(std::uint32_t pid) {
    OutMessage m;
    auto h = m.envelope().getBody().initHello();
    h.setProtocolMajor(proto::PROTOCOL_MAJOR);
    h.setSolverKind("mock");
    h.setPid(pid);
    h.setHost("testhost");
    socket_.send(m);
  }

  /// The next message for the solver that is not a heartbeat.
  InMessage next() {
    while (true) {
      auto r = socket_.receive(std::chrono::milliseconds(5000));
      if (!r) throw std::runtime_error("the session sent nothing within 5 s");
      if (!r->message) throw std::runtime_error("the session sent a malformed message: " + r->error);
      if (r->message->envelope().getBody().which() != Which::HEARTBEAT) return std::move(*r->message);
    }
  }

  void reply(std::uint64_t replyTo, const std::function<void(proto::Envelope::Body::Builder)>& body) {
    OutMessage m;
    m.envelope().setReplyTo(replyTo);
    body(m.envelope().getBody());
    socket_.send(m);
  }

  DealerSocket& socket() { return socket_; }

 private:
  DealerSocket socket_;
};

class PeerSessionContract : public ::testing::Test {
 protected:
  PeerSessionContract()
      : endpoint_(freshEndpoint()), router_(endpoint_), session_(router_, LinkOptions{0.1, 5.0, 5.0, {}}),
        solver_(endpoint_, "beam") {}

  /// Hello, welcome and one advance request the solver has received; its seq.
  std::uint64_t welcomedWithAnAdvancePending() {
    solver_.hello(101);
    session_.awaitHellos({"beam"}, 5.0);
    session_.welcome("beam");
    EXPECT_EQ(solver_.next().envelope().getBody().which(), Which::WELCOME);
    OutMessage advance;
    advance.envelope().getBody().initAdvance().setSteps(1);
    const auto seq = session_.request("beam", advance);
    EXPECT_EQ(solver_.next().envelope().getSeq(), seq);
    return seq;
  }

  /// What the session says when it faults while waiting for seq.
  std::string faultAwaiting(std::uint64_t seq) {
    try {
      session_.awaitReply("beam", seq);
    } catch (const PeerFault& e) {
      EXPECT_EQ(e.peer(), "beam");
      return e.what();
    }
    ADD_FAILURE() << "the session took the reply";
    return "";
  }

  std::string endpoint_;
  RouterSocket router_;
  PeerSession session_;
  ScriptedSolver solver_;
};

auto advanced = [](proto::Envelope::Body::Builder b) { b.initAdvanced(); };

TEST_F(PeerSessionContract, AnAnsweredRequestIsTaken) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq, advanced);
  EXPECT_EQ(session_.awaitReply("beam", seq).message.envelope().getBody().which(), Which::ADVANCED);
}

TEST_F(PeerSessionContract, AMalformedReplyFaultsNamingThePeer) {
  const auto seq = welcomedWithAnAdvancePending();
  const std::string text = "not an envelope";
  zmq::message_t junk(text.data(), text.size());
  solver_.socket().raw().send(junk, zmq::send_flags::none);
  const auto what = faultAwaiting(seq);
  EXPECT_NE(what.find("peer 'beam' (mock, pid 101 on testhost)"), std::string::npos) << what;
  EXPECT_NE(what.find("sent a malformed message (15 bytes)"), std::string::npos) << what;
}

TEST_F(PeerSessionContract, AReplyOfTheWrongKindFaults) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq, [](proto::Envelope::Body::Builder b) { b.initRestored(); });
  const auto what = faultAwaiting(seq);
  EXPECT_NE(what.find("answered 'advance' (seq " + std::to_string(seq) + ") with 'restored'"), std::string::npos)
      << what;
}

TEST_F(PeerSessionContract, AReplyToARequestNeverSentFaults) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq + 7, advanced);
  const auto what = faultAwaiting(seq);
  EXPECT_NE(what.find("in reply to seq " + std::to_string(seq + 7) + ", a request it was never sent"),
            std::string::npos)
      << what;
}

TEST_F(PeerSessionContract, ADuplicateReplyFaults) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq, advanced);
  session_.awaitReply("beam", seq);
  OutMessage advance;
  advance.envelope().getBody().initAdvance().setSteps(1);
  const auto second = session_.request("beam", advance);
  solver_.reply(seq, advanced);  // the first request answered again
  const auto what = faultAwaiting(second);
  EXPECT_NE(what.find("answered seq " + std::to_string(seq) + " a second time ('advanced')"), std::string::npos)
      << what;
}

TEST_F(PeerSessionContract, ASecondHelloMidRunFaultsInsteadOfRestartingTheSession) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.hello(202);
  const auto what = faultAwaiting(seq);
  EXPECT_NE(what.find("said hello again mid-run (pid 202 on testhost)"), std::string::npos) << what;
  EXPECT_NE(what.find("pid 101"), std::string::npos) << "the fault names the process first welcomed: " << what;
}

TEST_F(PeerSessionContract, AHelloFromAnUnknownInstanceIsRefusedWithTheExpectedNames) {
  ScriptedSolver stranger(endpoint_, "stranger");
  stranger.hello(303);
  solver_.hello(101);
  session_.awaitHellos({"beam"}, 5.0);
  for (int i = 0; i < 10; ++i) session_.pump(std::chrono::milliseconds(20));
  const auto answer = stranger.next();
  ASSERT_EQ(answer.envelope().getBody().which(), Which::ERROR);
  const std::string text = answer.envelope().getBody().getError().getMessage().cStr();
  EXPECT_EQ(text, "this run has no solver instance 'stranger' (it expects: beam)");
  EXPECT_EQ(session_.peers(), std::vector<std::string>{"beam"});
}

TEST_F(PeerSessionContract, AnErrorAnswerFaultsWithTheSolversMessage) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq, [](proto::Envelope::Body::Builder b) {
    auto e = b.initError();
    e.setCode(proto::Error::Code::SOLVER_FAILURE);
    e.setMessage("contact overlap above 20 % of the radius");
  });
  const auto what = faultAwaiting(seq);
  EXPECT_NE(what.find("answered 'advance' (seq " + std::to_string(seq) +
                      ") with an error: contact overlap above 20 % of the radius"),
            std::string::npos)
      << what;
}

TEST_F(PeerSessionContract, ADroppedPeerLeavesTheOthersRepliesToBeTaken) {
  // beam answers its advance; cells falls silent past the heartbeat timeout.
  // The fault names cells as gone, beam's reply stays with the session, and
  // once cells is dropped nothing it sends later matters.
  LinkOptions link{0.05, 0.5, 5.0, {}};
  PeerSession session(router_, link);
  ScriptedSolver cells(endpoint_, "cells");
  solver_.hello(101);
  cells.hello(102);
  session.awaitHellos({"beam", "cells"}, 5.0);
  session.welcome("beam");
  session.welcome("cells");
  EXPECT_EQ(solver_.next().envelope().getBody().which(), Which::WELCOME);
  EXPECT_EQ(cells.next().envelope().getBody().which(), Which::WELCOME);
  OutMessage a, b;
  a.envelope().getBody().initAdvance().setSteps(1);
  b.envelope().getBody().initAdvance().setSteps(1);
  const auto seqBeam = session.request("beam", a), seqCells = session.request("cells", b);
  EXPECT_EQ(solver_.next().envelope().getSeq(), seqBeam);
  solver_.reply(seqBeam, advanced);
  // beam keeps beating; cells says nothing more.
  std::atomic<bool> stop{false};
  std::thread beats([&] {
    while (!stop) {
      OutMessage h;
      h.envelope().getBody().initHeartbeat();
      solver_.socket().send(h);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  try {
    session.awaitReplies({{"beam", seqBeam}, {"cells", seqCells}});
    ADD_FAILURE() << "a silent peer was waited for without end";
  } catch (const PeerFault& e) {
    EXPECT_EQ(e.peer(), "cells");
    EXPECT_TRUE(e.gone()) << e.what();
  }
  session.dropPeer("cells");
  cells.reply(seqCells, advanced);  // too late: dropped
  const auto replies = session.awaitReplies({{"beam", seqBeam}});
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].message.envelope().getReplyTo(), seqBeam);
  session.pump(std::chrono::milliseconds(600));  // no liveness fault for the dropped peer
  stop = true;
  beats.join();
}

TEST_F(PeerSessionContract, AnErrorAnswerIsNotAPeerGone) {
  const auto seq = welcomedWithAnAdvancePending();
  solver_.reply(seq, [](proto::Envelope::Body::Builder b) { b.initError().setMessage("bad input"); });
  try {
    session_.awaitReply("beam", seq);
    ADD_FAILURE() << "the error was taken as a reply";
  } catch (const PeerFault& e) {
    EXPECT_FALSE(e.gone()) << e.what();  // the run must stop: its work cannot simply move
  }
}

}  // namespace
}  // namespace cosim::wire
