#pragma once
// Homogenisation of particle quantities onto the FE nodes of an Arlequin
// zone (Cheng 2022 Sec. 5.2.2) and the penalty forces of the volume coupling
// (Sec. 5.2.3, App. B).
//
// The operator Pi (Cheng Eq. 27) maps particle values to nodal values,
// v_i = sum_a Pi_ia v_a, with Pi_ia = g_ia / sum_b g_ib and
//   c = 0 (Eq. 19):  g_ia = m_a psi_i(x_a)            (x_a inside the zone's elements),
//   c > 0 (Eq. 18):  g_ia = m_a int_{Omega^C} W(|x - x_a|; c) psi_i(x) dV.
// Each row sums to one, which makes the forces on nodes and particles equal
// and opposite (Eq. 41). Pi is built once in the reference configuration.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace cosim::coupler {

class CgKernel;

/// Trilinear hexahedron in fem_solver's node order (VTK: natural coordinates
/// (-1,-1,-1), (1,-1,-1), (1,1,-1), (-1,1,-1), then the same at +1).
namespace hex8 {
using Corners = std::array<Eigen::Vector3d, 8>;
std::array<double, 8> shape(const Eigen::Vector3d& xi);
/// x(xi) and the Jacobian dx/dxi.
Eigen::Vector3d map(const Corners& X, const Eigen::Vector3d& xi, Eigen::Matrix3d* jacobian = nullptr);
/// Inverse isoparametric map by Newton on the trilinear map; false when it
/// does not converge. Inside the element when |xi_k| <= 1 for all k.
bool inverseMap(const Corners& X, const Eigen::Vector3d& x, Eigen::Vector3d& xi);
}  // namespace hex8

/// The hex8 elements of an FE coupling zone, reference configuration, as
/// fem_solver exports them ("<zone>/nodes", "/node_positions", "/elements").
struct ZoneMesh {
  std::vector<std::uint32_t> nodes;                     // global node ids
  std::vector<Eigen::Vector3d> positions;               // per zone node
  std::vector<std::array<std::uint32_t, 8>> elements;   // zone-local node indices
  /// Validates and converts the arrays; throws std::runtime_error naming `what`.
  static ZoneMesh fromArrays(std::span<const double> nodes, std::span<const double> positions,
                             std::span<const double> elements, const std::string& what);
  hex8::Corners corners(std::size_t e) const;
  /// Zone-local index of a global node id, or -1.
  long localIndex(std::uint32_t node) const;
  Eigen::Vector3d lower() const;
  Eigen::Vector3d upper() const;
};

struct ParticleCloud {
  std::vector<Eigen::Vector3d> positions;  // reference positions
  std::vector<double> masses;
};

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

/// A tensor Gauss-Legendre rule of n^3 points on one hex8 element: points,
/// shape values there and weights times det J.
struct ElementRule {
  std::vector<Eigen::Vector3d> x;
  std::vector<std::array<double, 8>> N;
  std::vector<double> w;
};
ElementRule elementRule(const hex8::Corners& X, int n);

/// How Pi smooths: kernel null for Eq. 19 (c = 0), else Eq. 18 with width c,
/// integrated per element by `points`^3 Gauss points (0: about four points
/// per width, which resolves the kernel; 2: the FE's own rule, as the
/// published runs did).
struct Smoothing {
  const CgKernel* kernel = nullptr;
  double width = 0.0;
  int points = 0;
};

/// Cheng Eq. 27 over the zone: one row per zone node.
SparseMatrix homogenisation(const ZoneMesh& zone, const ParticleCloud& particles, const Smoothing& smoothing);
/// Cheng Eq. 27, c = 0: psi_i at each particle's natural coordinates (Eq. 19).
/// Particles outside every zone element are not coupled (zero column).
SparseMatrix homogenisationDirac(const ZoneMesh& zone, const ParticleCloud& particles);
/// Cheng Eq. 27, c > 0 (Eq. 18): Gauss quadrature of W psi_i over the zone
/// elements within c of each particle.
SparseMatrix homogenisationCg(const ZoneMesh& zone, const ParticleCloud& particles, const CgKernel& kernel, double width);

/// The zone matrix M_ij = int_{Omega^C} psi_i psi_j dV (Cheng Eq. 32) from
/// fem_solver's (global i, global j, value) triplets, in zone-local indices.
SparseMatrix zoneMatrix(const ZoneMesh& zone, std::span<const double> triplets, const std::string& what);
/// The row-sum lumped form of M, diag(sum_j M_ij) = diag(int psi_i dV): the
/// penalty matrix of the published runs (shared/reference/cheng2022), which
/// ties each node to its own homogenised displacement only.
SparseMatrix rowSumLumped(const SparseMatrix& m);

/// The per-element form of the penalty operators (the published runs,
/// shared/reference/cheng2022): every element e holds its own homogenised
/// field, u^DE_(e,k) = sum_a Pi^e_ka u_a over the particles of e (Eq. 19) or
/// near e (Eq. 18 over e alone), each row normalised to one, and its own
/// gap u^DE_(e,k) - u^FE_k, penalised with the element's M^e (or its row
/// sums). Rows are the (element, corner) pairs some particle reaches;
/// `gather` picks each row's FE node. Elements without particles are not coupled.
struct ElementPenalty {
  SparseMatrix pi, gather, matrix;
};
ElementPenalty elementPenalty(const ZoneMesh& zone, const ParticleCloud& particles, const Smoothing& smoothing, bool lumped);

/// The penalty coupling of Cheng Eqs. 29-32 for fixed Pi, M and epsilon.
class PenaltyCoupling {
 public:
  /// Rows of pi and the matrix are the zone's nodes (gather empty: the
  /// identity), or the rows `gather` maps onto them (ElementPenalty).
  PenaltyCoupling(SparseMatrix pi, SparseMatrix zoneMatrix, double epsilon, SparseMatrix gather = {});
  struct Forces {
    Eigen::MatrixX3d uDe, uFe;         // per row: u^DE = Pi u_particles (Eq. 28), u^FE = G u_nodes
    Eigen::MatrixX3d onNodes;          // f_i = eps sum_j M_ij (u^DE_j - u^FE_j) (Eqs. 31, 38)
    Eigen::MatrixX3d onParticles;      // f_a = -sum_i Pi_ia f_i (Eqs. 32, 39)
    double energy = 0.0;               // eps/2 int |u^DE - u^FE|^2 dV (Eq. 29)
  };
  /// uParticles: one row per Pi column; uNodes: one row per zone node.
  void compute(const Eigen::MatrixX3d& uParticles, const Eigen::MatrixX3d& uNodes, Forces& out) const;
  const SparseMatrix& pi() const { return pi_; }
  const SparseMatrix& matrix() const { return m_; }
  double epsilon() const { return epsilon_; }
  /// Bounds on the highest frequency the penalty springs alone give the zone
  /// nodes and the particles (Gershgorin): omega^2 <= (row sum of |K|) / mass
  /// with K = eps [M, -M Pi; -Pi^T M, Pi^T M Pi], the stiffness of Eqs.
  /// 31-32. Masses as the solvers integrate them: FEM's lumped (1 - w)
  /// weighted nodal masses, w m for particles (Eqs. 25-26); a zero mass is
  /// skipped (nothing integrates it).
  struct Frequencies {
    double nodes = 0.0, particles = 0.0;
  };
  Frequencies maxFrequencies(const std::vector<double>& nodeMasses, const std::vector<double>& particleMasses) const;

 private:
  SparseMatrix pi_, m_, gather_;
  double epsilon_;
};

}  // namespace cosim::coupler
