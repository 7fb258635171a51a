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
  /// Wave speed of the critical step (Hartmann 2022 Eqs. 41-42, which take
  /// the bulk speed sqrt(K / rho)): the P-wave speed c_p = sqrt((K + 4 G / 3) /
  /// rho), the fastest wave of the solid, 1.34 x the bulk speed at nu = 0.25
  /// and 1.03 x at nu = 0.48 (PdSystem::criticalTimeStep).
  double cflWaveSpeed() const { return std::sqrt((bulkModulus() + 4.0 * shearModulus() / 3.0) / density); }
};

}  // namespace cosim::pd
