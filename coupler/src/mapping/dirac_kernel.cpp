// The Dirac kernel (c = 0): no width, so maps use their point forms instead
// of quadrature (Cheng 2022 Eq. 16 for surface forces, Eq. 27 with psi_i at
// the particle positions for the homogenisation operator).
#include <stdexcept>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {
namespace {

class DiracKernel final : public CgKernel {
 public:
  std::string name() const override { return "dirac"; }
  bool isDirac() const override { return true; }
  double value(double, double) const override {
    throw std::logic_error("the Dirac kernel has no pointwise value: use the point form of the map");
  }
};

const bool registered = CgKernelRegistry::add("dirac", [] { return std::make_unique<DiracKernel>(); });

}  // namespace
}  // namespace cosim::coupler
