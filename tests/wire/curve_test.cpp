// CurveZMQ on tcp: a peer with the coupler's public key gets through, a peer
// without it (or with another key) is never heard.
#include <gtest/gtest.h>

#include "cosim/wire/sockets.hpp"

namespace cosim::wire {
namespace {

OutMessage hello() {
  OutMessage m;
  m.envelope().getBody().initHello().setInstance("x");
  return m;
}

TEST(Curve, OnlyPeersWithTheServerKeyAreHeard) {
  const auto keys = CurveKeyPair::generate();
  ASSERT_EQ(keys.publicKey.size(), 40u);
  RouterSocket router("tcp://127.0.0.1:*", keys);

  DealerSocket plain(router.endpoint(), "plain");
  plain.send(hello());
  DealerSocket wrongKey(router.endpoint(), "wrong", CurveKeyPair::generate().publicKey);
  wrongKey.send(hello());
  EXPECT_FALSE(router.receive(std::chrono::milliseconds(500)).has_value());

  DealerSocket keyed(router.endpoint(), "keyed", keys.publicKey);
  keyed.send(hello());
  // Generous: the CURVE handshake shares two cores with the rest of a
  // parallel ctest run. (The test failed once in such a run; which check
  // failed was not recorded, so this is a guess at the likeliest one.)
  auto got = router.receive(std::chrono::milliseconds(30000));
  ASSERT_TRUE(got && got->message);
  EXPECT_EQ(got->identity, "keyed");
  EXPECT_FALSE(router.receive(std::chrono::milliseconds(200)).has_value());
}

TEST(Curve, MalformedServerKeyIsRefusedWithAReason) {
  try {
    DealerSocket bad("tcp://127.0.0.1:1", "x", "too-short");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("40 Z85 characters"), std::string::npos);
  }
}

}  // namespace
}  // namespace cosim::wire
