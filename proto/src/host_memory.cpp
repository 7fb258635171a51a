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

/// The file holding the memory limit of each cgroup from this process's up
/// to the root: cgroup v2 ("0::/path": memory.max) or the v1 memory
/// controller ("N:memory:/path": memory.limit_in_bytes).
struct CgroupFiles {
  std::string root, path, file;
};
CgroupFiles ownCgroup() {
  std::ifstream in("/proc/self/cgroup");
  CgroupFiles v2;
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1), path = line.substr(second + 1);
    if (controllers == "memory") return {"/sys/fs/cgroup/memory", path, "memory.limit_in_bytes"};
    if (line.rfind("0::", 0) == 0) v2 = {"/sys/fs/cgroup", path, "memory.max"};
  }
  return v2;
}

/// The tightest limit from the process's cgroup up to the root: a parent's
/// limit binds its children too. Levels the process cannot see (a container
/// shows its own cgroup as the root) are skipped.
double cgroupLimit() {
  const CgroupFiles group = ownCgroup();
  if (group.path.empty()) return kUnlimited;
  double limit = kUnlimited;
  for (std::string path = group.path;; path = path.substr(0, path.find_last_of('/'))) {
    std::ifstream in(group.root + (path == "/" ? "" : path) + "/" + group.file);
    std::stringstream text;
    text << in.rdbuf();
    if (in) limit = std::min(limit, cgroupMemoryLimit(text.str()));
    if (path.empty() || path == "/") break;
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
  // cgroup v1 writes "no limit" as the largest page-aligned 63-bit number.
  constexpr double kV1Unlimited = 9.0e18;
  return end != word.c_str() && *end == '\0' && bytes > 0.0 && bytes < kV1Unlimited ? bytes : kUnlimited;
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
