// St. Venant-Kirchhoff: the generalised Hooke's law of Cheng 2022 App. A,
// S = C : E with the isotropic tensor of Eq. 33 acting on the Green strain.
// Eq. 34 writes the tensor with the metric of the configuration; in Cartesian
// reference coordinates without growth (g_ij = delta_ij) the linear map from
// Green strain to the second Piola-Kirchhoff stress is Eq. 33, which is the
// form used here.
#include "cosim/fem/material/material.hpp"

namespace cosim::fem {
namespace {

class StVenantKirchhoff final : public Material {
 public:
  explicit StVenantKirchhoff(const MaterialParams& params) : Material(params), C_(isotropicTangent(lambda_, mu_)) {}
  std::string name() const override { return "st-venant-kirchhoff"; }
  void evaluate(const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override {
    const Mat3 E = greenStrain(H);
    const double trE = E.trace();
    S = lambda_ * trE * Mat3::Identity() + 2.0 * mu_ * E;
    W = 0.5 * lambda_ * trE * trE + mu_ * E.cwiseProduct(E).sum();
    if (tangent) *tangent = C_;
  }

 private:
  Mat6 C_;
};

const MaterialRegistry::Registrar kSvk("st-venant-kirchhoff", [](const MaterialParams& p) {
  return std::make_unique<StVenantKirchhoff>(p);
});
const MaterialRegistry::Registrar kHooke("generalised-hooke", [](const MaterialParams& p) {
  return std::make_unique<StVenantKirchhoff>(p);
});

}  // namespace
}  // namespace cosim::fem
