#pragma once
// The tangential history spring shared by the linear and Mindlin laws
// (Hartmann 2022 Eqs. 34-35): incremental shear displacement, rotated into the
// current tangent plane, Coulomb-limited.
#include <cmath>

#include "cosim/dem/contact/contact_law.hpp"

namespace cosim::dem {

/// ktBefore: the spring's stiffness one step ago (Mindlin's k_t follows the
/// overlap), so the energy balance books what the stiffness change adds or
/// removes from the stored spring energy (the incremental Mindlin model is not
/// derived from a potential; that difference appears in `dissipated`).
/// ct: the tangential dashpot, gamma sqrt(k_t m*) (Tsuji form, as the normal one).
inline double tangentialDashpot(const TangentialInput& in, double kt) {
  return in.pm->gamma > 0.0 ? in.pm->gamma * std::sqrt(kt * in.mEff) : 0.0;
}

inline Vec3 tangentialSpring(const TangentialInput& in, double kt, double ktBefore, double ct, Vec3& shear,
                             double& dissipated) {
  const double fmax = in.pm->friction * in.fnMag;  // Hartmann 2022 Eq. 35: |f_s| <= mu |f_n|
  if (fmax <= 0.0 || kt <= 0.0) {
    shear = {};
    return {};
  }
  // Rotate the stored displacement with the contact frame: drop its normal
  // component and restore its length, so history survives normal rotation.
  const double s2 = norm2(shear);
  Vec3 sh = shear - dot(shear, in.n) * in.n;
  const double p2 = norm2(sh);
  if (p2 > 0.0) sh *= std::sqrt(s2 / p2);
  const double before = 0.5 * ktBefore * s2;
  sh += in.vt * in.dt;  // Hartmann 2022 Eq. 34 with the spring factored out: du_s = v_s dt
  Vec3 ft = -kt * sh - ct * in.vt;
  const double f2 = norm2(ft);
  if (f2 > fmax * fmax) {
    // Sliding: the force sits on the Coulomb cone and the spring relaxes to match it.
    ft *= fmax / std::sqrt(f2);
    sh = -(1.0 / kt) * (ft + ct * in.vt);
  }
  shear = sh;
  // Energy balance: work of the tangential force not stored in the spring is lost.
  dissipated += -dot(ft, in.vt) * in.dt - (0.5 * kt * norm2(sh) - before);
  return ft;
}

}  // namespace cosim::dem
