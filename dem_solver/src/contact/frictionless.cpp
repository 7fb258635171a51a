// Registers the frictionless tangential law (class in builtin_laws.hpp).
#include "cosim/dem/contact/builtin_laws.hpp"

namespace cosim::dem {
namespace {
const bool registered = TangentialLawRegistry::add("none", [] { return std::make_unique<Frictionless>(); });
}  // namespace
}  // namespace cosim::dem
