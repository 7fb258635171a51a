// The homogenisation operator Pi of Cheng 2022 Eq. 27 in its two forms:
// basis functions at the particles (c = 0, Eq. 19) and the CG-enriched form
// (c > 0, Eq. 18), each either over the whole zone (one row per node) or per
// element (one row per element corner, the published runs' form). Every row
// is normalised to one (Eq. 41).
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

struct ElementWeight {
  std::size_t element, corner, particle;
  double value;
};

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


/// g_(e, k), a for every element e, its corner k and particle a: Cheng Eq. 19
/// (kernel null) or Eq. 18 over element e alone. `sharedFaces`: a particle on
/// a face shared by two elements counts in both (each element locates its
/// particles by itself, as the published runs did), else in the first only.
std::vector<ElementWeight> elementWeights(const ZoneMesh& zone, const ParticleCloud& particles, const Smoothing& smoothing,
                                          bool sharedFaces) {
  std::vector<ElementWeight> g;
  const double width = smoothing.width;
  if (!smoothing.kernel) {
    // psi is continuous across faces, so the first element found gives the
    // zone form the same g as any other.
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
          if (N[k] != 0.0) g.push_back({e, k, a, particles.masses[a] * N[k]});
        if (!sharedFaces) break;
      }
    }
    return g;
  }
  if (!(width > 0.0)) throw std::runtime_error("CG homogenisation needs a positive width, got " + std::to_string(width));
  // Cheng Eq. 18: g_ia = m_a int_{Omega^C} W(|x - x_a|; c) psi_i(x) dV, by a
  // tensor Gauss rule per element fine enough to resolve the kernel (about
  // four points per width; the 2x2x2 rule of the FE solver does not).
  for (std::size_t e = 0; e < zone.elements.size(); ++e) {
    const hex8::Corners X = zone.corners(e);
    Eigen::Vector3d lo = X[0], hi = X[0];
    for (const auto& c : X) lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
    // (1 - 1e-9): equal elements whose sizes differ by round-off get the same rule.
    const int n = smoothing.points > 0
                      ? smoothing.points
                      : std::clamp(static_cast<int>(std::ceil(4.0 * (hi - lo).maxCoeff() / width * (1.0 - 1e-9))), 2, 24);
    const ElementRule rule = elementRule(X, n);
    // Particles within c of the element's box (the extended element of Cheng Fig. 5).
    for (std::size_t a = 0; a < particles.positions.size(); ++a) {
      const Eigen::Vector3d& xa = particles.positions[a];
      if ((xa.array() < lo.array() - width).any() || (xa.array() > hi.array() + width).any()) continue;
      std::array<double, 8> sum{};
      for (std::size_t q = 0; q < rule.x.size(); ++q) {
        const double W = smoothing.kernel->value((rule.x[q] - xa).norm(), width);
        if (W == 0.0) continue;
        for (std::size_t b = 0; b < 8; ++b) sum[b] += W * rule.N[q][b] * rule.w[q];
      }
      for (std::size_t b = 0; b < 8; ++b)
        if (sum[b] != 0.0) g.push_back({e, b, a, particles.masses[a] * sum[b]});
    }
  }
  return g;
}

std::string formName(const Smoothing& s) {
  return s.kernel ? s.kernel->name() + " kernel, c = " + std::to_string(s.width) + " m" : std::string("c = 0");
}

}  // namespace

ElementRule elementRule(const hex8::Corners& X, int n) {
  std::vector<double> gx, gw;
  gaussLegendre(n, gx, gw);
  ElementRule r;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const auto I = static_cast<std::size_t>(i), J = static_cast<std::size_t>(j), K = static_cast<std::size_t>(k);
        const Eigen::Vector3d xi(gx[I], gx[J], gx[K]);
        Eigen::Matrix3d jac;
        r.x.push_back(hex8::map(X, xi, &jac));
        r.N.push_back(hex8::shape(xi));
        r.w.push_back(gw[I] * gw[J] * gw[K] * jac.determinant());
      }
  return r;
}

SparseMatrix homogenisationDirac(const ZoneMesh& zone, const ParticleCloud& particles) {
  return homogenisation(zone, particles, Smoothing{});
}

SparseMatrix homogenisationCg(const ZoneMesh& zone, const ParticleCloud& particles, const CgKernel& kernel,
                              double width) {
  return homogenisation(zone, particles, Smoothing{&kernel, width});
}

SparseMatrix homogenisation(const ZoneMesh& zone, const ParticleCloud& particles, const Smoothing& smoothing) {
  Triplets g;
  for (const ElementWeight& w : elementWeights(zone, particles, smoothing, false))
    g.emplace_back(static_cast<int>(zone.elements[w.element][w.corner]), static_cast<int>(w.particle), w.value);
  return normaliseRows(zone, particles.positions.size(), g, formName(smoothing));
}

ElementPenalty elementPenalty(const ZoneMesh& zone, const ParticleCloud& particles, const Smoothing& smoothing, bool lumped) {
  // One row per (element, corner) that some particle reaches: elements
  // without particles are not coupled.
  const std::vector<ElementWeight> g = elementWeights(zone, particles, smoothing, true);
  std::vector<long> row(8 * zone.elements.size(), -1);
  std::vector<double> rowSum;
  for (const ElementWeight& w : g) {
    long& r = row[8 * w.element + w.corner];
    if (r < 0) r = static_cast<long>(rowSum.size()), rowSum.push_back(0.0);
    rowSum[static_cast<std::size_t>(r)] += w.value;
  }
  if (rowSum.empty())
    throw std::runtime_error("homogenisation operator Pi (Cheng Eq. 27, " + formName(smoothing) +
                             ", per element): no particle lies in any zone element");
  const auto rows = static_cast<Eigen::Index>(rowSum.size());
  Triplets pi, gather, matrix;
  for (const ElementWeight& w : g)
    pi.emplace_back(static_cast<int>(row[8 * w.element + w.corner]), static_cast<int>(w.particle),
                    w.value / rowSum[static_cast<std::size_t>(row[8 * w.element + w.corner])]);
  for (std::size_t e = 0; e < zone.elements.size(); ++e) {
    // The element's own M^e_kl = int_e psi_k psi_l dV (2x2x2 Gauss, exact on
    // parallelepipeds), or its row sums int_e psi_k dV.
    const ElementRule rule = elementRule(zone.corners(e), 2);
    for (std::size_t k = 0; k < 8; ++k) {
      const long rk = row[8 * e + k];
      if (rk < 0) continue;
      gather.emplace_back(static_cast<int>(rk), static_cast<int>(zone.elements[e][k]), 1.0);
      for (std::size_t l = 0; l < 8; ++l) {
        const long rl = row[8 * e + l];
        double m = 0.0;
        for (std::size_t q = 0; q < rule.w.size(); ++q) m += rule.N[q][k] * rule.N[q][l] * rule.w[q];
        if (lumped) matrix.emplace_back(static_cast<int>(rk), static_cast<int>(rk), m);
        else if (rl >= 0) matrix.emplace_back(static_cast<int>(rk), static_cast<int>(rl), m);
      }
    }
  }
  ElementPenalty out{SparseMatrix(rows, static_cast<Eigen::Index>(particles.positions.size())),
                     SparseMatrix(rows, static_cast<Eigen::Index>(zone.nodes.size())), SparseMatrix(rows, rows)};
  out.pi.setFromTriplets(pi.begin(), pi.end());
  out.gather.setFromTriplets(gather.begin(), gather.end());
  out.matrix.setFromTriplets(matrix.begin(), matrix.end());
  return out;
}

}  // namespace cosim::coupler
