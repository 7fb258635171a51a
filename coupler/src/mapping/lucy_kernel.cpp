// Lucy polynomial kernel, Cheng 2022 Eq. (10):
//   W(r) = C (-3 q^4 + 8 q^3 - 6 q^2 + 1) = C (1 + 3q)(1 - q)^3,  q = r / c < 1.
// In 3D, 4 pi C c^3 int_0^1 (1 + 3q)(1 - q)^3 q^2 dq = 4 pi C c^3 / 35 = 1 gives
// C = 105 / (16 pi c^3) (the paper leaves C to the normalisation condition).
#include <cmath>
#include <numbers>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {
namespace {

class LucyKernel final : public CgKernel {
 public:
  std::string name() const override { return "lucy"; }
  double value(double r, double c) const override {
    const double q = r / c;
    if (q >= 1.0) return 0.0;
    const double a = 1.0 - q;
    return 105.0 / (16.0 * std::numbers::pi * c * c * c) * (1.0 + 3.0 * q) * a * a * a;
  }
};

const bool registered = CgKernelRegistry::add("lucy", [] { return std::make_unique<LucyKernel>(); });

}  // namespace
}  // namespace cosim::coupler
