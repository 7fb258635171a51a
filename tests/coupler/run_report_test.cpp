// The run report's host line: busy, idle and steal time; steal as a share of the machine's time.
#include <gtest/gtest.h>

#include "cosim/coupler/analysis/run_report.hpp"

namespace cosim::coupler {
namespace {

TEST(RunReport, StealIsAShareOfEveryCpusWallTime) {
  RunReport r;
  r.wallS = 10.0;
  EXPECT_EQ(r.stealShare(), 0.0);  // unknown host
  EXPECT_EQ(r.text().find("host "), std::string::npos);
  r.host = util::HostCpuTimes{15.0, 4.0, 1.0, 2};
  EXPECT_DOUBLE_EQ(r.stealShare(), 0.05);
  const auto text = r.text();
  EXPECT_NE(text.find("host          2 CPUs busy 15.000 s, idle 4.000 s, steal 1.000 s (5.000 % of their time)"), std::string::npos)
      << text;
}

}  // namespace
}  // namespace cosim::coupler
