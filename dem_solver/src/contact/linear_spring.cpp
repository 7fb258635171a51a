// Registers the linear spring normal law (class in builtin_laws.hpp).
#include "cosim/dem/contact/builtin_laws.hpp"

namespace cosim::dem {
namespace {
const bool registered = NormalLawRegistry::add("linear", [] { return std::make_unique<LinearSpring>(); });
}  // namespace
}  // namespace cosim::dem
