#include "cosim/util/host_memory.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace cosim::util {
namespace {

constexpr double kUnlimited = std::numeric_limits<double>::infinity();

/// The cgroup (v2) this process is in, from /proc/self/cgroup ("0::/path").
std::string ownCgroup() {
  std::ifstream in("/proc/self/cgroup");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("0::", 0) == 0) return line.substr(3);
  return {};
}

/// The tightest memory.max from the process's cgroup up to the root: a
/// parent's limit binds its children too.
double cgroupLimit() {
  const std::string group = ownCgroup();
  if (group.empty()) return kUnlimited;
  double limit = kUnlimited;
  for (std::string path = group; !path.empty(); path = path.substr(0, path.find_last_of('/'))) {
    std::ifstream in("/sys/fs/cgroup" + path + "/memory.max");
    std::stringstream text;
    text << in.rdbuf();
    if (in) limit = std::min(limit, cgroupMemoryLimit(text.str()));
    if (path == "/") break;
  }
  return limit;
}

double environmentLimit() {
  const char* text = std::getenv("COSIM_MEMORY_LIMIT");
  if (!text || !*text) return kUnlimited;
  char* end = nullptr;
  const double bytes = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(bytes) || bytes <= 0.0)
    throw std::runtime_error(std::string("COSIM_MEMORY_LIMIT: expected a positive number of bytes, got '") + text + "'");
  return bytes;
}

}  // namespace

double cgroupMemoryLimit(const std::string& memoryMaxText) {
  std::istringstream in(memoryMaxText);
  std::string word;
  in >> word;
  if (word.empty() || word == "max") return kUnlimited;
  char* end = nullptr;
  const double bytes = std::strtod(word.c_str(), &end);
  return end != word.c_str() && *end == '\0' && bytes > 0.0 ? bytes : kUnlimited;
}

double availableMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long pageSize = ::sysconf(_SC_PAGE_SIZE);
  double bytes = pages > 0 && pageSize > 0 ? static_cast<double>(pages) * static_cast<double>(pageSize) : kUnlimited;
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
    bytes = std::min(bytes, static_cast<double>(limit.rlim_cur));
  return std::min({bytes, cgroupLimit(), environmentLimit()});
}

}  // namespace cosim::util
