#pragma once
// Corotational kinematics for stresses supplied from outside (GMH unit cells,
// Liu 2016 Sec. 2.3 and App. B): the rotation from the polar decomposition of
// the midstep deformation gradient (Eq. 61), the strain increment rotated into
// the corotational frame (Eq. 60), and the received corotational Cauchy
// stress rotated back (Eq. 62).
#include "cosim/fem/types.hpp"

namespace cosim::fem::corotational {

/// R of the polar decomposition F = R U (U symmetric positive definite).
Mat3 polarRotation(const Mat3& F);

struct Increment {
  Mat3 rotation;        // R_{n+1/2}
  Mat3 strainIncrement; // corotational Delta eps, R^T sym(Delta L) R
};

/// Liu 2016 Eqs. 60-61: with F_{n+1/2} = (F_n + F_{n+1}) / 2 (the gradient of
/// the midstep coordinates x_{n+1/2}) and Delta L = (F_{n+1} - F_n) F_{n+1/2}^-1,
/// Delta eps = sym(Delta L) rotated by R_{n+1/2}. A rigid rotation gives
/// Delta L skew (a Cayley transform), hence exactly no strain increment.
Increment strainIncrement(const Mat3& Fn, const Mat3& Fn1);

/// The spatial alternative (frame: spatial): the whole increment of the
/// gradient, spin included, log(F_{n+1} F_n^-1). A cell deformed affinely by
/// it (x <- exp(Delta L) x) follows F exactly and turns with the material,
/// as a directly sheared DEM sample does; its stress is then the lab-frame
/// Cauchy stress. Throws InputError when |F_{n+1} F_n^-1 - I| >= 0.5 (no
/// small increment: the series would not converge).
Mat3 logarithmicIncrement(const Mat3& Fn, const Mat3& Fn1);

/// Liu 2016 Eq. 62: sigma = R sigma^R R^T.
Mat3 rotateToGlobal(const Mat3& R, const Mat3& sigmaCorotational);

/// Second Piola-Kirchhoff stress S = J F^-1 sigma F^-T from Cauchy stress (for
/// the total Lagrangian force of an externally supplied stress).
Mat3 secondPiolaFromCauchy(const Mat3& F, const Mat3& sigma);

}  // namespace cosim::fem::corotational
