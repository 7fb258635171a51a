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

/// n: unit normal; vt: tangential relative velocity; fmax = mu |f_n| (Hartmann
/// 2022 Eq. 35: |f_s| <= mu |f_n|).
inline Vec3 tangentialSpring(const Vec3& n, const Vec3& vt, double fmax, double dt, double kt, double ktBefore,
                             double ct, Vec3& shear, double& dissipated) {
  // Written without branches (selects only, every division and root done
  // on a safe operand), so that the batched pair loop vectorises; every select
  // keeps the value the branched form would give.
  const bool active = (fmax > 0.0) & (kt > 0.0);  // otherwise no spring: history and force are zero
  // Rotate the stored displacement with the contact frame: drop its normal
  // component and restore its length, so history survives normal rotation.
  const double s2 = norm2(shear);
  Vec3 sh = shear - dot(shear, n) * n;
  const double p2 = norm2(sh);
  const double restore = std::sqrt(s2 / (p2 > 0.0 ? p2 : 1.0));  // every division unconditional
  sh *= p2 > 0.0 ? restore : 1.0;
  const double before = 0.5 * ktBefore * s2;
  const Vec3 springBefore = -ktBefore * sh;
  const Vec3 step = vt * dt;
  sh += step;  // Hartmann 2022 Eq. 34 with the spring factored out: du_s = v_s dt
  Vec3 ft = -kt * sh - ct * vt;
  const double f2 = norm2(ft);
  // Sliding: the force sits on the Coulomb cone and the spring relaxes to match it.
  const bool sliding = f2 > fmax * fmax;
  const double onCone = fmax / std::sqrt(sliding ? f2 : 1.0);
  ft *= sliding ? onCone : 1.0;
  const Vec3 relaxed = -(1.0 / (active ? kt : 1.0)) * (ft + ct * vt);
  sh = select(sliding, relaxed, sh);
  sh = select(active, sh, Vec3{});
  ft = select(active, ft, Vec3{});
  shear = sh;
  // Energy balance: work of the tangential force not stored in the spring is
  // lost. The spring's part does the work of the trapezoid over the step (what
  // Verlet's kicks hand the particles, and what a driven particle's drive work
  // counts); charged at its end value alone, a sticking spring booked
  // k_t |v_t dt|^2 / 2 a step as dissipated while it stored all of it.
  const Vec3 spring = -kt * sh;
  const double lost = -dot(0.5 * (spring + springBefore) + (ft - spring), step) - (0.5 * kt * norm2(sh) - before);
  dissipated += active ? lost : 0.0;
  return ft;
}

/// The same for a law's TangentialInput.
inline Vec3 tangentialSpring(const TangentialInput& in, double kt, double ktBefore, double ct, Vec3& shear,
                             double& dissipated) {
  return tangentialSpring(in.n, in.vt, in.pm->friction * in.fnMag, in.dt, kt, ktBefore, ct, shear, dissipated);
}

}  // namespace cosim::dem
