#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "cosim/io/h5_file.hpp"
#include "cosim/io/xdmf.hpp"

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

// A writer killed between HDF5 flushes leaves links whose object headers are
// not on disk; the test writes zeros over one header to make that state.
// HDF5 cannot unlink such an object, so a resumed run rewrites the file
// without the snapshots after its checkpoint instead.
TEST(H5, AResumeRewritesTheFileWithoutSnapshotsAKilledWriterLeftUnreadable) {
  const auto path = std::filesystem::temp_directory_path() / ("cosim-h5-resume-" + std::to_string(::getpid()) + ".h5");
  const XdmfTimeSeries::Topology points{};
  {
    auto f = H5File::create(path);
    f.setAttribute("/", "solver", "test");
    const std::vector<double> mesh{1, 2, 3, 4, 5, 6};
    f.writeArray("/mesh/coordinates", mesh, 3);
    for (int k = 1; k <= 4; ++k) {
      const std::string g = "/snapshots/" + std::to_string(k);
      const std::vector<double> x(3 * k, k);
      f.writeArray(g + "/position", x, 3);
      f.setAttribute(g, "time", 0.5 * k);
    }
  }
  H5O_info_t info{};
  {
    auto f = H5File::openReadOnly(path);
    ASSERT_GE(H5Oget_info_by_name(f.id(), "/snapshots/4", &info, H5P_DEFAULT), 0);
  }
  {
    std::fstream raw(path, std::ios::in | std::ios::out | std::ios::binary);
    raw.seekp(static_cast<std::streamoff>(info.addr));
    const std::string zeros(64, '\0');
    raw.write(zeros.data(), static_cast<std::streamsize>(zeros.size()));
  }
  {
    auto f = H5File::openForAppend(path);
    EXPECT_LT(H5Ldelete(f.id(), "/snapshots/4", H5P_DEFAULT), 0) << "the damaged snapshot can be unlinked in place";
  }
  {
    auto f = H5File::openForAppend(path);
    XdmfTimeSeries xdmf(path, "test", points, "position", {});
    ASSERT_NO_THROW(xdmf.resumeAt(f, 3));
    EXPECT_EQ(f.children("/snapshots"), (std::vector<std::string>{"1", "2", "3"}));
    EXPECT_EQ(f.attribute("/snapshots/3", "time", 0.0), 1.5);
    EXPECT_EQ(f.readArray("/snapshots/2/position"), std::vector<double>(6, 2.0));
    EXPECT_EQ(f.readArray("/mesh/coordinates"), (std::vector<double>{1, 2, 3, 4, 5, 6}));
    const std::vector<double> again(3, 4.0);
    f.writeArray("/snapshots/4/position", again, 3);  // the resumed run writes step 4 again
  }
  auto f = H5File::openReadOnly(path);
  EXPECT_EQ(f.readArray("/snapshots/4/position"), std::vector<double>(3, 4.0));
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".rewrite"));
  char solver[5] = {};
  const hid_t a = H5Aopen(f.id(), "solver", H5P_DEFAULT);
  ASSERT_GE(a, 0) << "the root attributes were not copied";
  const hid_t type = H5Aget_type(a);
  H5Aread(a, type, solver);
  H5Tclose(type);
  H5Aclose(a);
  EXPECT_EQ(std::string(solver, 4), "test");
  std::filesystem::remove(path);
  std::filesystem::remove(std::filesystem::path(path).replace_extension(".xmf"));
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
