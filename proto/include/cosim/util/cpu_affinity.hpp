#pragma once
// Which CPUs a process may run on. A lockstep coupled run whose solvers do
// little work per exchange is bound by wake-up latency, not by compute: each
// exchange wakes the coupler, every solver and their ZeroMQ I/O threads in
// turn, and a wake-up that crosses to another (idle) CPU costs an
// inter-processor interrupt, on a VM a halted vCPU's exit as well. Packing the
// whole run on one CPU turns those into local context switches
// (docs/protocol.md, "Placement").
#include <string>
#include <vector>

namespace cosim::util {

/// The CPUs this process may run on now (its affinity mask), ascending.
std::vector<int> allowedCpus();
/// The same for another process (its main thread).
std::vector<int> allowedCpusOf(int pid);

/// "[0, 2]": a CPU list as messages and reports write it.
std::string describeCpus(const std::vector<int>& cpus);

/// Throws std::runtime_error naming cpu and the allowed ones when this
/// process may not run on it.
void requireAllowed(int cpu);

/// The CPU the calling thread runs on at this moment.
int currentCpu();

/// Restricts every thread of this process (ZeroMQ's I/O threads and OpenMP
/// workers included) to cpus; threads and processes started later inherit it.
/// Throws std::runtime_error naming the CPU when one is not allowed.
void restrictProcessTo(const std::vector<int>& cpus);

/// The same for the main thread of another process (one that has not yet
/// started threads of its own, so that they inherit it).
void restrictThreadsOf(int pid, const std::vector<int>& cpus);

}  // namespace cosim::util
