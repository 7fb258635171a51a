#include "cosim/util/host_cpu_time.hpp"

#include <unistd.h>

#include <fstream>
#include <sstream>

namespace cosim::util {

std::optional<HostCpuTimes> parseProcStat(const std::string& text, double ticksPerSecond) {
  if (!(ticksPerSecond > 0.0)) return std::nullopt;
  std::istringstream in(text);
  std::string line;
  std::optional<HostCpuTimes> out;
  int cpus = 0;
  while (std::getline(in, line)) {
    if (line.rfind("cpu", 0) != 0) continue;
    std::istringstream fields(line);
    std::string label;
    fields >> label;
    if (label != "cpu") {  // "cpu0", "cpu1" ...
      ++cpus;
      continue;
    }
    // user nice system idle iowait irq softirq steal (proc(5)); guest time is
    // already inside user and nice.
    double t[8];
    for (double& v : t)
      if (!(fields >> v)) return std::nullopt;
    out = HostCpuTimes{(t[0] + t[1] + t[2] + t[5] + t[6]) / ticksPerSecond, (t[3] + t[4]) / ticksPerSecond,
                       t[7] / ticksPerSecond, 0};
  }
  if (out) out->cpus = cpus;
  return out;
}

std::optional<HostCpuTimes> readHostCpuTimes() {
  std::ifstream in("/proc/stat");
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  return parseProcStat(text.str(), static_cast<double>(sysconf(_SC_CLK_TCK)));
}

HostCpuTimes operator-(const HostCpuTimes& later, const HostCpuTimes& earlier) {
  return {later.busyS - earlier.busyS, later.idleS - earlier.idleS, later.stealS - earlier.stealS, later.cpus};
}

}  // namespace cosim::util
