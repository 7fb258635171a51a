#pragma once
// How much memory this process may use, for the solvers' checks of a scene's
// sizes before they allocate (a lattice, a packing, a PD body's bonds): a size
// beyond it is refused with the key to change, not left to end in bad_alloc.

namespace cosim::util {

/// The machine's physical memory, or the address-space limit (ulimit -v) when
/// that is lower, or the cap below; infinite when none can be read.
double availableMemoryBytes();

/// Caps what availableMemoryBytes() reports in this process (0: no cap). The
/// fuzz targets set one, so that the solvers' own size checks refuse the
/// scenes that would take seconds to build.
void capAvailableMemory(double bytes);

}  // namespace cosim::util
