// Correspondence output, Hartmann 2022 Eqs. 26-30.
//
// Eq. 26 as extracted omits the partner volume and Eq. 27 uses u_IJ; we use
// the consistent one-point quadrature of the correspondence model (Silling
// 2007): K = sum w xi (x) xi V_J and F = (sum w Y (x) xi V_J) K^-1 with the
// deformed bond Y = xi + eta, so F = I in the reference configuration and F
// reproduces any affine map exactly. The influence function is constant.
#include <Eigen/Dense>
#include <cmath>

#include "cosim/pd/correspondence.hpp"

namespace cosim::pd {
namespace {

void putSym(std::vector<double>& out, std::size_t i, const Eigen::Matrix3d& m) {
  double* o = &out[6 * i];
  o[0] = m(0, 0); o[1] = m(1, 1); o[2] = m(2, 2);
  o[3] = m(0, 1); o[4] = m(1, 2); o[5] = m(2, 0);
}

}  // namespace

CorrespondenceFields correspondence(const BodyContext& body) {
  const auto& b = body.bonds;
  const auto& p = body.particles;
  const std::size_t n = body.end - body.begin;
  CorrespondenceFields out;
  out.deformationGradient.assign(9 * n, 0.0);
  out.greenLagrange.assign(6 * n, 0.0);
  out.pk2.assign(6 * n, 0.0);
  out.cauchy.assign(6 * n, 0.0);
  out.vonMises.assign(n, 0.0);
  const double G = body.material.shearModulus();
  const double lambda = body.material.lameLambda();
  const long nl = static_cast<long>(n);
#pragma omp parallel for schedule(dynamic, 256) if (nl > kOmpMinParticles)
  for (long il = 0; il < nl; ++il) {
    const std::size_t i = body.begin + static_cast<std::size_t>(il);
    Eigen::Matrix3d K = Eigen::Matrix3d::Zero(), N = Eigen::Matrix3d::Zero();
    for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
      if (b.broken[k]) continue;
      const std::size_t j = b.neighbor[k];
      Eigen::Vector3d xi, y;
      for (int a = 0; a < 3; ++a) {
        xi[a] = p.reference[3 * j + a] - p.reference[3 * i + a];
        y[a] = p.current(j, a) - p.current(i, a);
      }
      const double wv = b.volumeFraction[k] * p.volume[j];
      K += wv * xi * xi.transpose();  // Eq. 26
      N += wv * y * xi.transpose();   // Eq. 27 numerator
    }
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    const double scale = K.trace();
    bool valid = scale > 0.0 && std::abs(K.determinant()) > 1e-12 * scale * scale * scale;
    if (valid) F = N * K.inverse();  // Eq. 27
    const double J = F.determinant();
    if (!(J > 0.0)) valid = false;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out.deformationGradient[9 * static_cast<std::size_t>(il) + 3 * r + c] = valid ? F(r, c) : (r == c ? 1.0 : 0.0);
    if (!valid) continue;
    const Eigen::Matrix3d C = F.transpose() * F;
    const Eigen::Matrix3d E = 0.5 * (C - Eigen::Matrix3d::Identity());  // Green-Lagrange
    const Eigen::Matrix3d Ci = C.inverse();
    // Eq. 29 (Neo-Hookean with Ciarlet's volumetric part, Eq. 28).
    const Eigen::Matrix3d S = G * (Eigen::Matrix3d::Identity() - Ci) + 0.5 * lambda * (J * J - 1.0) * Ci;
    const Eigen::Matrix3d sigma = F * S * F.transpose() / J;  // Eq. 30
    const std::size_t q = static_cast<std::size_t>(il);
    putSym(out.greenLagrange, q, E);
    putSym(out.pk2, q, S);
    putSym(out.cauchy, q, sigma);
    const Eigen::Matrix3d dev = sigma - sigma.trace() / 3.0 * Eigen::Matrix3d::Identity();
    out.vonMises[q] = std::sqrt(1.5 * (dev.array() * dev.array()).sum());
  }
  return out;
}

}  // namespace cosim::pd
