// The shared-memory data path on its own: messages built in one end's lane
// are read in place by the other, in order, with their payloads intact; the
// writer reuses what the reader let go of, so the file stays at the size of
// what is held at once; a message from elsewhere is announced as travelling
// on ZeroMQ; a reader holding every descriptor makes the writer say so
// instead of overwriting; a descriptor pointing outside the lane is refused;
// a doorbell wakes a process sleeping on it in another process.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <vector>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/clock.hpp"
#include "cosim/wire/shm_layout.hpp"
#include "cosim/wire/shm_link.hpp"

namespace cosim::wire {
namespace {
namespace fs = std::filesystem;
using Which = proto::Envelope::Body::Which;

class ShmLinkTest : public ::testing::Test {
 protected:
  ShmLinkTest() {
    dir_ = fs::temp_directory_path() / ("shm-link-test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    doorbell_ = std::make_unique<CouplerDoorbell>((dir_ / "doorbell").string());
    coupler_ = ShmLink::create((dir_ / "beam").string(), std::uint64_t{1} << 30, *doorbell_);
    solver_ = ShmLink::open((dir_ / "beam").string(), (dir_ / "doorbell").string());
  }
  ~ShmLinkTest() override {
    solver_.reset();
    coupler_.reset();
    doorbell_.reset();
    fs::remove_all(dir_);
  }

  /// An advance request at `exchange` with a payload of n values k + exchange.
  OutMessage advance(std::uint32_t exchange, std::size_t n) {
    OutMessage m = coupler_->message(256);
    auto adv = m.envelope().getBody().initAdvance();
    adv.setExchange(exchange);
    std::vector<double> values(n);
    std::iota(values.begin(), values.end(), static_cast<double>(exchange));
    addArray(adv.initInputs().initArrays(1), 0, "u", 1, values);
    return m;
  }

  static void expectAdvance(const LaneItem& item, std::uint32_t exchange, std::size_t n) {
    ASSERT_EQ(item.kind, LaneItem::Kind::message) << item.error;
    auto adv = item.message->envelope().getBody().getAdvance();
    EXPECT_EQ(adv.getExchange(), exchange);
    const auto values = view(adv.getInputs().getArrays()[0].getValues());
    ASSERT_EQ(values.size(), n);
    for (std::size_t k = 0; k < n; k += 997) EXPECT_EQ(values[k], static_cast<double>(exchange + k));
  }

  std::uintmax_t allocatedBytes() const {
    struct stat st {};
    ::stat((dir_ / "beam").c_str(), &st);
    return static_cast<std::uintmax_t>(st.st_blocks) * 512;
  }

  fs::path dir_;
  std::unique_ptr<CouplerDoorbell> doorbell_;
  std::shared_ptr<ShmLink> coupler_, solver_;
};

TEST_F(ShmLinkTest, CarriesRequestsAndRepliesInOrderWithTheirPayloads) {
  for (std::uint32_t e = 1; e <= 3; ++e) ASSERT_TRUE(coupler_->post(advance(e, 100000)));
  EXPECT_TRUE(solver_->hasIncoming());
  for (std::uint32_t e = 1; e <= 3; ++e) {
    auto item = solver_->take();
    ASSERT_TRUE(item);
    expectAdvance(*item, e, 100000);
    EXPECT_GE(item->bytes, 100000 * sizeof(double));
  }
  EXPECT_FALSE(solver_->take());
  // The reply lane rings the coupler's doorbell.
  const auto rings = doorbell_->bell().rings.load();
  OutMessage reply = solver_->message(64);
  reply.envelope().setReplyTo(3);
  reply.envelope().getBody().setShutdownDone();
  ASSERT_TRUE(solver_->post(reply));
  EXPECT_EQ(doorbell_->bell().rings.load(), rings + 1);
  auto item = coupler_->take();
  ASSERT_TRUE(item && item->kind == LaneItem::Kind::message);
  EXPECT_EQ(item->message->envelope().getReplyTo(), 3u);
  EXPECT_EQ(item->message->envelope().getBody().which(), Which::SHUTDOWN_DONE);
}

TEST_F(ShmLinkTest, ReusesWhatTheReaderLetGoOf) {
  // 200 messages of 8 MB, one held at a time: the lane needs room for two
  // (the next is built while the reader still holds the last), not 200.
  std::optional<LaneItem> held;
  for (std::uint32_t e = 1; e <= 200; ++e) {
    ASSERT_TRUE(coupler_->post(advance(e, 1'000'000)));
    auto item = solver_->take();
    ASSERT_TRUE(item);
    if (e % 50 == 0) expectAdvance(*item, e, 1'000'000);
    held = std::move(item);
  }
  EXPECT_LT(allocatedBytes(), std::uintmax_t{48} << 20);
}

TEST_F(ShmLinkTest, AMessageBuiltElsewhereIsAnnouncedAsTravellingOnZeroMq) {
  OutMessage heap(64);
  heap.envelope().getBody().setShutdownDone();
  EXPECT_FALSE(coupler_->post(heap));
  ASSERT_TRUE(coupler_->post(advance(7, 10)));
  auto first = solver_->take();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->kind, LaneItem::Kind::onZmq);
  auto second = solver_->take();
  ASSERT_TRUE(second);
  expectAdvance(*second, 7, 10);
}

TEST_F(ShmLinkTest, AReaderHoldingEveryDescriptorIsNotOverwritten) {
  std::vector<LaneItem> held;
  for (unsigned e = 1; e <= shm_layout::kSlots; ++e) {
    ASSERT_TRUE(coupler_->post(advance(e, 10)));
    held.push_back(std::move(*solver_->take()));
  }
  EXPECT_FALSE(coupler_->post(advance(999, 10)));  // goes by ZeroMQ, unannounced
  EXPECT_FALSE(solver_->take());
  for (unsigned e = 1; e <= shm_layout::kSlots; ++e) expectAdvance(held[e - 1], e, 10);
  held.clear();
  ASSERT_TRUE(coupler_->post(advance(1000, 10)));
  auto item = solver_->take();
  ASSERT_TRUE(item);
  expectAdvance(*item, 1000, 10);
}

TEST_F(ShmLinkTest, ADescriptorOutsideTheLaneIsRefusedAsMalformed) {
  ASSERT_TRUE(coupler_->post(advance(1, 10)));
  // A corrupt writer: the descriptor of message 0 points past the arena.
  const int fd = ::open((dir_ / "beam").c_str(), O_RDWR);
  ASSERT_GE(fd, 0);
  void* p = ::mmap(nullptr, shm_layout::kHeaderBytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ::close(fd);
  ASSERT_NE(p, MAP_FAILED);
  auto* header = static_cast<shm_layout::SegmentHeader*>(p);
  header->lanes[0].slots[0].offsets[0] = std::uint64_t{1} << 40;
  auto item = solver_->take();
  ::munmap(p, shm_layout::kHeaderBytes);
  ASSERT_TRUE(item);
  EXPECT_EQ(item->kind, LaneItem::Kind::malformed);
  EXPECT_NE(item->error.find("outside the lane"), std::string::npos) << item->error;
}

TEST_F(ShmLinkTest, TheOtherEndsFileMustBeASegment) {
  const auto bogus = dir_ / "bogus";
  { std::ofstream(bogus) << std::string(100000, 'x'); }
  try {
    ShmLink::open(bogus.string(), (dir_ / "doorbell").string());
    FAIL() << "a file of x's was taken for a segment";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bogus"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ShmLink::create((dir_ / "beam").string(), 1 << 20, *doorbell_), std::runtime_error);  // exists
}

TEST_F(ShmLinkTest, ADoorbellWakesASleeperInAnotherProcess) {
  Doorbell& bell = solver_->incomingBell();
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // The child sleeps (no spin) until the request is there: 5 s at most.
    const bool got = waitForDoorbell(bell, 0.0, 5.0, [&] { return solver_->hasIncoming(); });
    ::_exit(got ? 0 : 1);
  }
  ::usleep(100000);  // let it fall asleep
  const double sent = monotonicSeconds();
  ASSERT_TRUE(coupler_->post(advance(1, 10)));
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  EXPECT_LT(monotonicSeconds() - sent, 2.0);  // woken, not timed out
}

}  // namespace
}  // namespace cosim::wire
