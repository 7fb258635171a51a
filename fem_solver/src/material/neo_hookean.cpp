// Compressible Neo-Hookean: W = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2.
// S = mu (I - C^-1) + lambda ln J C^-1 and
// dS/dE = lambda C^-1 (x) C^-1 + 2 (mu - lambda ln J) C^-1 (.) C^-1
// (standard hyperelastic derivation; not in the seed papers).
#include <cmath>

#include "cosim/fem/material/material.hpp"

namespace cosim::fem {
namespace {

constexpr int kVoigt[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {1, 2}, {0, 2}};

class NeoHookean final : public Material {
 public:
  using Material::Material;
  std::string name() const override { return "neo-hookean"; }
  void evaluate(const Mat3& H, Mat3& S, Mat6* tangent, double& W) const override {
    const Mat3 F = Mat3::Identity() + H;
    const double J = F.determinant();
    if (!(J > 0.0)) throw SolveError("neo-hookean: non-positive volume ratio J = " + std::to_string(J));
    const Mat3 C = F.transpose() * F;
    const Mat3 Ci = C.inverse();
    const double lnJ = std::log(J);
    S = mu_ * (Mat3::Identity() - Ci) + lambda_ * lnJ * Ci;
    W = 0.5 * mu_ * (C.trace() - 3.0) - mu_ * lnJ + 0.5 * lambda_ * lnJ * lnJ;
    if (!tangent) return;
    const double m = mu_ - lambda_ * lnJ;
    for (int I = 0; I < 6; ++I) {
      for (int K = 0; K < 6; ++K) {
        const int i = kVoigt[I][0], j = kVoigt[I][1], k = kVoigt[K][0], l = kVoigt[K][1];
        (*tangent)(I, K) = lambda_ * Ci(i, j) * Ci(k, l) + m * (Ci(i, k) * Ci(j, l) + Ci(i, l) * Ci(j, k));
      }
    }
  }
};

const MaterialRegistry::Registrar kNeoHookean("neo-hookean", [](const MaterialParams& p) {
  return std::make_unique<NeoHookean>(p);
});

}  // namespace
}  // namespace cosim::fem
