#pragma once
// Coarse-graining kernels W(r; c) of Cheng 2022 Sec. 4 (Eqs. 9-10), one class
// per file, registered by the name scenes use (`kernel: lucy`). The width c is
// the kernel's cut-off radius: W = 0 for r >= c. value() is normalised in 3D
// (its integral over R^3 is 1); surface maps normalise by quadrature instead
// (Cheng Sec. 5.1.2), so they only need the kernel's shape.
#include <memory>
#include <string>

#include "cosim/util/registry.hpp"

namespace cosim::coupler {

class CgKernel {
 public:
  virtual ~CgKernel() = default;
  virtual std::string name() const = 0;
  /// True for the Dirac kernel (c = 0): maps then use the point forms (Eqs. 16, 27 with psi_i(x_p)).
  virtual bool isDirac() const { return false; }
  /// W(r; c) for c > 0, with the 3D normalisation constant.
  virtual double value(double r, double c) const = 0;
};

using CgKernelRegistry = Registry<CgKernel>;

}  // namespace cosim::coupler
