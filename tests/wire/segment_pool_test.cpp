// The segment pool hands out zeroed segments, reuses what came back, and a
// message built into a reused (previously dirty) segment reads exactly as one
// built into fresh memory: Cap'n Proto relies on unset fields being zero. A
// large payload goes to an unzeroed segment of its own, and such a segment is
// never lent for Cap'n Proto's structures.
#include <gtest/gtest.h>

#include <algorithm>
#include <capnp/serialize.h>
#include <memory>
#include <vector>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/message.hpp"
#include "cosim/wire/segment_pool.hpp"

namespace cosim::wire {
namespace {

constexpr std::size_t kBig = SegmentPool::kMinPooledWords * 4;

bool allZero(const SegmentPool::Segment& s) {
  return std::all_of(s.words, s.words + s.capacity, [](const capnp::word& w) {
    const auto* b = reinterpret_cast<const unsigned char*>(&w);
    return std::all_of(b, b + sizeof(w), [](unsigned char c) { return c == 0; });
  });
}

TEST(SegmentPool, ReusesAReleasedSegmentZeroed) {
  SegmentPool pool(std::size_t{64} << 20);
  auto a = pool.acquire(kBig);
  ASSERT_TRUE(allZero(a));
  std::fill_n(reinterpret_cast<unsigned char*>(a.words), 1000 * sizeof(capnp::word), 0xAB);
  capnp::word* first = a.words;
  pool.release(a, 1000);
  auto b = pool.acquire(kBig - 10);  // fits within twice the request
  EXPECT_EQ(b.words, first);
  EXPECT_TRUE(allZero(b));
  EXPECT_EQ(pool.stats().reused, 1u);
  pool.release(b, 0);
}

TEST(SegmentPool, DoesNotLendAFarLargerSegment) {
  SegmentPool pool(std::size_t{64} << 20);
  auto a = pool.acquire(kBig * 4);
  capnp::word* first = a.words;
  pool.release(a, 0);
  auto b = pool.acquire(kBig);  // less than half of what is kept
  EXPECT_NE(b.words, first);
  EXPECT_EQ(pool.stats().freeSegments, 1u);
  pool.release(b, 0);
}

TEST(SegmentPool, SmallSegmentsAndOverflowAreFreed) {
  SegmentPool pool(kBig * sizeof(capnp::word));  // room for one big segment
  pool.release(pool.acquire(64), 64);
  EXPECT_EQ(pool.stats().freeSegments, 0u);
  auto a = pool.acquire(kBig);
  auto b = pool.acquire(kBig);
  pool.release(a, 0);
  pool.release(b, 0);
  EXPECT_EQ(pool.stats().freeSegments, 1u);
  EXPECT_EQ(pool.stats().freeBytes, kBig * sizeof(capnp::word));
}

TEST(SegmentPool, MessageInReusedSegmentReadsAsFresh) {
  SegmentPool pool(std::size_t{64} << 20);
  std::vector<double> payload(kBig / 2, 3.5);
  {
    PooledMessageBuilder dirty(kBig, pool);
    auto env = dirty.getRoot<proto::Envelope>();
    env.setSeq(77);
    env.setReplyTo(78);
    auto advance = env.getBody().initAdvance();
    advance.setDt(0.25);
    addArray(advance.initInputs().initArrays(1), 0, "payload", 1, payload);
  }
  // The structures' first segment (capped) and the payload's own segment.
  EXPECT_EQ(pool.stats().freeSegments, 2u);
  PooledMessageBuilder reused(kBig, pool);
  auto env = reused.getRoot<proto::Envelope>();  // the first segment is taken here
  EXPECT_EQ(pool.stats().reused, 1u);
  env.getBody().initAdvance().setSteps(2);  // seq, replyTo, dt and inputs left unset
  auto reader = env.asReader();
  EXPECT_EQ(reader.getSeq(), 0u);
  EXPECT_EQ(reader.getReplyTo(), 0u);
  EXPECT_EQ(reader.getBody().getAdvance().getDt(), 0.0);
  EXPECT_EQ(reader.getBody().getAdvance().getSteps(), 2u);
  EXPECT_FALSE(reader.getBody().getAdvance().hasInputs());
}

TEST(SegmentPool, LargePayloadTakesAnUnzeroedSegmentOfItsOwn) {
  SegmentPool pool(std::size_t{64} << 20);
  std::vector<double> payload(kBig, 0.0);
  const capnp::word* payloadWords = nullptr;
  for (int round = 0; round < 3; ++round) {
    for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<double>(i) * (round + 1) - 0.5;
    auto builder = std::make_unique<PooledMessageBuilder>(kBig + 256, pool);
    builder->getRoot<proto::Envelope>().setSeq(static_cast<std::uint64_t>(round) + 1);
    addArray(builder->getRoot<proto::Envelope>().getBody().initAdvance().initInputs().initArrays(1), 0, "p", 1,
             payload);
    const auto segments = builder->getSegmentsForOutput();
    ASSERT_EQ(segments.size(), 2u) << "structures, then the payload with its landing pad";
    EXPECT_EQ(segments[1].size(), payload.size() + 1);
    if (round > 0) {
      EXPECT_EQ(segments[1].begin(), payloadWords) << "the payload segment came back and was reused";
    }
    payloadWords = segments[1].begin();
    // Read back through a flat copy, as a receiver would.
    const auto flat = capnp::messageToFlatArray(*builder);
    capnp::FlatArrayMessageReader reader(flat);
    const auto env = reader.getRoot<proto::Envelope>();
    EXPECT_EQ(env.getSeq(), static_cast<std::uint64_t>(round) + 1);
    const auto values = view(env.getBody().getAdvance().getInputs().getArrays()[0].getValues());
    ASSERT_EQ(values.size(), payload.size());
    EXPECT_TRUE(std::equal(values.begin(), values.end(), payload.begin()));
    builder.reset();
    // A message of structures only after it: never built into the dirty payload segment.
    PooledMessageBuilder structures(kBig * 2, pool);
    auto advance = structures.getRoot<proto::Envelope>().getBody().initAdvance();
    EXPECT_EQ(advance.asReader().getDt(), 0.0);
    EXPECT_FALSE(advance.asReader().hasInputs());
    for (const auto& seg : structures.getSegmentsForOutput()) EXPECT_NE(seg.begin(), payloadWords);
  }
}

TEST(SegmentPool, AnnouncedPayloadThatFitsStaysInTheStructuresSegment) {
  SegmentPool pool(std::size_t{64} << 20);
  std::vector<double> small(100, 1.25);
  PooledMessageBuilder builder(1024, pool);
  addArray(builder.getRoot<proto::Envelope>().getBody().initAdvance().initInputs().initArrays(1), 0, "p", 1, small);
  EXPECT_EQ(builder.getSegmentsForOutput().size(), 1u);
}

TEST(SegmentPool, OutMessagesRoundTripThroughReusedSegments) {
  // Through the process pool, as the sockets use it: frames keep the builder
  // alive; when the last frame goes, its segments return for the next message.
  for (int round = 0; round < 3; ++round) {
    std::vector<double> payload(kBig, 0.0);
    for (std::size_t i = 0; i < payload.size(); ++i) payload[i] = static_cast<double>(i * (round + 1));
    std::vector<zmq::message_t> frames;
    {
      OutMessage out(kBig + 256);
      out.envelope().setSeq(static_cast<std::uint64_t>(round) + 1);
      addArray(out.envelope().getBody().initAdvance().initInputs().initArrays(1), 0, "p", 1, payload);
      frames = out.frames();
    }
    std::vector<zmq::message_t> copies;  // what a receiver would get
    for (const auto& f : frames) copies.emplace_back(f.data(), f.size());
    frames.clear();
    const auto in = InMessage::decode(std::move(copies));
    EXPECT_EQ(in.envelope().getSeq(), static_cast<std::uint64_t>(round) + 1);
    const auto values = view(in.envelope().getBody().getAdvance().getInputs().getArrays()[0].getValues());
    ASSERT_EQ(values.size(), payload.size());
    EXPECT_TRUE(std::equal(values.begin(), values.end(), payload.begin()));
  }
  EXPECT_GE(SegmentPool::instance().stats().reused, 2u);
}

}  // namespace
}  // namespace cosim::wire
