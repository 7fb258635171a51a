#pragma once
// Isotropic linear-elastic constants of one peridynamic body (SI units).
#include <cmath>

namespace cosim::pd {

struct Material {
  double youngsModulus = 0.0;  // E [Pa]
  double poissonRatio = 0.25;  // nu [-]
  double density = 0.0;        // rho [kg/m^3]

  double bulkModulus() const { return youngsModulus / (3.0 * (1.0 - 2.0 * poissonRatio)); }
  double shearModulus() const { return youngsModulus / (2.0 * (1.0 + poissonRatio)); }
  double lameLambda() const {
    return youngsModulus * poissonRatio / ((1.0 + poissonRatio) * (1.0 - 2.0 * poissonRatio));
  }
  /// Bulk wave speed of the CFL estimate, Hartmann 2022 Eq. 42: c = sqrt(K / rho).
  double cflWaveSpeed() const { return std::sqrt(bulkModulus() / density); }
};

}  // namespace cosim::pd
