#include "cosim/util/cpu_affinity.hpp"

#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace cosim::util {
namespace {

cpu_set_t maskOf(const std::vector<int>& cpus) {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (cpus.empty()) throw std::runtime_error("an empty CPU list");
  for (int c : cpus) {
    requireAllowed(c);
    CPU_SET(c, &mask);
  }
  return mask;
}

void setMask(pid_t tid, const cpu_set_t& mask, const std::vector<int>& cpus) {
  if (::sched_setaffinity(tid, sizeof mask, &mask) != 0 && errno != ESRCH)  // ESRCH: the thread ended meanwhile
    throw std::runtime_error("cannot restrict thread " + std::to_string(tid) + " to CPUs " + describeCpus(cpus) + ": " +
                             std::strerror(errno));
}

}  // namespace

std::string describeCpus(const std::vector<int>& cpus) {
  std::string s;
  for (int c : cpus) s += (s.empty() ? "" : ", ") + std::to_string(c);
  return "[" + s + "]";
}

std::vector<int> allowedCpus() { return allowedCpusOf(0); }

std::vector<int> allowedCpusOf(int pid) {
  cpu_set_t mask;
  CPU_ZERO(&mask);
  if (::sched_getaffinity(static_cast<pid_t>(pid), sizeof mask, &mask) != 0)
    throw std::runtime_error("cannot read the CPUs of process " + std::to_string(pid) + ": " + std::strerror(errno));
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &mask)) cpus.push_back(c);
  return cpus;
}

void requireAllowed(int cpu) {
  const auto allowed = allowedCpus();
  if (!std::binary_search(allowed.begin(), allowed.end(), cpu))
    throw std::runtime_error("CPU " + std::to_string(cpu) + " is not one this process may use (allowed: " +
                             describeCpus(allowed) + ")");
}

int currentCpu() {
  const int c = ::sched_getcpu();
  if (c < 0) throw std::runtime_error(std::string("sched_getcpu failed: ") + std::strerror(errno));
  return c;
}

void restrictProcessTo(const std::vector<int>& cpus) {
  const auto mask = maskOf(cpus);
  // sched_setaffinity acts on one thread: walk them all, the calling one last
  // so that a failure leaves it as it was.
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    const auto tid = static_cast<pid_t>(std::stol(entry.path().filename().string()));
    if (tid != static_cast<pid_t>(::syscall(SYS_gettid))) setMask(tid, mask, cpus);
  }
  if (ec) throw std::runtime_error("cannot list the threads of this process (/proc/self/task): " + ec.message());
  setMask(0, mask, cpus);
}

void restrictThreadsOf(int pid, const std::vector<int>& cpus) { setMask(static_cast<pid_t>(pid), maskOf(cpus), cpus); }

}  // namespace cosim::util
