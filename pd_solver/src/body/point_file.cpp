// Point clouds with volumes: one "x y z volume" line per particle.
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <vector>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "cosim/pd/body.hpp"

namespace cosim::pd {
namespace {

/// Two points at one position would make a bond of zero length (a division
/// by zero in its strain): refused, naming both lines.
void requireDistinct(const PointCloud& cloud, const std::vector<int>& lines, const std::string& path) {
  std::vector<std::size_t> order(lines.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto at = [&](std::size_t i) {
    return std::array<double, 3>{cloud.positions[3 * i], cloud.positions[3 * i + 1], cloud.positions[3 * i + 2]};
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return at(a) < at(b); });
  for (std::size_t k = 1; k < order.size(); ++k)
    if (at(order[k]) == at(order[k - 1]))
      throw std::invalid_argument(path + ":" + std::to_string(lines[std::max(order[k], order[k - 1])]) +
                                  ": the point repeats line " + std::to_string(lines[std::min(order[k], order[k - 1])]));
}

}  // namespace

PointCloud readPointFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open point file");
  PointCloud cloud;
  std::vector<int> lines;  // of each point, for messages
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    std::string first;
    if (!(fields >> first)) continue;  // blank or comment
    std::istringstream all(line);
    double v[4];
    std::string token;
    for (int k = 0; k < 4; ++k) {
      if (!(all >> token))
        throw std::invalid_argument(path + ":" + std::to_string(lineNo) +
                                    ": expected 'x y z volume', got fewer than 4 values");
      try {
        std::size_t used = 0;
        v[k] = std::stod(token, &used);
        if (used != token.size()) throw std::invalid_argument("trailing");
      } catch (const std::exception&) {
        throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": '" + token +
                                    "' is not a number");
      }
      if (!std::isfinite(v[k]))
        throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": value " +
                                    std::to_string(k + 1) + " is NaN or infinite");
    }
    if (all >> token)
      throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": more than 4 values");
    if (!(v[3] > 0.0))
      throw std::invalid_argument(path + ":" + std::to_string(lineNo) +
                                  ": volume must be positive, got " + std::to_string(v[3]));
    cloud.positions.insert(cloud.positions.end(), v, v + 3);
    cloud.volumes.push_back(v[3]);
    lines.push_back(lineNo);
  }
  if (cloud.volumes.empty()) throw std::invalid_argument(path + ": no points in file");
  requireDistinct(cloud, lines, path);
  return cloud;
}

}  // namespace cosim::pd
