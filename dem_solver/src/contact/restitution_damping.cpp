// Viscous damping calibrated to a requested coefficient of restitution: the
// normal law supplies the gamma of F_d = -gamma sqrt(S_n m*) v_n that gives it
// (exact for linear springs; calibrated Tsuji form for Hertz).
#include "cosim/dem/contact/contact_law.hpp"

namespace cosim::dem {
namespace {

class RestitutionDamping final : public DampingLaw {
 public:
  double coefficient(const NormalLaw& normal, const PairMaterial& pm) const override {
    return normal.dampingCoefficient(pm.restitution);
  }
};

const bool registered =
    DampingLawRegistry::add("restitution", [] { return std::make_unique<RestitutionDamping>(); });

}  // namespace
}  // namespace cosim::dem
