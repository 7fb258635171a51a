#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "cosim/dem/packing/packing.hpp"
#include "cosim/io/h5_file.hpp"

namespace cosim::dem {
namespace {

SphereSet readCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot open particle file");
  SphereSet s;
  std::string line;
  int lineNo = 0;
  bool first = true;
  while (std::getline(in, line)) {
    ++lineNo;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.find_first_not_of(" \t\r,") == std::string::npos) continue;
    for (char& c : line)
      if (c == ',' || c == ';' || c == '\t') c = ' ';
    std::istringstream fields(line);
    std::vector<double> v;
    std::string tok;
    int col = 0;
    bool header = false;
    while (fields >> tok) {
      ++col;
      std::size_t used = 0;
      double value = 0.0;
      try {
        value = std::stod(tok, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tok.size()) {
        if (first) {  // one header line of column names is allowed
          header = true;
          break;
        }
        throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": column " + std::to_string(col) +
                                    ": '" + tok + "' is not a number");
      }
      if (!std::isfinite(value))
        throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": column " + std::to_string(col) +
                                    ": non-finite value '" + tok + "'");
      v.push_back(value);
    }
    first = false;
    if (header) continue;
    if (v.size() != 4 && v.size() != 7)
      throw std::invalid_argument(path + ":" + std::to_string(lineNo) + ": expected 4 (x y z r) or 7 (x y z r vx vy vz) "
                                  "columns, found " + std::to_string(v.size()));
    s.centres.push_back({v[0], v[1], v[2]});
    s.radii.push_back(v[3]);
    s.velocities.push_back(v.size() == 7 ? Vec3{v[4], v[5], v[6]} : Vec3{});
    s.origin.push_back(path + ":" + std::to_string(lineNo));
  }
  return s;
}

SphereSet readHdf5(const std::string& path) {
  const io::H5File file = io::H5File::openReadOnly(path);
  for (const char* name : {"/positions", "/radii"})
    if (!file.exists(name)) throw std::invalid_argument(path + ": missing dataset " + name);
  const std::vector<double> x = file.readArray("/positions"), r = file.readArray("/radii");
  if (x.size() != 3 * r.size())
    throw std::invalid_argument(path + ": /positions has " + std::to_string(x.size()) + " values for " +
                                std::to_string(r.size()) + " radii (need N x 3)");
  std::vector<double> v;
  if (file.exists("/velocities")) {
    v = file.readArray("/velocities");
    if (v.size() != x.size()) throw std::invalid_argument(path + ": /velocities must be N x 3 like /positions");
  }
  SphereSet s;
  for (std::size_t i = 0; i < r.size(); ++i) {
    for (std::size_t k = 0; k < 3; ++k)
      if (!std::isfinite(x[3 * i + k]) || (!v.empty() && !std::isfinite(v[3 * i + k])))
        throw std::invalid_argument(path + ": particle " + std::to_string(i) + ": non-finite position or velocity");
    if (!std::isfinite(r[i])) throw std::invalid_argument(path + ": particle " + std::to_string(i) + ": non-finite radius");
    s.centres.push_back({x[3 * i], x[3 * i + 1], x[3 * i + 2]});
    s.radii.push_back(r[i]);
    s.velocities.push_back(v.empty() ? Vec3{} : Vec3{v[3 * i], v[3 * i + 1], v[3 * i + 2]});
    s.origin.push_back(path + ": particle " + std::to_string(i));
  }
  return s;
}

}  // namespace

SphereSet readSphereFile(const std::string& path) {
  if (!std::filesystem::exists(path)) throw std::invalid_argument(path + ": particle file not found");
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext == ".h5" || ext == ".hdf5") return readHdf5(path);
  return readCsv(path);
}

}  // namespace cosim::dem
