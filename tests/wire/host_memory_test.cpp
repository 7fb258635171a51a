// What the solvers' size checks take as this process's memory: the tightest
// of the machine's memory, ulimit -v, the cgroup's memory.max (a Slurm job's
// --mem, a container's limit) and COSIM_MEMORY_LIMIT; a bad value of the
// variable is refused naming it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "cosim/util/host_memory.hpp"

namespace cosim::util {
namespace {

/// Sets COSIM_MEMORY_LIMIT for one scope.
struct MemoryLimit {
  explicit MemoryLimit(const char* value) { ::setenv("COSIM_MEMORY_LIMIT", value, 1); }
  ~MemoryLimit() { ::unsetenv("COSIM_MEMORY_LIMIT"); }
};

TEST(HostMemory, TheEnvironmentLimitCapsTheMachinesMemory) {
  const double machine = availableMemoryBytes();
  EXPECT_GT(machine, 0.0);
  {
    MemoryLimit limit("4194304");
    EXPECT_EQ(availableMemoryBytes(), 4194304.0);
  }
  {
    MemoryLimit limit("1e30");  // above the machine's: the machine's stands
    EXPECT_EQ(availableMemoryBytes(), machine);
  }
  EXPECT_EQ(availableMemoryBytes(), machine);
}

TEST(HostMemory, ABadEnvironmentLimitIsRefusedNamingIt) {
  for (const char* bad : {"4G", "-1", "0", "nan", "1e400"}) {
    MemoryLimit limit(bad);
    try {
      availableMemoryBytes();
      ADD_FAILURE() << "accepted COSIM_MEMORY_LIMIT=" << bad;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("COSIM_MEMORY_LIMIT"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
}

TEST(HostMemory, CgroupMemoryMaxIsReadAsBytesOrNone) {
  EXPECT_EQ(cgroupMemoryLimit("8589934592\n"), 8589934592.0);
  EXPECT_TRUE(std::isinf(cgroupMemoryLimit("max\n")));
  EXPECT_TRUE(std::isinf(cgroupMemoryLimit("9223372036854771712\n")));  // v1's "no limit"
  EXPECT_TRUE(std::isinf(cgroupMemoryLimit("")));
  EXPECT_TRUE(std::isinf(cgroupMemoryLimit("garbage")));
}

}  // namespace
}  // namespace cosim::util
