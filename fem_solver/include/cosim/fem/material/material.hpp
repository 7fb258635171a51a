#pragma once
// Constitutive models for the total Lagrangian formulation: given the
// displacement gradient H = F - I (passed instead of F so that small strains
// keep their digits: forming F^T F - I from F loses them), a material returns the second Piola-Kirchhoff
// stress S, the material tangent dS/dE (Voigt, engineering shear) and the
// strain energy density per unit reference volume.
//
// Voigt order: 11, 22, 33, 12, 23, 13.
#include <map>
#include <memory>
#include <string>

#include "cosim/fem/registry.hpp"
#include "cosim/fem/types.hpp"

namespace cosim::fem {

struct MaterialParams {
  double youngsModulus = 0.0;
  double poissonRatio = 0.0;
  double density = 0.0;
};

class Material {
 public:
  static std::string registryKind() { return "material"; }
  explicit Material(const MaterialParams& params);
  virtual ~Material() = default;
  virtual std::string name() const = 0;
  /// S(H), optional tangent C = dS/dE, and strain energy density W; F = I + H.
  virtual void evaluate(const Mat3& H, Mat3& S, Mat6* tangent, double& energyDensity) const = 0;
  /// The same at material point `point` (element e, point q: e * pointsPerElement + q);
  /// only materials with per-point state (the external material) override it.
  virtual void evaluateAt(std::size_t point, const Mat3& H, Mat3& S, Mat6* tangent, double& energyDensity) const {
    (void)point;
    evaluate(H, S, tangent, energyDensity);
  }
  /// Materials with per-point state learn the number of points here.
  virtual void setPointCount(std::size_t points) { (void)points; }

  double density() const { return params_.density; }
  double lambda() const { return lambda_; }
  double mu() const { return mu_; }
  /// P-wave modulus lambda + 2 mu: sets the dilatational wave speed (CFL step).
  double waveModulus() const { return lambda_ + 2.0 * mu_; }
  const MaterialParams& params() const { return params_; }

 protected:
  MaterialParams params_;
  double lambda_ = 0.0;
  double mu_ = 0.0;
};

using MaterialRegistry = Registry<Material, const MaterialParams&>;

/// Green-Lagrange strain E = (F^T F - I) / 2 = (H + H^T + H^T H) / 2 (Cheng 2022, Sec. 3.1);
/// inline: every material evaluation of an explicit step calls it.
inline Mat3 greenStrain(const Mat3& H) { return 0.5 * (H + H.transpose() + H.transpose() * H); }
/// Isotropic elasticity tensor in Voigt form (Cheng 2022 Eq. 33).
Mat6 isotropicTangent(double lambda, double mu);
Vec6 toVoigtStrain(const Mat3& E);   // engineering shear
Mat3 fromVoigtStress(const Vec6& s);

}  // namespace cosim::fem
