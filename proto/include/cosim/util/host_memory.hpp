#pragma once
// How much memory this process may use, for the solvers' checks of a scene's
// sizes before they allocate (a lattice, a packing, a PD body's bonds): a size
// beyond it is refused with the key to change, not left to end in bad_alloc.

#include <string>

namespace cosim::util {

/// The smallest of: the machine's physical memory, the address-space limit
/// (ulimit -v), the memory limit of the process's cgroup (cgroup v2
/// memory.max, v1 memory.limit_in_bytes: a Slurm job's --mem, a container's
/// limit) and the bytes in
/// the environment variable COSIM_MEMORY_LIMIT (a decimal or floating-point
/// number); infinite when none can be read. Throws std::runtime_error naming
/// the variable when COSIM_MEMORY_LIMIT is not a positive number.
double availableMemoryBytes();

/// The limit in a cgroup memory.max (v2) or memory.limit_in_bytes (v1) file's
/// text; "max", v1's "no limit" number or anything unreadable: infinite.
double cgroupMemoryLimit(const std::string& memoryMaxText);

}  // namespace cosim::util
