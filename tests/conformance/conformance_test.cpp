// Protocol conformance of any solver binary:
//   conformance_tests --solver PATH --scene SCENE.yaml --instance NAME [--data zmq|shm] [gtest flags]
// The suite plays a minimal coupler written directly against the sockets
// (independent of the coupler's own session code); with --data shm its
// welcome offers a shared-memory segment and every request and reply goes
// through the segment's lanes (docs/protocol.md). It checks the handshake,
// setup, advance, fields, checkpoint/restore, error answers to bad requests,
// shutdown, and that the solver leaves when its coupler falls silent.
#include <capnp/serialize.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/clock.hpp"
#include "cosim/wire/shm_link.hpp"
#include "cosim/wire/sockets.hpp"
#include "cosim/wire/solver.hpp"
#include "subprocess.hpp"

namespace cosim::conformance {
namespace {
namespace fs = std::filesystem;
using Code = proto::Error::Code;
using Body = proto::Envelope::Body;

struct Subject {
  std::string binary;
  std::string scene;
  std::string instance;
};
Subject g_subject;
// The data path the suite speaks: "zmq" (the socket) or "shm" (the welcome
// offers a shared-memory segment, and requests and replies go through it).
std::string g_data = "zmq";

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Conformance : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_FALSE(g_subject.binary.empty()) << "run with --solver PATH --scene FILE --instance NAME";
    dir_ = testing::freshDirectory("cosim-conf");
    router_.emplace("ipc://" + (dir_ / "c.sock").string());
    solver_.emplace(std::vector<std::string>{g_subject.binary, "--endpoint", router_->endpoint(), "--name",
                                             g_subject.instance, "--connect-timeout", "20"});
    hello_ = receive(20.0);
    ASSERT_TRUE(hello_.has_value()) << "no hello within 20 s; solver stderr:\n" << solverErr();
  }

  void TearDown() override {
    if (solver_) {
      solver_->signal(SIGKILL);
      solver_->wait(5);
    }
    link_.reset();
    doorbell_.reset();
    router_.reset();
    fs::remove_all(dir_);
  }

  /// A request to build: in the segment's request lane on the shm path.
  wire::OutMessage message() { return link_ ? link_->message(1024) : wire::OutMessage(); }

  /// Offers the shared-memory data path in the welcome `w` (--data shm).
  void offerSharedMemory(proto::Welcome::Builder w) {
    if (g_data != "shm") return;
    std::vector<std::string> caps;
    for (auto c : hello_->envelope().getBody().getHello().getCapabilities()) caps.emplace_back(c.cStr());
    ASSERT_NE(std::find(caps.begin(), caps.end(), "shm-data"), caps.end()) << "the solver does not offer shm-data";
    doorbell_ = std::make_unique<wire::CouplerDoorbell>((dir_ / "doorbell").string());
    link_ = wire::ShmLink::create((dir_ / "segment").string(), wire::ShmOptions{}.laneBytes, *doorbell_);
    w.setDataSegment(link_->path());
    w.setDoorbell(doorbell_->path());
    w.setSpinS(wire::ShmOptions{}.spinS);
  }

  /// The next reply in the reply lane, if one comes within 50 ms; a
  /// malformed one is a failure, one announced as on ZeroMQ is for the socket.
  std::optional<wire::InMessage> takeFromLane() {
    wire::waitForDoorbell(doorbell_->bell(), wire::ShmOptions{}.spinS, 0.05, [this] { return link_->hasIncoming(); });
    auto item = link_->take();
    if (!item) return std::nullopt;
    EXPECT_NE(item->kind, wire::LaneItem::Kind::malformed) << "the solver wrote a malformed reply: " << item->error;
    if (item->kind != wire::LaneItem::Kind::message) return std::nullopt;
    return std::move(item->message);
  }

  std::string solverErr() {
    if (solver_ && !exited_) {
      solver_->signal(SIGKILL);
      solver_->wait(5);
      exited_ = true;
    }
    return solver_ ? solver_->err() : "";
  }

  /// The next data-channel message (heartbeats are counted, not returned).
  std::optional<wire::InMessage> receive(double timeoutS) {
    const double end = monotonicSeconds() + timeoutS;
    while (monotonicSeconds() < end) {
      if (link_) {
        if (auto m = takeFromLane()) return m;
      }
      auto r = router_->receive(std::chrono::milliseconds(link_ ? 0 : 50));
      if (!r) continue;
      if (r->identity == g_subject.instance + "#hb") {
        ++heartbeats_;
        continue;
      }
      EXPECT_EQ(r->identity, g_subject.instance);
      EXPECT_TRUE(r->message.has_value()) << "the solver sent a malformed message: " << r->error;
      if (r->message) return std::move(r->message);
    }
    return std::nullopt;
  }

  void welcome(double heartbeatTimeoutS = 10.0, std::uint16_t major = proto::PROTOCOL_MAJOR) {
    wire::OutMessage m;
    auto w = m.envelope().getBody().initWelcome();
    w.setProtocolMajor(major);
    w.setHeartbeatIntervalS(0.1);
    w.setHeartbeatTimeoutS(heartbeatTimeoutS);
    offerSharedMemory(w);
    ASSERT_TRUE(router_->send(g_subject.instance, m));
  }

  /// Sends a request with the next seq (or the given one) and waits for its answer.
  wire::InMessage request(wire::OutMessage& m, std::optional<std::uint64_t> seq = std::nullopt, double timeoutS = 60) {
    const auto s = seq.value_or(++seq_);
    m.envelope().setSeq(s);
    // On the shm path a request built elsewhere follows its "on ZeroMQ" descriptor.
    if (!link_ || !link_->post(m)) {
      EXPECT_TRUE(router_->send(g_subject.instance, m));
    }
    auto reply = receive(timeoutS);
    if (!reply) throw std::runtime_error("no reply within " + std::to_string(timeoutS) + " s");
    EXPECT_EQ(reply->envelope().getReplyTo(), s) << "a reply must name the request it answers";
    return std::move(*reply);
  }

  wire::InMessage setup() {
    wire::OutMessage m = message();
    auto s = m.envelope().getBody().initSetup();
    s.setSceneFile(g_subject.scene);
    s.setSceneYaml(readFile(g_subject.scene));
    s.setInstance(g_subject.instance);
    s.setRunDir((dir_ / "run").string());
    fs::create_directories(dir_ / "run");
    auto reply = request(m);
    if (!reply.envelope().getBody().isSetupDone())
      ADD_FAILURE() << "setup failed: " << describe(reply);
    else {
      const double c = reply.envelope().getBody().getSetupDone().getCriticalDt();
      EXPECT_TRUE(std::isfinite(c) && c >= 0.0) << "critical dt " << c;
      dt_ = c > 0.0 ? 0.5 * c : 1e-4;
    }
    return reply;
  }

  wire::InMessage advance(std::uint32_t steps, double dt, std::optional<std::uint64_t> seq = std::nullopt,
                          bool wantEnergies = true) {
    wire::OutMessage m = message();
    auto a = m.envelope().getBody().initAdvance();
    a.setWantEnergies(wantEnergies);
    a.setSteps(steps);
    a.setDt(dt);
    a.setTime(time_);
    a.setExchange(++exchange_);
    a.initInputs();
    return request(m, seq);
  }

  static std::string describe(const wire::InMessage& reply) {
    auto body = reply.envelope().getBody();
    if (body.isError()) return std::string("error: ") + body.getError().getMessage().cStr();
    return "'" + wire::bodyName(reply.envelope()) + "'";
  }

  static void expectError(const wire::InMessage& reply, Code code) {
    ASSERT_TRUE(reply.envelope().getBody().isError()) << "expected an error, got " << describe(reply);
    const auto e = reply.envelope().getBody().getError();
    EXPECT_EQ(e.getCode(), code) << e.getMessage().cStr();
    EXPECT_GT(e.getMessage().size(), 0u) << "an error must say what is wrong";
  }

  /// Everything an advance reply says about the state, as bytes.
  static std::vector<unsigned char> fingerprintOf(const wire::InMessage& reply) {
    auto a = reply.envelope().getBody().getAdvanced();
    capnp::MallocMessageBuilder b;
    auto copy = b.initRoot<proto::Advanced>();
    copy.setTime(a.getTime());
    copy.setStep(a.getStep());
    copy.setCriticalDt(a.getCriticalDt());
    copy.setEnergies(a.getEnergies());
    copy.setOutputs(a.getOutputs());
    auto flat = capnp::messageToFlatArray(b);
    auto bytes = flat.asBytes();
    return {bytes.begin(), bytes.end()};
  }

  void expectAlive() {
    wire::OutMessage m = message();
    m.envelope().getBody().initFieldsRequest();
    auto r = request(m);
    EXPECT_FALSE(r.envelope().getBody().isHello()) << "the solver restarted";
  }

  fs::path dir_;
  std::optional<wire::RouterSocket> router_;
  std::unique_ptr<wire::CouplerDoorbell> doorbell_;  // --data shm
  std::shared_ptr<wire::ShmLink> link_;
  std::optional<testing::Subprocess> solver_;
  std::optional<wire::InMessage> hello_;
  std::uint64_t seq_ = 0;
  std::uint64_t exchange_ = 0;
  double time_ = 0.0;
  double dt_ = 1e-4;
  int heartbeats_ = 0;
  bool exited_ = false;
};

TEST_F(Conformance, HelloDescribesTheSolver) {
  ASSERT_TRUE(hello_->envelope().getBody().isHello()) << "the first message must be hello, got " << describe(*hello_);
  const auto h = hello_->envelope().getBody().getHello();
  EXPECT_EQ(h.getProtocolMajor(), proto::PROTOCOL_MAJOR);
  EXPECT_GT(h.getSolverKind().size(), 0u);
  EXPECT_GT(h.getVersion().size(), 0u);
  EXPECT_EQ(std::string(h.getInstance().cStr()), g_subject.instance);
  EXPECT_EQ(static_cast<pid_t>(h.getPid()), solver_->pid());
  std::vector<std::string> caps;
  for (auto c : h.getCapabilities()) caps.emplace_back(c.cStr());
  for (const auto& needed : wire::baseCapabilities())
    EXPECT_NE(std::find(caps.begin(), caps.end(), needed), caps.end()) << "missing base capability " << needed;
}

TEST_F(Conformance, HeartbeatsFlowWhileIdle) {
  welcome();
  const double end = monotonicSeconds() + 1.0;
  while (monotonicSeconds() < end) receive(0.1);
  EXPECT_GE(heartbeats_, 3) << "heartbeat interval 0.1 s over 1 s";
}

TEST_F(Conformance, SetupThenAdvanceMovesTimeAndSteps) {
  welcome();
  setup();
  auto r = advance(3, dt_);
  ASSERT_TRUE(r.envelope().getBody().isAdvanced()) << describe(r);
  auto a = r.envelope().getBody().getAdvanced();
  EXPECT_NEAR(a.getTime(), 3 * dt_, 1e-12 * std::max(1.0, 3 * dt_));
  EXPECT_EQ(a.getStep(), 3u);
  EXPECT_GE(a.getComputeSeconds(), 0.0);
  for (auto e : a.getEnergies()) EXPECT_TRUE(std::isfinite(e.getValue())) << e.getName().cStr();
  time_ = a.getTime();
  r = advance(2, dt_);
  ASSERT_TRUE(r.envelope().getBody().isAdvanced()) << describe(r);
  EXPECT_EQ(r.envelope().getBody().getAdvanced().getStep(), 5u);
  EXPECT_NEAR(r.envelope().getBody().getAdvanced().getTime(), 5 * dt_, 1e-12 * std::max(1.0, 5 * dt_));
}

TEST_F(Conformance, EnergiesAreLeftOutUnlessAskedFor) {
  // The coupler asks only on exchanges that record them (a PD strain energy is a bond sweep).
  welcome();
  setup();
  auto r = advance(1, dt_, std::nullopt, false);
  ASSERT_TRUE(r.envelope().getBody().isAdvanced()) << describe(r);
  EXPECT_EQ(r.envelope().getBody().getAdvanced().getEnergies().size(), 0u);
  time_ += dt_;
  r = advance(1, dt_);
  ASSERT_TRUE(r.envelope().getBody().isAdvanced()) << describe(r);
  for (auto e : r.envelope().getBody().getAdvanced().getEnergies()) EXPECT_TRUE(std::isfinite(e.getValue()));
}

TEST_F(Conformance, FieldsAreServedAndUnknownNamesRejected) {
  welcome();
  setup();
  wire::OutMessage all = message();
  all.envelope().getBody().initFieldsRequest();
  auto r = request(all);
  EXPECT_TRUE(r.envelope().getBody().isFields()) << describe(r);
  wire::OutMessage bogus = message();
  bogus.envelope().getBody().initFieldsRequest().initNames(1).set(0, "no-such-field-xyz");
  expectError(request(bogus), Code::BAD_INPUT);
}

TEST_F(Conformance, CheckpointAndRestoreContinueBitForBit) {
  welcome();
  setup();
  ASSERT_TRUE(advance(2, dt_).envelope().getBody().isAdvanced());
  time_ = 2 * dt_;
  const auto path = (dir_ / "run" / "state.chk").string();
  wire::OutMessage chk = message();
  chk.envelope().getBody().initCheckpoint().setPath(path);
  auto done = request(chk);
  ASSERT_TRUE(done.envelope().getBody().isCheckpointDone()) << describe(done);
  EXPECT_GT(done.envelope().getBody().getCheckpointDone().getBytes(), 0u);
  EXPECT_TRUE(fs::exists(path));
  const auto exchangeAtCheckpoint = exchange_;
  const auto first = fingerprintOf(advance(3, dt_));

  wire::OutMessage restore = message();
  restore.envelope().getBody().initRestore().setPath(path);
  auto restored = request(restore);
  ASSERT_TRUE(restored.envelope().getBody().isRestored()) << describe(restored);
  EXPECT_EQ(restored.envelope().getBody().getRestored().getStep(), 2u);
  EXPECT_NEAR(restored.envelope().getBody().getRestored().getTime(), 2 * dt_, 1e-15);
  exchange_ = exchangeAtCheckpoint;
  const auto second = fingerprintOf(advance(3, dt_));
  EXPECT_EQ(first, second) << "the restored run must continue bit for bit";
}

TEST_F(Conformance, RestoreFromAMissingFileIsAnError) {
  welcome();
  setup();
  wire::OutMessage restore = message();
  restore.envelope().getBody().initRestore().setPath((dir_ / "nothing.chk").string());
  auto r = request(restore);
  ASSERT_TRUE(r.envelope().getBody().isError()) << describe(r);
  expectAlive();
}

TEST_F(Conformance, AdvanceBeforeSetupIsAnError) {
  welcome();
  expectError(advance(1, 1e-4), Code::UNEXPECTED);
  setup();  // still alive and usable
}

TEST_F(Conformance, InvalidAdvanceIsRejected) {
  welcome();
  setup();
  expectError(advance(0, dt_), Code::BAD_INPUT);
  expectError(advance(1, 0.0), Code::BAD_INPUT);
  expectError(advance(1, std::nan("")), Code::BAD_INPUT);
  expectError(advance(1, -dt_), Code::BAD_INPUT);
  ASSERT_TRUE(advance(1, dt_).envelope().getBody().isAdvanced());
}

TEST_F(Conformance, OutOfOrderSequenceIsAnError) {
  welcome();
  setup();  // seq 1
  expectError(advance(1, dt_, 1), Code::OUT_OF_ORDER);
  seq_ = 1;
  ASSERT_TRUE(advance(1, dt_).envelope().getBody().isAdvanced());
}

TEST_F(Conformance, MalformedBytesAreAnsweredNotFatal) {
  welcome();
  std::mt19937 rng(3);
  for (int i = 0; i < 20; ++i) {
    std::vector<char> junk(1 + rng() % 300);
    for (auto& c : junk) c = static_cast<char>(rng());
    zmq::message_t id(g_subject.instance.data(), g_subject.instance.size());
    router_->raw().send(id, zmq::send_flags::sndmore);
    zmq::message_t m(junk.data(), junk.size());
    router_->raw().send(m, zmq::send_flags::none);
    auto r = receive(10);
    ASSERT_TRUE(r.has_value()) << "no answer to garbage";
    expectError(*r, Code::MALFORMED);
  }
  setup();
}

TEST_F(Conformance, ReplyKindsAreNotAcceptedAsRequests) {
  welcome();
  setup();
  wire::OutMessage m = message();
  m.envelope().getBody().initAdvanced();
  expectError(request(m), Code::UNEXPECTED);
  expectAlive();
}

TEST_F(Conformance, ShutdownEndsTheProcessCleanly) {
  welcome();
  setup();
  wire::OutMessage m = message();
  m.envelope().getBody().initShutdown().setReason("conformance");
  auto r = request(m);
  EXPECT_TRUE(r.envelope().getBody().isShutdownDone()) << describe(r);
  EXPECT_EQ(solver_->wait(10), 0) << solver_->err();
  exited_ = true;
}

// A coupler of another protocol major cannot be understood: the solver says
// so, naming both versions, and leaves without waiting for a setup.
TEST_F(Conformance, AWelcomeOfAnotherProtocolMajorIsRefused) {
  welcome(10.0, static_cast<std::uint16_t>(proto::PROTOCOL_MAJOR + 1));
  const int code = solver_->wait(10);
  exited_ = true;
  EXPECT_FALSE(solver_->timedOut()) << "the solver stayed with a coupler it cannot understand";
  EXPECT_EQ(code, 3) << solver_->err();
  EXPECT_NE(solver_->err().find("the coupler speaks protocol " + std::to_string(proto::PROTOCOL_MAJOR + 1) + "."),
            std::string::npos) << solver_->err();
}

TEST_F(Conformance, LeavesWhenTheCouplerFallsSilent) {
  welcome(0.5);
  const int code = solver_->wait(10);
  exited_ = true;
  EXPECT_FALSE(solver_->timedOut()) << "the solver did not notice its coupler was gone";
  EXPECT_NE(code, 0);
}

}  // namespace
}  // namespace cosim::conformance

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  for (int i = 1; i + 1 < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--solver") cosim::conformance::g_subject.binary = argv[++i];
    else if (a == "--scene") cosim::conformance::g_subject.scene = argv[++i];
    else if (a == "--instance") cosim::conformance::g_subject.instance = argv[++i];
    else if (a == "--data") cosim::conformance::g_data = argv[++i];
  }
  return RUN_ALL_TESTS();
}
