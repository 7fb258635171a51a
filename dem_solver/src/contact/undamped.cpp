// No damping: elastic contacts whatever the materials' restitution says.
#include "cosim/dem/contact/contact_law.hpp"

namespace cosim::dem {
namespace {

class Undamped final : public DampingLaw {
 public:
  double coefficient(const NormalLaw&, const PairMaterial&) const override { return 0.0; }
};

const bool registered = DampingLawRegistry::add("none", [] { return std::make_unique<Undamped>(); });

}  // namespace
}  // namespace cosim::dem
