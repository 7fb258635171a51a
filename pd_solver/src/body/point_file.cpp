// Point clouds with volumes: one "x y z volume" line per particle.
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "cosim/pd/body.hpp"

namespace cosim::pd {

PointCloud readPointFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open point file");
  PointCloud cloud;
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
  }
  if (cloud.volumes.empty()) throw std::invalid_argument(path + ": no points in file");
  return cloud;
}

}  // namespace cosim::pd
