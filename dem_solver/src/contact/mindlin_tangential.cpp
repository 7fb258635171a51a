// Registers the Mindlin tangential law (class in builtin_laws.hpp).
#include "cosim/dem/contact/builtin_laws.hpp"

namespace cosim::dem {
namespace {
const bool registered =
    TangentialLawRegistry::add("mindlin", [] { return std::make_unique<MindlinTangential>(); });
}  // namespace
}  // namespace cosim::dem
