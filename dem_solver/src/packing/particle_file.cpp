#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "cosim/dem/packing/packing.hpp"
#include "cosim/io/h5_file.hpp"

namespace cosim::dem {
namespace {

enum class Token { number, text, outOfRange };

Token parseToken(const std::string& tok, double& value) {
  std::size_t used = 0;
  try {
    value = std::stod(tok, &used);
  } catch (const std::out_of_range&) {
    return Token::outOfRange;
  } catch (const std::exception&) {
    return Token::text;
  }
  return used == tok.size() ? Token::number : Token::text;
}

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
    std::vector<std::string> tokens;
    for (std::string tok; fields >> tok;) tokens.push_back(tok);
    std::vector<double> v(tokens.size());
    std::vector<Token> kinds(tokens.size());
    for (std::size_t c = 0; c < tokens.size(); ++c) kinds[c] = parseToken(tokens[c], v[c]);
    // One header line of column names is allowed, and only names: a data line
    // with one mistyped number must not pass for a header and vanish.
    const bool header = first && std::none_of(kinds.begin(), kinds.end(), [](Token k) { return k != Token::text; });
    first = false;
    if (header) continue;
    for (std::size_t c = 0; c < tokens.size(); ++c) {
      const std::string where = path + ":" + std::to_string(lineNo) + ": column " + std::to_string(c + 1) + ": ";
      if (kinds[c] == Token::text) throw std::invalid_argument(where + "'" + tokens[c] + "' is not a number");
      if (kinds[c] == Token::outOfRange || !std::isfinite(v[c]))
        throw std::invalid_argument(where + "value '" + tokens[c] + "' is not finite or out of double range");
    }
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

/// An N x 3 dataset: rank 2 with three columns (a 3 x N array has the right
/// number of values and the wrong layout).
void requireRows3(const io::H5File& file, const std::string& path, const char* name, std::size_t rows) {
  const std::vector<std::size_t> shape = file.shape(name);
  if (shape.size() != 2 || shape[1] != 3 || shape[0] != rows) {
    std::string dims;
    for (std::size_t d : shape) dims += (dims.empty() ? "" : " x ") + std::to_string(d);
    throw std::invalid_argument(path + ": " + name + " has shape (" + dims + "), need " + std::to_string(rows) +
                                " x 3 (one row per radius)");
  }
}

SphereSet readHdf5(const std::string& path) {
  const io::H5File file = io::H5File::openReadOnly(path);
  for (const char* name : {"/positions", "/radii"})
    if (!file.exists(name)) throw std::invalid_argument(path + ": missing dataset " + name);
  const std::vector<double> r = file.readArray("/radii");
  requireRows3(file, path, "/positions", r.size());
  const std::vector<double> x = file.readArray("/positions");
  std::vector<double> v;
  if (file.exists("/velocities")) {
    requireRows3(file, path, "/velocities", r.size());
    v = file.readArray("/velocities");
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
