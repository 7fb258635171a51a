// The homogenisation operator Pi of Cheng 2022 Eq. 27 in its two forms:
// basis functions at the particles (c = 0, Eq. 19) and the CG-enriched form
// (c > 0, Eq. 18). Both normalise each node's row to one (Eq. 41).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "cosim/coupler/mapping/cg_kernel.hpp"
#include "cosim/coupler/mapping/homogenisation.hpp"
#include "cosim/coupler/mapping/gauss_legendre.hpp"
#include <Eigen/LU>

namespace cosim::coupler {
namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

std::string point(const Eigen::Vector3d& x) {
  std::ostringstream s;
  s << "(" << x[0] << ", " << x[1] << ", " << x[2] << ")";
  return s.str();
}

/// Pi_ia = g_ia / sum_b g_ib. A node no particle reaches makes Pi singular
/// (its u^DE is undefined): refuse, naming the node.
SparseMatrix normaliseRows(const ZoneMesh& zone, std::size_t particles, const Triplets& g, const std::string& form) {
  const auto n = static_cast<Eigen::Index>(zone.nodes.size());
  SparseMatrix pi(n, static_cast<Eigen::Index>(particles));
  pi.setFromTriplets(g.begin(), g.end());
  const Eigen::VectorXd rowSum = pi * Eigen::VectorXd::Ones(pi.cols());
  const double largest = rowSum.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(rowSum[i] > 1e-12 * largest))
      throw std::runtime_error("homogenisation operator Pi (Cheng Eq. 27, " + form + ") is singular: zone node " +
                               std::to_string(zone.nodes[static_cast<std::size_t>(i)]) + " at " +
                               point(zone.positions[static_cast<std::size_t>(i)]) +
                               " has no coupled particle in its support");
  for (Eigen::Index i = 0; i < n; ++i)
    for (SparseMatrix::InnerIterator it(pi, i); it; ++it) it.valueRef() /= rowSum[i];
  return pi;
}

}  // namespace

SparseMatrix homogenisationDirac(const ZoneMesh& zone, const ParticleCloud& particles) {
  // Cheng Eq. 19: g_ia = m_a psi_i(x_a) for the element holding x_a. A
  // particle on a shared face belongs to the first element found; psi is
  // continuous there, so the choice does not change g.
  Triplets g;
  const double tol = 1e-10;
  for (std::size_t a = 0; a < particles.positions.size(); ++a) {
    const Eigen::Vector3d& x = particles.positions[a];
    for (std::size_t e = 0; e < zone.elements.size(); ++e) {
      const hex8::Corners X = zone.corners(e);
      Eigen::Vector3d lo = X[0], hi = X[0];
      for (const auto& c : X) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
      const double pad = tol * (hi - lo).norm();
      if ((x.array() < lo.array() - pad).any() || (x.array() > hi.array() + pad).any()) continue;
      Eigen::Vector3d xi;
      if (!hex8::inverseMap(X, x, xi) || xi.cwiseAbs().maxCoeff() > 1.0 + tol) continue;
      const auto N = hex8::shape(xi);
      for (std::size_t k = 0; k < 8; ++k)
        if (N[k] != 0.0)
          g.emplace_back(static_cast<int>(zone.elements[e][k]), static_cast<int>(a), particles.masses[a] * N[k]);
      break;
    }
  }
  return normaliseRows(zone, particles.positions.size(), g, "c = 0");
}

SparseMatrix homogenisationCg(const ZoneMesh& zone, const ParticleCloud& particles, const CgKernel& kernel,
                              double width) {
  if (!(width > 0.0)) throw std::runtime_error("CG homogenisation needs a positive width, got " + std::to_string(width));
  // Cheng Eq. 18: g_ia = m_a int_{Omega^C} W(|x - x_a|; c) psi_i(x) dV, by a
  // tensor Gauss rule per element fine enough to resolve the kernel (about
  // four points per width; the 2x2x2 rule of the FE solver does not).
  Triplets g;
  for (std::size_t e = 0; e < zone.elements.size(); ++e) {
    const hex8::Corners X = zone.corners(e);
    Eigen::Vector3d lo = X[0], hi = X[0];
    for (const auto& c : X) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    // (1 - 1e-9): equal elements whose sizes differ by round-off get the same rule.
    const int n = std::clamp(static_cast<int>(std::ceil(4.0 * (hi - lo).maxCoeff() / width * (1.0 - 1e-9))), 2, 24);
    std::vector<double> gx, gw;
    gaussLegendre(n, gx, gw);
    // Quadrature points of this element: position, psi values, weight x det J.
    std::vector<Eigen::Vector3d> xq;
    std::vector<std::array<double, 8>> Nq;
    std::vector<double> wq;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          const Eigen::Vector3d xi(gx[static_cast<std::size_t>(i)], gx[static_cast<std::size_t>(j)], gx[static_cast<std::size_t>(k)]);
          Eigen::Matrix3d J;
          xq.push_back(hex8::map(X, xi, &J));
          Nq.push_back(hex8::shape(xi));
          wq.push_back(gw[static_cast<std::size_t>(i)] * gw[static_cast<std::size_t>(j)] * gw[static_cast<std::size_t>(k)] *
                       J.determinant());
        }
    // Particles within c of the element's box (the extended element of Cheng Fig. 5).
    for (std::size_t a = 0; a < particles.positions.size(); ++a) {
      const Eigen::Vector3d& xa = particles.positions[a];
      if ((xa.array() < lo.array() - width).any() || (xa.array() > hi.array() + width).any()) continue;
      std::array<double, 8> sum{};
      for (std::size_t q = 0; q < xq.size(); ++q) {
        const double W = kernel.value((xq[q] - xa).norm(), width);
        if (W == 0.0) continue;
        for (std::size_t b = 0; b < 8; ++b) sum[b] += W * Nq[q][b] * wq[q];
      }
      for (std::size_t b = 0; b < 8; ++b)
        if (sum[b] != 0.0) g.emplace_back(static_cast<int>(zone.elements[e][b]), static_cast<int>(a), particles.masses[a] * sum[b]);
    }
  }
  return normaliseRows(zone, particles.positions.size(), g, kernel.name() + " kernel, c = " + std::to_string(width) + " m");
}

}  // namespace cosim::coupler
