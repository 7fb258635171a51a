#pragma once
// The whole machine's CPU time, from Linux's /proc/stat. On a shared VM the
// hypervisor runs other guests on our vCPUs (steal time): a run's wall time
// then grows with no change in its own work: on a development VM the same
// coupled run (17 s undisturbed) took 16 to 36 s, with 0.5 to 19 s of steal
// (docs/protocol.md, "Time accounting"). A report that carries the steal
// says how far its timings can be trusted.
#include <optional>
#include <string>

namespace cosim::util {

/// Seconds since boot, every CPU summed.
struct HostCpuTimes {
  double busyS = 0.0;   // user + nice + system + irq + softirq
  double idleS = 0.0;   // idle + iowait
  double stealS = 0.0;  // runnable but run the hypervisor's other work
  int cpus = 0;         // CPUs listed in /proc/stat
};

/// The times now; empty where /proc/stat cannot be read (not Linux).
std::optional<HostCpuTimes> readHostCpuTimes();

/// Parses /proc/stat's text (its "cpu" total line and "cpuN" lines) with
/// ticksPerSecond (sysconf(_SC_CLK_TCK)); empty when the total line is missing
/// or malformed.
std::optional<HostCpuTimes> parseProcStat(const std::string& text, double ticksPerSecond);

/// What the machine did between two readings.
HostCpuTimes operator-(const HostCpuTimes& later, const HostCpuTimes& earlier);

}  // namespace cosim::util
