// A corrupt checkpoint stops with the file's name and what is wrong, before
// any step reads out of bounds (an index past an array, arrays of different
// lengths, a count larger than the file, a NaN radius).
#include <gtest/gtest.h>

#include <functional>
#include <sstream>
#include <stdexcept>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/packing/packing.hpp"
#include "dem_test_util.hpp"

namespace cosim::dem::test {
namespace {

/// A small settled-ish system with a plane, a triangle wall and contacts.
DemSystem smallSystem() {
  DemSystem s = softGlassPacking({0, 0, 0}, {0.01, 0.01, 0.01}, 0.0007, 0.001, 60, 3);
  s.planes.push_back(PlaneWall{});
  TriangleWallGroup lid;
  lid.name = "lid";
  lid.vertices = {{-0.01, -0.01, 0.0105}, {0.03, -0.01, 0.0105}, {-0.01, 0.03, 0.0105}};
  lid.velocities.assign(3, Vec3{});
  lid.triangles = {{0, 2, 1}};
  s.meshes.push_back(lid);
  s.gravity = {0, 0, -9.81};
  s.neighbors.skin = 1e-4;
  s.initialize();
  for (int k = 0; k < 20; ++k) s.advance(1e-5);
  return s;
}

/// The message readCheckpoint gives for `s` changed by `corrupt`, or "" when it accepts it.
std::string restoreError(const std::function<void(DemSystem&)>& corrupt) {
  DemSystem s = smallSystem();
  corrupt(s);
  std::stringstream buffer;
  writeCheckpoint(s, buffer, "cell.ckpt");
  DemSystem restored;
  try {
    readCheckpoint(restored, buffer, "cell.ckpt");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(DemCheckpoint, AnIntactCheckpointRestores) {
  EXPECT_EQ(restoreError([](DemSystem&) {}), "");
}

TEST(DemCheckpoint, IndicesOutOfRangeAreRefusedWithTheFileName) {
  const std::vector<std::pair<std::function<void(DemSystem&)>, std::string>> cases = {
      {[](DemSystem& s) { s.neighbors.partner.at(0) = 0xFFFFFFF0u; }, "neighbour partner out of range"},
      {[](DemSystem& s) { s.neighbors.rowStart.at(3) = 1u << 30; }, "neighbour list rows do not match"},
      {[](DemSystem& s) { s.neighbors.revPair.at(0) = 1u << 30; }, "reverse neighbour pair out of range"},
      {[](DemSystem& s) { s.particles.material.at(5) = 7; }, "particle material out of range"},
      {[](DemSystem& s) { s.particles.material.pop_back(); }, "particle arrays of different lengths"},
      {[](DemSystem& s) { s.particles.x.pop_back(); }, "particle arrays of different lengths"},
      {[](DemSystem& s) { s.particles.radius.at(2) = std::nan(""); }, "radius not positive and finite"},
      {[](DemSystem& s) { s.particles.mass.at(2) = 0.0; }, "mass or inertia not positive and finite"},
      {[](DemSystem& s) { s.particles.x.at(4).z = std::nan(""); }, "non-finite position or velocity"},
      {[](DemSystem& s) { s.meshes.at(0).triangles.at(0)[1] = 9; }, "triangle vertex out of range"},
      {[](DemSystem& s) { s.meshes.at(0).history.at(1)[0].triangle = 4; }, "contact history triangle out of range"},
      {[](DemSystem& s) { s.meshes.at(0).candTri.push_back(0); }, "candidates rows do not match"},
      {[](DemSystem& s) { s.planeShear.at(0).pop_back(); }, "contact arrays do not match the particles"},
      {[](DemSystem& s) { s.time = std::nan(""); }, "non-finite time"},
      // The periodic pair loop reads one image per pair (a fuzzed checkpoint
      // whose cell was periodic without them read through a null pointer).
      {[](DemSystem& s) {
         s.cell.enabled = true;
         s.cell.h = {0.02, 0, 0, 0, 0.02, 0, 0, 0, 0.02};
         s.neighbors.image.clear();
       },
       "periodic images do not match the neighbour list"},
      {[](DemSystem& s) { s.neighbors.image.assign(s.neighbors.partner.size(), {0, 0, 0}); },
       "periodic images without a periodic cell"},
  };
  for (const auto& [corrupt, expected] : cases) {
    const std::string message = restoreError(corrupt);
    EXPECT_NE(message.find("cell.ckpt: inconsistent checkpoint"), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << "expected '" << expected << "' in: " << message;
  }
}

TEST(DemCheckpoint, ACountLargerThanTheFileIsRefusedBeforeAllocating) {
  DemSystem s = smallSystem();
  std::stringstream buffer;
  writeCheckpoint(s, buffer, "cell.ckpt");
  std::string bytes = buffer.str();
  // particles.x: its count followed by the first position, which is unique
  // in the file. Make the count huge.
  const std::uint64_t n = s.particles.size();
  std::string needle(reinterpret_cast<const char*>(&n), sizeof n);
  needle.append(reinterpret_cast<const char*>(&s.particles.x[0]), sizeof(Vec3));
  const std::size_t at = bytes.find(needle);
  ASSERT_NE(at, std::string::npos);
  const std::uint64_t huge = std::uint64_t{1} << 38;
  bytes.replace(at, sizeof huge, reinterpret_cast<const char*>(&huge), sizeof huge);
  std::stringstream corrupt(bytes);
  DemSystem restored;
  try {
    readCheckpoint(restored, corrupt, "cell.ckpt");
    FAIL() << "accepted a count of 2^38";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cell.ckpt: corrupt checkpoint"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("more than the file holds"), std::string::npos) << e.what();
  }
  // Truncated anywhere: refused, never crashed.
  for (std::size_t cut : {std::size_t{20}, bytes.size() / 3, buffer.str().size() - 8}) {
    std::stringstream part(buffer.str().substr(0, cut));
    DemSystem r;
    EXPECT_THROW(readCheckpoint(r, part, "cell.ckpt"), std::runtime_error) << cut;
  }
}

}  // namespace
}  // namespace cosim::dem::test
