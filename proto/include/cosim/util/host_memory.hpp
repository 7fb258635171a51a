#pragma once
// How much memory this process may use, for the solvers' checks of a scene's
// sizes before they allocate (a lattice, a packing, a PD body's bonds): a size
// beyond it is refused with the key to change, not left to end in bad_alloc.

namespace cosim::util {

/// The machine's physical memory, or the address-space limit (ulimit -v) when
/// that is lower; infinite when neither can be read.
double availableMemoryBytes();

}  // namespace cosim::util
