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
#include <cmath>

#include "cosim/fem/fem/element_formulation.hpp"
#include "cosim/fem/fem/hex8.hpp"
#include "cosim/fem/fem/total_lagrangian.hpp"

namespace cosim::fem {
namespace {

using Mat84 = Eigen::Matrix<double, 8, 4>;

class Hex8OnePoint final : public ElementFormulation {
 public:
  std::string name() const override { return "one-point"; }
  void initialise(const Mesh& mesh, const Material& material, const FormulationOptions& options) override {
    material_ = &material;
    viscous_ = options.hourglassType == FormulationOptions::Hourglass::viscous;
    if (!(options.hourglassCoefficient >= 0.0) || !std::isfinite(options.hourglassCoefficient))
      throw InputError("hourglass coefficient must be finite and >= 0");
    hex8::ReferenceGeometry geometry;
    geometry.build(mesh);
    const std::size_t ne = mesh.numElements();
    bbar_.resize(ne);
    volume_.resize(ne);
    gamma_.resize(ne);
    stiffness_.resize(ne);
    Mat84 h;
    for (int a = 0; a < 8; ++a) {
      const double* s = hex8::kNodeXi[a];
      h(a, 0) = s[1] * s[2];
      h(a, 1) = s[0] * s[2];
      h(a, 2) = s[0] * s[1];
      h(a, 3) = s[0] * s[1] * s[2];
    }
    for (std::size_t e = 0; e < ne; ++e) {
      Mat83 B = Mat83::Zero();
      for (int q = 0; q < 8; ++q) B += geometry.weight(e, q) * geometry.grad(e, q);
      const double V = geometry.volume[e];
      B /= V;
      const Mat83 X = mesh.elementCoordinates(e);
      // gamma = h - B (X^T h): removes the linear part of each base vector.
      const Mat84 gamma = h - B * (X.transpose() * h);
      bbar_[e] = B;
      volume_[e] = V;
      gamma_[e] = gamma;
      if (viscous_) {
        const double waveSpeed = std::sqrt(material.waveModulus() / material.density());
        stiffness_[e] = options.hourglassCoefficient * material.density() * waveSpeed * std::cbrt(V * V) / 4.0;
      } else {
        stiffness_[e] = options.hourglassCoefficient * material.waveModulus() * V * B.squaredNorm() / 8.0;
      }
    }
  }

  void evaluate(std::size_t e, const Mat83& ue, Vec24& fe, Mat24* Ke, ElementEnergy& energy) const override {
    fe.setZero();
    if (Ke) Ke->setZero();
    const double scale = pointScale(e, 0);
    addMaterialPoint<8>(bbar_[e], ue, volume_[e] * scale, *material_, fe, Ke, energy.strain, e);
    if (viscous_) return;  // the hourglass force depends on velocity: viscousForce()
    const Mat84& g = gamma_[e];
    const double k = stiffness_[e] * scale;
    const Eigen::Matrix<double, 4, 3> q = g.transpose() * ue;  // hourglass displacement modes
    const Mat83 fh = k * (g * q);
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) fe(3 * a + i) += fh(a, i);
    energy.hourglass += 0.5 * k * q.squaredNorm();
    if (!Ke) return;
    const Eigen::Matrix<double, 8, 8> gg = k * g * g.transpose();
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b)
        for (int i = 0; i < 3; ++i) (*Ke)(3 * a + i, 3 * b + i) += gg(a, b);
  }

  int pointsPerElement() const override { return 1; }
  bool hasViscousForce() const override { return viscous_; }
  void viscousForce(std::size_t e, const Mat83& ve, Vec24& fe) const override {
    fe.setZero();
    if (!viscous_) return;
    const Mat84& g = gamma_[e];
    const Eigen::Matrix<double, 4, 3> q = g.transpose() * ve;  // hourglass velocity modes
    const Mat83 fh = stiffness_[e] * pointScale(e, 0) * (g * q);
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) fe(3 * a + i) = fh(a, i);
  }
  void pointStates(std::size_t e, const Mat83& ue, MaterialPointState* out) const override {
    pointStress<8>(bbar_[e], ue, *material_, out[0].F, out[0].S, e);
  }

 private:
  std::vector<Mat83> bbar_;
  std::vector<double> volume_;
  std::vector<Mat84> gamma_;
  std::vector<double> stiffness_;  // k (stiffness type) or c (viscous type) per element
  bool viscous_ = false;
  const Material* material_ = nullptr;
};

const FormulationRegistry::Registrar kOnePoint("one-point", [] { return std::make_unique<Hex8OnePoint>(); });

}  // namespace
}  // namespace cosim::fem
