// /proc/stat's CPU times: the parse, and the live reading a run report uses.
#include <gtest/gtest.h>

#include <chrono>

#include "cosim/util/host_cpu_time.hpp"

namespace cosim::util {
namespace {

TEST(HostCpuTime, ParsesTheTotalLineAndCountsTheCpus) {
  const std::string text =
      "cpu  100 20 30 400 50 6 7 80 11 0\n"
      "cpu0 50 10 15 200 25 3 3 40 5 0\n"
      "cpu1 50 10 15 200 25 3 4 40 6 0\n"
      "intr 12345 0 0\n"
      "ctxt 999\n";
  const auto t = parseProcStat(text, 100.0);
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->cpus, 2);
  EXPECT_DOUBLE_EQ(t->busyS, (100 + 20 + 30 + 6 + 7) / 100.0);  // guest (11) is inside user
  EXPECT_DOUBLE_EQ(t->idleS, (400 + 50) / 100.0);
  EXPECT_DOUBLE_EQ(t->stealS, 0.8);
  const auto later = parseProcStat("cpu  150 20 30 500 50 6 7 130\ncpu0 0 0 0 0 0 0 0 0\n", 100.0);
  ASSERT_TRUE(later.has_value());
  const auto d = *later - *t;
  EXPECT_DOUBLE_EQ(d.busyS, 0.5);
  EXPECT_DOUBLE_EQ(d.idleS, 1.0);
  EXPECT_DOUBLE_EQ(d.stealS, 0.5);
  EXPECT_EQ(d.cpus, 1);
}

TEST(HostCpuTime, RefusesTextWithoutAWholeTotalLine) {
  EXPECT_FALSE(parseProcStat("cpu0 1 2 3 4 5 6 7 8\n", 100.0).has_value());
  EXPECT_FALSE(parseProcStat("cpu  1 2 3\n", 100.0).has_value());  // a kernel older than steal
  EXPECT_FALSE(parseProcStat("cpu  1 2 3 4 5 6 7 x\n", 100.0).has_value());
  EXPECT_FALSE(parseProcStat("cpu  1 2 3 4 5 6 7 8\n", 0.0).has_value());
}

TEST(HostCpuTime, LiveReadingsGrowWithWork) {
  const auto before = readHostCpuTimes();
  ASSERT_TRUE(before.has_value()) << "/proc/stat unreadable on this Linux machine";
  EXPECT_GE(before->cpus, 1);
  // 100 ms of spinning is 10 ticks of this process alone.
  volatile double sink = 0.0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(100);
  while (std::chrono::steady_clock::now() < end) sink = sink + 1.0;
  const auto after = readHostCpuTimes();
  ASSERT_TRUE(after.has_value());
  const auto d = *after - *before;
  EXPECT_GE(d.busyS + d.stealS, 0.05);
  EXPECT_GE(d.busyS, 0.0);
  EXPECT_GE(d.stealS, 0.0);
}

}  // namespace
}  // namespace cosim::util
