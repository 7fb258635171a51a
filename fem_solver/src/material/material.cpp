#include "cosim/fem/material/material.hpp"

#include <cmath>
#include <sstream>

namespace cosim::fem {

Material::Material(const MaterialParams& params) : params_(params) {
  const double E = params.youngsModulus;
  const double nu = params.poissonRatio;
  if (!(E > 0.0) || !std::isfinite(E)) throw InputError("material: E must be positive and finite");
  if (!(nu > -1.0 && nu < 0.5)) throw InputError("material: nu must lie in (-1, 0.5)");
  if (!(params.density > 0.0) || !std::isfinite(params.density))
    throw InputError("material: density must be positive and finite");
  // Lame constants as defined under Cheng 2022 Eq. 33.
  lambda_ = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  mu_ = E / (2.0 * (1.0 + nu));
  // E near the largest double with nu near 1/2 overflows lambda: the wave
  // speed would be infinite and the critical step 0, which reads "no limit".
  if (!std::isfinite(lambda_) || !std::isfinite(lambda_ + 2.0 * mu_)) {
    std::ostringstream m;
    m << "material: E = " << E << " Pa and nu = " << nu << " give Lame constants beyond double range";
    throw InputError(m.str());
  }
}

Mat6 isotropicTangent(double lambda, double mu) {
  // C_ijkl = lambda d_ij d_kl + mu (d_ik d_jl + d_il d_jk), Cheng 2022 Eq. 33,
  // in Voigt form with engineering shear strains.
  Mat6 C = Mat6::Zero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) C(i, j) = lambda;
    C(i, i) += 2.0 * mu;
    C(i + 3, i + 3) = mu;
  }
  return C;
}

Vec6 toVoigtStrain(const Mat3& E) {
  Vec6 e;
  e << E(0, 0), E(1, 1), E(2, 2), 2.0 * E(0, 1), 2.0 * E(1, 2), 2.0 * E(0, 2);
  return e;
}

Mat3 fromVoigtStress(const Vec6& s) {
  Mat3 S;
  S << s(0), s(3), s(5), s(3), s(1), s(4), s(5), s(4), s(2);
  return S;
}

}  // namespace cosim::fem
