// Cut-off Gaussian kernel, Cheng 2022 Eq. (9): W(r) = C exp(-r^2 / (2 (c/3)^2))
// for r < c. With s = c/3 the 3D normalisation over the ball r < c = 3 s is
//   1/C = 4 pi int_0^{3s} exp(-r^2 / 2s^2) r^2 dr
//       = (2 pi)^{3/2} s^3 [erf(3 / sqrt 2) - sqrt(2/pi) 3 exp(-9/2)],
// slightly above the untruncated Gaussian's constant.
#include <cmath>
#include <numbers>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {
namespace {

class CutoffGaussianKernel final : public CgKernel {
 public:
  std::string name() const override { return "gaussian"; }
  double value(double r, double c) const override {
    if (r >= c) return 0.0;
    const double s = c / 3.0;
    return std::exp(-0.5 * (r * r) / (s * s)) / (s * s * s * kTruncatedMass);
  }

 private:
  // (2 pi)^{3/2} [erf(3/sqrt 2) - 3 sqrt(2/pi) exp(-9/2)]: the Gaussian's mass inside 3 sigma.
  static inline const double kTruncatedMass =
      std::pow(2.0 * std::numbers::pi, 1.5) *
      (std::erf(3.0 / std::numbers::sqrt2) - 3.0 * std::sqrt(2.0 / std::numbers::pi) * std::exp(-4.5));
};

const bool registered = CgKernelRegistry::add("gaussian", [] { return std::make_unique<CutoffGaussianKernel>(); });

}  // namespace
}  // namespace cosim::coupler
