// One-point quadrature hexahedron with stiffness-type hourglass control
// (Liu 2016 Sec. 2.2 uses reduced integration with hourglass control; the
// operators follow Flanagan & Belytschko 1981):
//  * mean gradient Bbar_a = (1/V) int dN_a/dX dV, so the element is exact for
//    linear fields and equilibrium of constant stress holds on distorted
//    meshes (patch test);
//  * hourglass shape vectors gamma_alpha = h_alpha - (h_alpha . X_i) Bbar_i,
//    orthogonal to every linear field, so rigid motions and homogeneous
//    deformation produce no hourglass force;
//  * stiffness type: hourglass force f = k Gamma Gamma^T u with k = kappa
//    (lambda + 2 mu) V sum_a |Bbar_a|^2 / 8, energy k |Gamma^T u|^2 / 2
//    reported separately;
//  * viscous type: f = c Gamma Gamma^T v on the hourglass velocity modes
//    q = Gamma^T v, c = kappa rho c_d V^(2/3) / 4 with the dilatational wave
//    speed c_d = sqrt((lambda + 2 mu) / rho) (Flanagan & Belytschko 1981,
//    viscous form; the scaling is that of LS-DYNA's type-1 control). It
//    dissipates c |q|^2 >= 0 and adds no stiffness. Since Gamma^T is zero on
//    every linear velocity field, rigid motion and uniform strain rate are
//    not damped.
//  * stiffness damping (Rayleigh C = beta K): the viscous element stress
//    sigma_v = beta (lambda tr(D) I + 2 mu D), D = sym(v^T Bbar) the element's
//    rate of deformation on the reference geometry (small strains), force
//    V Bbar sigma_v. Its damping fraction beta omega / 2 grows with the
//    frequency: it removes element-scale vibration (omega near omega_max)
//    and leaves the slow modes of the body almost undamped, which mass
//    damping cannot do. The stable step shrinks by Liu Eq. 65
//    (Model::criticalTimeStep).
// Evaluation never forms Gamma: with c = X^T h (3 x 4, per element) and the
// displacement gradient H = U^T Bbar, the hourglass modes are
//   q = Gamma^T U = h^T U - c^T H^T,
// and the element force w F S Bbar + k Gamma q folds into one product with
// Bbar,  f = Bbar T^T + k h q,  T = w F S - k (c q)^T,
// so an element reads 38 numbers instead of 58 and the two 8 x 4 x 3
// products with Gamma become products with the constant +-1 matrix h.
#include <cmath>

#include "cosim/fem/fem/element_formulation.hpp"
#include "cosim/fem/fem/hex8.hpp"
#include "cosim/fem/fem/total_lagrangian.hpp"

namespace cosim::fem {
namespace {

using Mat84 = Eigen::Matrix<double, 8, 4>;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Mat43 = Eigen::Matrix<double, 4, 3>;

/// Hourglass base vectors h_alpha (Flanagan & Belytschko 1981 Eq. 37):
/// eta zeta, xi zeta, xi eta, xi eta zeta at the nodes.
Mat84 hourglassBase() {
  Mat84 h;
  for (int a = 0; a < 8; ++a) {
    const double* s = hex8::kNodeXi[a];
    h(a, 0) = s[1] * s[2];
    h(a, 1) = s[0] * s[2];
    h(a, 2) = s[0] * s[1];
    h(a, 3) = s[0] * s[1] * s[2];
  }
  return h;
}
const Mat84 kHourglassBase = hourglassBase();

/// What an element needs at run time, contiguous per element.
struct OnePointElement {
  Mat83 bbar;       // mean gradient Bbar
  Mat34 base;       // c = X^T h
  double volume;    // V
  double hourglass; // k (stiffness type) or c (viscous type)
};

class Hex8OnePoint final : public ElementFormulation {
 public:
  std::string name() const override { return "one-point"; }
  void initialise(const Mesh& mesh, const Material& material, const FormulationOptions& options) override {
    material_ = &material;
    viscous_ = options.hourglassType == FormulationOptions::Hourglass::viscous;
    if (!(options.stiffnessDamping >= 0.0) || !std::isfinite(options.stiffnessDamping))
      throw InputError("stiffness damping must be finite and >= 0");
    beta_ = options.stiffnessDamping;
    if (!(options.hourglassCoefficient >= 0.0) || !std::isfinite(options.hourglassCoefficient))
      throw InputError("hourglass coefficient must be finite and >= 0");
    hex8::ReferenceGeometry geometry;
    geometry.build(mesh);
    elements_.resize(mesh.numElements());
    for (std::size_t e = 0; e < elements_.size(); ++e) {
      OnePointElement& el = elements_[e];
      el.bbar.setZero();
      for (int q = 0; q < 8; ++q) el.bbar += geometry.weight(e, q) * geometry.grad(e, q);
      el.volume = geometry.volume[e];
      el.bbar /= el.volume;
      el.base = mesh.elementCoordinates(e).transpose() * kHourglassBase;
      if (viscous_) {
        const double waveSpeed = std::sqrt(material.waveModulus() / material.density());
        el.hourglass = options.hourglassCoefficient * material.density() * waveSpeed * std::cbrt(el.volume * el.volume) / 4.0;
      } else {
        el.hourglass = options.hourglassCoefficient * material.waveModulus() * el.volume * el.bbar.squaredNorm() / 8.0;
      }
    }
  }

  void evaluate(std::size_t e, const Mat83& ue, Vec24& fe, Mat24* Ke, ElementEnergy& energy) const override {
    const OnePointElement& el = elements_[e];
    const double scale = pointScale(e, 0);
    if (Ke) {
      evaluateWithTangent(e, ue, scale, fe, *Ke, energy);
      return;
    }
    const double w = el.volume * scale;
    const Mat3 H = ue.transpose() * el.bbar;
    Mat3 S;
    double W = 0.0;
    material_->evaluateAt(e, H, S, nullptr, W);
    energy.strain += w * W;
    Mat3 T = w * (Mat3::Identity() + H) * S;  // w F S
    Mat83 f;
    if (viscous_) {  // the hourglass force depends on velocity: viscousForce()
      f.noalias() = el.bbar * T.transpose();
    } else {
      const double k = el.hourglass * scale;
      const Mat43 q = hourglassModes(el, ue, H);
      T.noalias() -= k * (el.base * q).transpose();
      f.noalias() = el.bbar * T.transpose();
      f.noalias() += k * (kHourglassBase * q);
      energy.hourglass += 0.5 * k * q.squaredNorm();
    }
    toNodeMajor(f, fe);
  }

  int pointsPerElement() const override { return 1; }
  bool hasViscousForce() const override { return viscous_ || beta_ > 0.0; }
  double stiffnessDamping() const override { return beta_; }
  void viscousForce(std::size_t e, const Mat83& ve, Vec24& fe) const override {
    const OnePointElement& el = elements_[e];
    const Mat3 L = ve.transpose() * el.bbar;  // velocity gradient
    Mat83 f = Mat83::Zero();
    if (viscous_) {
      const double c = el.hourglass * pointScale(e, 0);
      const Mat43 q = hourglassModes(el, ve, L);  // hourglass velocity modes
      f.noalias() += c * (kHourglassBase * q);
      f.noalias() -= el.bbar * (c * (el.base * q));
    }
    if (beta_ > 0.0) {
      const Mat3 D = 0.5 * (L + L.transpose());
      const Mat3 sigma = beta_ * (material_->lambda() * D.trace() * Mat3::Identity() + 2.0 * material_->mu() * D);
      f.noalias() += (el.volume * pointScale(e, 0)) * (el.bbar * sigma);
    }
    toNodeMajor(f, fe);
  }
  void pointStates(std::size_t e, const Mat83& ue, MaterialPointState* out) const override {
    pointStress<8>(elements_[e].bbar, ue, *material_, out[0].F, out[0].S, e);
  }

 private:
  /// q = Gamma^T U = h^T U - c^T H^T with H = U^T Bbar.
  static Mat43 hourglassModes(const OnePointElement& el, const Mat83& U, const Mat3& H) {
    Mat43 q = kHourglassBase.transpose() * U;
    q.noalias() -= el.base.transpose() * H.transpose();
    return q;
  }
  static void toNodeMajor(const Mat83& f, Vec24& fe) {
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) fe(3 * a + i) = f(a, i);
  }
  /// Material part through the shared kernel, hourglass stiffness k Gamma Gamma^T.
  void evaluateWithTangent(std::size_t e, const Mat83& ue, double scale, Vec24& fe, Mat24& Ke,
                           ElementEnergy& energy) const {
    const OnePointElement& el = elements_[e];
    fe.setZero();
    Ke.setZero();
    addMaterialPoint<8>(el.bbar, ue, el.volume * scale, *material_, fe, &Ke, energy.strain, e);
    if (viscous_) return;
    const double k = el.hourglass * scale;
    const Mat84 gamma = kHourglassBase - el.bbar * el.base;
    const Mat43 q = gamma.transpose() * ue;
    const Mat83 fh = k * (gamma * q);
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) fe(3 * a + i) += fh(a, i);
    energy.hourglass += 0.5 * k * q.squaredNorm();
    const Eigen::Matrix<double, 8, 8> gg = k * gamma * gamma.transpose();
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b)
        for (int i = 0; i < 3; ++i) Ke(3 * a + i, 3 * b + i) += gg(a, b);
  }

  std::vector<OnePointElement> elements_;
  double beta_ = 0.0;  // stiffness damping [s]
  bool viscous_ = false;
  const Material* material_ = nullptr;
};

const FormulationRegistry::Registrar kOnePoint("one-point", [] { return std::make_unique<Hex8OnePoint>(); });

}  // namespace
}  // namespace cosim::fem
