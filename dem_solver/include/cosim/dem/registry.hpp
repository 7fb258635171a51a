#pragma once
// The DEM's extension points (contact laws, integrators) use the project's one
// registry: implementations register themselves by the name a scene uses.
#include "cosim/util/registry.hpp"

namespace cosim::dem {

template <class Base>
using Registry = cosim::Registry<Base>;

}  // namespace cosim::dem
