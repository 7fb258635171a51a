// A payload far beyond Cap'n Proto's default 64 MiB traversal limit crosses a
// real ipc socket both ways, intact.
#include <gtest/gtest.h>

#include <filesystem>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/endpoint.hpp"
#include "cosim/wire/sockets.hpp"

namespace cosim::wire {
namespace {

TEST(LargePayload, TwoHundredMiBRoundTripsOverIpc) {
  const auto dir = std::filesystem::temp_directory_path() / ("cosim-large-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  RouterSocket router(bindEndpoint({}, dir));
  DealerSocket dealer(router.endpoint(), "big");

  const std::size_t n = 200ull * 1024 * 1024 / sizeof(double);
  std::uint64_t sentPrint = 0;
  {
    OutMessage out(n + 1024);
    auto arrays = out.envelope().getBody().initAdvanced().initOutputs().initArrays(1);
    auto a = arrays[0];
    a.setName("payload");
    auto values = view(a.initValues(static_cast<unsigned>(n)));
    for (std::size_t i = 0; i < n; ++i) values[i] = static_cast<double>(i) * 1.5 - 7.0;
    sentPrint = fingerprint(values);
    ASSERT_GT(out.sizeInBytes(), 200ull * 1024 * 1024);
    dealer.send(out);
  }
  auto got = router.receive(std::chrono::milliseconds(60000));
  ASSERT_TRUE(got.has_value());
  ASSERT_TRUE(got->message.has_value()) << got->error;
  EXPECT_EQ(got->identity, "big");
  auto values = view(got->message->envelope().getBody().getAdvanced().getOutputs().getArrays()[0].getValues());
  ASSERT_EQ(values.size(), n);
  EXPECT_EQ(fingerprint(values), sentPrint);

  // And back: the coupler side sends the same 200 MiB to the solver side.
  {
    OutMessage back(n + 1024);
    auto arrays = back.envelope().getBody().initAdvance().initInputs().initArrays(1);
    addArray(arrays, 0, "payload", 1, values);
    ASSERT_TRUE(router.send("big", back));
  }
  got.reset();  // release the first copy before the second arrives
  auto echoed = dealer.receive(std::chrono::milliseconds(60000));
  ASSERT_TRUE(echoed && echoed->message) << (echoed ? echoed->error : "timeout");
  auto again = view(echoed->message->envelope().getBody().getAdvance().getInputs().getArrays()[0].getValues());
  ASSERT_EQ(again.size(), n);
  EXPECT_EQ(fingerprint(again), sentPrint);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cosim::wire
