#pragma once
// The total Lagrangian material-point kernel shared by every formulation
// (Cheng 2022 Eq. 5): with G the rows of gradients of the N interpolation
// functions w.r.t. reference coordinates, F = I + U^T G, E = (F^T F - I)/2,
// S = S(E), and the residual contribution f_ai = w sum_jk F_ij S_jk G_ak.
// The consistent tangent is the material part B^T C B plus the geometric
// part (G S G^T) (x) I.
#include "cosim/fem/material/material.hpp"
#include "cosim/fem/types.hpp"

namespace cosim::fem {

template <int N>
using GradRows = Eigen::Matrix<double, N, 3>;
template <int N>
using PointVec = Eigen::Matrix<double, 3 * N, 1>;
template <int N>
using PointMat = Eigen::Matrix<double, 3 * N, 3 * N, Eigen::RowMajor>;

/// Contribution of the N rows G at a point whose displacement gradient H is
/// given (H may involve more interpolation functions than the rows in G).
template <int N>
void addPointRows(const GradRows<N>& G, const Mat3& H, double w, const Material& material, PointVec<N>& f,
                  PointMat<N>* K, double& energy, std::size_t point) {
  const Mat3 F = Mat3::Identity() + H;
  Mat3 S;
  Mat6 C;
  double W = 0.0;
  material.evaluateAt(point, H, S, K ? &C : nullptr, W);
  energy += w * W;
  const Mat3 FS = F * S;
  const GradRows<N> P = G * FS.transpose();  // P(a, i) = sum_k G_ak (F S)_ik
  for (int a = 0; a < N; ++a)
    for (int i = 0; i < 3; ++i) f(3 * a + i) += w * P(a, i);
  if (!K) return;
  // B maps a nodal variation to the Voigt variation of E: dE = sym(F^T dF).
  Eigen::Matrix<double, 6, 3 * N> B;
  for (int a = 0; a < N; ++a) {
    const double g0 = G(a, 0), g1 = G(a, 1), g2 = G(a, 2);
    for (int i = 0; i < 3; ++i) {
      const int c = 3 * a + i;
      B(0, c) = F(i, 0) * g0;
      B(1, c) = F(i, 1) * g1;
      B(2, c) = F(i, 2) * g2;
      B(3, c) = F(i, 0) * g1 + F(i, 1) * g0;
      B(4, c) = F(i, 1) * g2 + F(i, 2) * g1;
      B(5, c) = F(i, 0) * g2 + F(i, 2) * g0;
    }
  }
  const Eigen::Matrix<double, 6, 3 * N> CB = C * B;
  K->noalias() += w * (B.transpose() * CB);
  const Eigen::Matrix<double, N, N> geo = G * S * G.transpose();
  for (int a = 0; a < N; ++a)
    for (int b = 0; b < N; ++b) {
      const double k = w * geo(a, b);
      for (int i = 0; i < 3; ++i) (*K)(3 * a + i, 3 * b + i) += k;
    }
}

template <int N>
void addMaterialPoint(const GradRows<N>& G, const GradRows<N>& U, double w, const Material& material,
                      PointVec<N>& f, PointMat<N>* K, double& energy, std::size_t point) {
  addPointRows<N>(G, U.transpose() * G, w, material, f, K, energy, point);
}

/// F and S at one point (for output).
template <int N>
void pointStress(const GradRows<N>& G, const GradRows<N>& U, const Material& material, Mat3& F, Mat3& S,
                 std::size_t point) {
  const Mat3 H = U.transpose() * G;
  F = Mat3::Identity() + H;
  double W = 0.0;
  material.evaluateAt(point, H, S, nullptr, W);
}

}  // namespace cosim::fem
