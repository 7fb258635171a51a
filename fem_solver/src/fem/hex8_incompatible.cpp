// Incompatible-modes (enhanced) hexahedron: Wilson's three bubble modes
// phi_k = 1 - xi_k^2 enrich the displacement gradient,
//   F = I + sum_a u_a (x) dN_a/dX + sum_k alpha_k (x) G_k,
//   G_k = (j0 / j(xi)) J0^-T dphi_k/dxi,
// with Taylor's j0/j correction so that int G_k dV = 0 and the element passes
// the patch test on distorted meshes (Simo & Armero 1992 form of the total
// Lagrangian enhanced-strain element). The nine alpha are condensed per
// element by a local Newton iteration from alpha = 0 on every call, so the
// element carries no history and restarts are bit-for-bit.
#include <cmath>

#include "cosim/fem/fem/element_formulation.hpp"
#include "cosim/fem/fem/hex8.hpp"
#include "cosim/fem/fem/total_lagrangian.hpp"

namespace cosim::fem {
namespace {

using Grad11 = GradRows<11>;

class Hex8Incompatible final : public ElementFormulation {
 public:
  std::string name() const override { return "incompatible-modes"; }
  void initialise(const Mesh& mesh, const Material& material, const FormulationOptions&) override {
    material_ = &material;
    const std::size_t ne = mesh.numElements();
    grads_.resize(8 * ne);
    weights_.resize(8 * ne);
    const Mat83 d0 = hex8::shapeDerivatives(Vec3::Zero());
    for (std::size_t e = 0; e < ne; ++e) {
      const Mat83 X = mesh.elementCoordinates(e);
      hex8::checkElement(e, X);
      const Mat3 J0 = X.transpose() * d0;
      const double j0 = J0.determinant();
      const Mat3 J0invT = J0.inverse().transpose();
      for (int q = 0; q < 8; ++q) {
        const Vec3 xi = hex8::gaussPoint(q);
        const Mat83 dxi = hex8::shapeDerivatives(xi);
        const Mat3 J = X.transpose() * dxi;
        const double j = J.determinant();
        Grad11 G;
        G.topRows<8>() = dxi * J.inverse();
        for (int k = 0; k < 3; ++k) {
          Vec3 dphi = Vec3::Zero();
          dphi[k] = -2.0 * xi[k];
          G.row(8 + k) = ((j0 / j) * (J0invT * dphi)).transpose();
        }
        grads_[8 * e + static_cast<std::size_t>(q)] = G;
        weights_[8 * e + static_cast<std::size_t>(q)] = j;
      }
    }
  }

  void evaluate(std::size_t e, const Mat83& ue, Vec24& fe, Mat24* Ke, ElementEnergy& energy) const override {
    Grad11 U;
    U.topRows<8>() = ue;
    U.bottomRows<3>().setZero();
    PointMat<3> Kaa;
    Eigen::Matrix<double, 9, 1> ra;
    condense(e, U, ra, Kaa);
    // At the converged alpha: f_u (and the condensed tangent when asked).
    double W = 0.0;
    if (!Ke) {
      PointVec<8> f = PointVec<8>::Zero();
      for (int q = 0; q < 8; ++q) {
        const std::size_t p = 8 * e + static_cast<std::size_t>(q);
        addPointRows<8>(grads_[p].topRows<8>(), U.transpose() * grads_[p], weights_[p] * pointScale(e, q), *material_,
                        f, nullptr, W, p);
      }
      fe = f;
      energy.strain += W;
      return;
    }
    PointVec<11> f = PointVec<11>::Zero();
    PointMat<11> K = PointMat<11>::Zero();
    for (int q = 0; q < 8; ++q) {
      const std::size_t p = 8 * e + static_cast<std::size_t>(q);
      addMaterialPoint<11>(grads_[p], U, weights_[p] * pointScale(e, q), *material_, f, &K, W, p);
    }
    // Static condensation of the enhanced parameters.
    const Eigen::LDLT<Eigen::Matrix<double, 9, 9>> solve(K.bottomRightCorner<9, 9>());
    const Eigen::Matrix<double, 9, 24> KaaInvKau = solve.solve(K.bottomLeftCorner<9, 24>());
    fe = f.head<24>() - KaaInvKau.transpose() * f.tail<9>();
    *Ke = K.topLeftCorner<24, 24>() - K.topRightCorner<24, 9>() * KaaInvKau;
    energy.strain += W;
  }

  int pointsPerElement() const override { return 8; }
  void pointStates(std::size_t e, const Mat83& ue, MaterialPointState* out) const override {
    Grad11 U;
    U.topRows<8>() = ue;
    U.bottomRows<3>().setZero();
    PointMat<3> Kaa;
    Eigen::Matrix<double, 9, 1> ra;
    condense(e, U, ra, Kaa);
    for (int q = 0; q < 8; ++q)
      pointStress<11>(grads_[8 * e + static_cast<std::size_t>(q)], U, *material_, out[q].F, out[q].S,
                      8 * e + static_cast<std::size_t>(q));
  }

 private:
  /// Local Newton on the enhanced parameters (rows 8..10 of U) until their
  /// residual vanishes; leaves f, K, W evaluated at the converged alpha.
  /// Local Newton on the enhanced parameters (rows 8..10 of U) with only the
  /// 9 x 9 enhanced block, until their residual vanishes to round-off.
  void condense(std::size_t e, Grad11& U, Eigen::Matrix<double, 9, 1>& ra, PointMat<3>& Kaa) const {
    const double scale = U.topRows<8>().cwiseAbs().maxCoeff();
    double refForce = 0.0;
    for (int it = 0; it < 12; ++it) {
      ra.setZero();
      Kaa.setZero();
      double W = 0.0;
      for (int q = 0; q < 8; ++q) {
        const std::size_t p = 8 * e + static_cast<std::size_t>(q);
        const Mat3 H = U.transpose() * grads_[p];
        addPointRows<3>(grads_[p].bottomRows<3>(), H, weights_[p] * pointScale(e, q), *material_, ra, &Kaa, W, p);
        if (it == 0) refForce += weights_[p] * pointScale(e, q) * H.norm();
      }
      const double rn = ra.norm();
      if (!std::isfinite(rn)) throw SolveError("element " + std::to_string(e) + ": non-finite enhanced-mode residual");
      if (!(rn > 1e-15 * refForce * material_->waveModulus())) return;
      const Eigen::Matrix<double, 9, 1> da = Kaa.ldlt().solve(-ra);
      for (int k = 0; k < 3; ++k) U.row(8 + k) += da.segment<3>(3 * k).transpose();
      // A correction at round-off level ends the iteration.
      if (da.cwiseAbs().maxCoeff() <= 1e-14 * (scale + U.bottomRows<3>().cwiseAbs().maxCoeff())) return;
    }
  }

  std::vector<Grad11> grads_;
  std::vector<double> weights_;
  const Material* material_ = nullptr;
};

const FormulationRegistry::Registrar kIncompatible("incompatible-modes",
                                                  [] { return std::make_unique<Hex8Incompatible>(); });

}  // namespace
}  // namespace cosim::fem
