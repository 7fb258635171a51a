// CG kernels W(r; c) of Cheng 2022 Eqs. (9)-(10): 3D normalisation, compact
// support, shape; their quadrature-normalised use on a surface (Sec. 5.1.2);
// and the c -> 0 limit of the nodal surface force, Eq. (15) -> Eq. (16).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {
namespace {

const std::array<double, 5> kWidths{1e-4, 2e-3, 0.05, 1.0, 7.5};

// 4 pi int_0^c W(r) r^2 dr by composite Simpson (error ~ (c/n)^4, far below 1e-10 for n = 20000).
double radialIntegral(const CgKernel& k, double c) {
  const int n = 20000;
  const double h = c / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    // The cut-off Gaussian jumps to zero at r = c: the end point takes the inner limit.
    const double r = i == n ? std::nextafter(c, 0.0) : i * h;
    const double f = k.value(r, c) * r * r;
    sum += (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0)) * f;
  }
  return 4.0 * std::numbers::pi * sum * h / 3.0;
}

class SmoothKernel : public ::testing::TestWithParam<const char*> {
 protected:
  std::unique_ptr<CgKernel> kernel = CgKernelRegistry::create(GetParam(), "CG kernel");
};

TEST_P(SmoothKernel, NormalisedIn3D) {
  for (double c : kWidths) {
    const double integral = radialIntegral(*kernel, c);
    std::printf("%s c = %g: 4 pi int W r^2 dr = %.15f\n", GetParam(), c, integral);
    EXPECT_NEAR(integral, 1.0, 1e-10) << "c = " << c;
  }
}

TEST_P(SmoothKernel, CompactSupportNonNegativeMonotone) {
  for (double c : kWidths) {
    EXPECT_EQ(kernel->value(c, c), 0.0);
    EXPECT_EQ(kernel->value(std::nextafter(c, 2 * c), c), 0.0);
    EXPECT_EQ(kernel->value(3.0 * c, c), 0.0);
    EXPECT_GT(kernel->value(0.999 * c, c), 0.0);
    double previous = kernel->value(0.0, c);
    EXPECT_GT(previous, 0.0);
    for (int i = 1; i <= 1000; ++i) {
      const double w = kernel->value(c * i / 1000.0, c);
      EXPECT_GE(w, 0.0);
      EXPECT_LE(w, previous) << "W increases at r = " << c * i / 1000.0;
      previous = w;
    }
  }
}

// A flat surface z = 0 over [0, L]^2 covered by bilinear elements of size e,
// each split into s x s sub-cells with 2 x 2 Gauss points: the quadrature the
// surface map integrates on.
struct SurfaceQuadrature {
  std::vector<double> x, y, w;
  SurfaceQuadrature(double length, int cells) {
    const double h = length / cells, g = 0.5 / std::sqrt(3.0);
    for (int j = 0; j < cells; ++j)
      for (int i = 0; i < cells; ++i)
        for (double gy : {-g, g})
          for (double gx : {-g, g}) {
            x.push_back((i + 0.5 + gx) * h);
            y.push_back((j + 0.5 + gy) * h);
            w.push_back(0.25 * h * h);
          }
  }
};

// Quadrature-normalised kernel weights around (x0, y0) (Cheng Sec. 5.1.2: "the
// quadrature formula is normalized"): a_q = w_q W(|x_q - x0|) / sum_q w_q W.
std::vector<double> normalisedWeights(const CgKernel& k, double c, const SurfaceQuadrature& q, double x0, double y0) {
  std::vector<double> a(q.w.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    a[i] = q.w[i] * k.value(std::hypot(q.x[i] - x0, q.y[i] - y0), c);
    sum += a[i];
  }
  for (double& v : a) v /= sum;
  return a;
}

TEST_P(SmoothKernel, SurfaceQuadratureNormalisation) {
  const SurfaceQuadrature q(4.0, 160);  // sub-cells of 0.025
  const double x0 = 1.7312, y0 = 2.2049;   // off the quadrature lattice, away from the edges
  for (double c : {0.8, 0.4, 0.2, 0.1}) {
    const std::vector<double> a = normalisedWeights(*kernel, c, q, x0, y0);
    double sum = 0.0, cx = 0.0, cy = 0.0;
    std::size_t used = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      sum += a[i];
      cx += a[i] * q.x[i];
      cy += a[i] * q.y[i];
      used += a[i] > 0.0;
    }
    const double offset = std::hypot(cx - x0, cy - y0);
    std::printf("%s c = %.2f: %zu quadrature points, weight sum - 1 = %.1e, centroid offset %.2e c\n", GetParam(), c,
                used, sum - 1.0, offset / c);
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_LT(offset, 1e-3 * c);
  }
}

// Eq. (15) with the quadrature-normalised kernel against its limit Eq. (16):
// f_i = F sum_q a_q psi_i(x_q)  ->  F psi_i(x0)  as c -> 0, psi_i bilinear hats.
double nodalForceError(const CgKernel& k, double c, const SurfaceQuadrature& q, double e, double x0, double y0) {
  const std::vector<double> a = normalisedWeights(k, c, q, x0, y0);
  const auto hat = [e](double x, double y, double xi, double yi) {
    return std::max(0.0, 1.0 - std::fabs(x - xi) / e) * std::max(0.0, 1.0 - std::fabs(y - yi) / e);
  };
  double worst = 0.0;
  for (int nj = 0; nj <= 4; ++nj)
    for (int ni = 0; ni <= 4; ++ni) {
      double f = 0.0;
      for (std::size_t i = 0; i < a.size(); ++i) f += a[i] * hat(q.x[i], q.y[i], ni * e, nj * e);
      worst = std::max(worst, std::fabs(f - hat(x0, y0, ni * e, nj * e)));
    }
  return worst;  // per unit force
}

TEST_P(SmoothKernel, NodalForceConvergesToPointFormAsWidthVanishes) {
  const double e = 1.0;                  // element size: 4 x 4 bilinear elements
  const SurfaceQuadrature q(4.0, 320);   // 80 x 80 sub-cells per element
  // On an element edge (x = 2): psi_i has a kink there, so smearing it costs O(c).
  std::vector<double> errors;
  for (double c : {0.4, 0.2, 0.1, 0.05}) {
    errors.push_back(nodalForceError(*kernel, c, q, e, 2.0, 1.37));
    std::printf("%s on an edge, c = %.3f: max_i |f_i - F psi_i(x0)| / |F| = %.3e\n", GetParam(), c, errors.back());
  }
  for (std::size_t k = 1; k < errors.size(); ++k) {
    const double rate = std::log2(errors[k - 1] / errors[k]);
    EXPECT_GT(rate, 0.9) << "halving c must halve the error (O(c))";
    EXPECT_LT(rate, 1.1);
  }
  // Inside an element psi_i is bilinear, so a symmetric kernel reproduces psi_i(x0)
  // once its support fits inside the element: only the quadrature error remains
  // (largest for the cut-off Gaussian, whose jump at r = c the sub-cells resolve to O(h)).
  const double inside = nodalForceError(*kernel, 0.1, q, e, 2.43, 1.37);
  std::printf("%s inside an element, c = 0.1: error %.3e\n", GetParam(), inside);
  EXPECT_LT(inside, 1e-4);
  EXPECT_LT(inside, 1e-2 * errors[2]);
}

INSTANTIATE_TEST_SUITE_P(Kernels, SmoothKernel, ::testing::Values("lucy", "gaussian"));

TEST(DiracKernel, ReportsDiracAndRefusesPointValues) {
  const auto dirac = CgKernelRegistry::create("dirac", "CG kernel");
  EXPECT_TRUE(dirac->isDirac());
  EXPECT_THROW((void)dirac->value(0.0, 1.0), std::logic_error);
  EXPECT_FALSE(CgKernelRegistry::create("lucy", "CG kernel")->isDirac());
  EXPECT_FALSE(CgKernelRegistry::create("gaussian", "CG kernel")->isDirac());
  EXPECT_THROW((void)CgKernelRegistry::create("tophat", "CG kernel"), std::invalid_argument);
}

}  // namespace
}  // namespace cosim::coupler
