#include <gtest/gtest.h>

#include <filesystem>

#include "cosim/io/h5_file.hpp"

namespace cosim::io {
namespace {

TEST(H5, SeriesAppendFlushAndReadBack) {
  const auto path = std::filesystem::temp_directory_path() / ("cosim-h5-" + std::to_string(::getpid()) + ".h5");
  {
    auto f = H5File::create(path);
    SeriesWriter series(f, "/series");
    series.setUnits("time", "s");
    for (int i = 0; i < 1000; ++i) {
      series.append("time", i * 0.5);
      const double row[3] = {1.0 * i, 2.0 * i, 3.0 * i};
      series.append("solver/energy/kinetic", row);
      if (i == 499) series.flush();
    }
    EXPECT_EQ(series.rows("time"), 1000u);
    f.setAttribute("/", "scene", "unit-test");
  }
  auto f = H5File::openReadOnly(path);
  const auto time = f.readArray("/series/time");
  ASSERT_EQ(time.size(), 1000u);
  EXPECT_EQ(time[999], 499.5);
  EXPECT_EQ(f.shape("/series/solver/energy/kinetic"), (std::vector<std::size_t>{1000, 3}));
  EXPECT_EQ(f.readArray("/series/solver/energy/kinetic")[3 * 999 + 2], 3.0 * 999);
  EXPECT_TRUE(f.exists("/series/solver/energy"));
  EXPECT_FALSE(f.exists("/series/nothing/here"));
  std::filesystem::remove(path);
}

TEST(H5, ColumnCountMismatchNamesTheSeries) {
  const auto path = std::filesystem::temp_directory_path() / ("cosim-h5b-" + std::to_string(::getpid()) + ".h5");
  auto f = H5File::create(path);
  SeriesWriter series(f);
  series.append("x", 1.0);
  const double two[2] = {1, 2};
  try {
    series.append("x", two);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/series/x"), std::string::npos);
  }
  std::filesystem::remove(path);
}

TEST(H5, OpeningAMissingFileNamesIt) {
  try {
    H5File::openReadOnly("/nonexistent/dir/file.h5");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/file.h5"), std::string::npos);
  }
}

}  // namespace
}  // namespace cosim::io
