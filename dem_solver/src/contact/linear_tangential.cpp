// Registers the linear tangential spring (class in builtin_laws.hpp).
#include "cosim/dem/contact/builtin_laws.hpp"

namespace cosim::dem {
namespace {
const bool registered =
    TangentialLawRegistry::add("linear", [] { return std::make_unique<LinearTangential>(); });
}  // namespace
}  // namespace cosim::dem
