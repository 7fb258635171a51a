// The zone side of the Arlequin coupling: hex8 geometry, the zone mesh and
// matrix as fem_solver exports them, and the penalty forces (Cheng 2022
// Eqs. 29-32, 41).
#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cosim/coupler/mapping/homogenisation.hpp"
#include <Eigen/LU>

namespace cosim::coupler {

namespace hex8 {
namespace {
constexpr double kNodeXi[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                  {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
}

std::array<double, 8> shape(const Eigen::Vector3d& xi) {
  std::array<double, 8> N{};
  for (std::size_t a = 0; a < 8; ++a)
    N[a] = 0.125 * (1 + kNodeXi[a][0] * xi[0]) * (1 + kNodeXi[a][1] * xi[1]) * (1 + kNodeXi[a][2] * xi[2]);
  return N;
}

Eigen::Vector3d map(const Corners& X, const Eigen::Vector3d& xi, Eigen::Matrix3d* jacobian) {
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  if (jacobian) jacobian->setZero();
  for (std::size_t a = 0; a < 8; ++a) {
    const double s = kNodeXi[a][0], t = kNodeXi[a][1], u = kNodeXi[a][2];
    const double fs = 1 + s * xi[0], ft = 1 + t * xi[1], fu = 1 + u * xi[2];
    x += 0.125 * fs * ft * fu * X[a];
    if (jacobian) {
      jacobian->col(0) += 0.125 * s * ft * fu * X[a];
      jacobian->col(1) += 0.125 * t * fs * fu * X[a];
      jacobian->col(2) += 0.125 * u * fs * ft * X[a];
    }
  }
  return x;
}

bool inverseMap(const Corners& X, const Eigen::Vector3d& x, Eigen::Vector3d& xi) {
  // Newton on x(xi) = x from the centre; the trilinear map of a brick is
  // affine, so one step suffices there, distorted elements need a few.
  const double size = (X[6] - X[0]).norm();
  xi.setZero();
  for (int it = 0; it < 30; ++it) {
    Eigen::Matrix3d J;
    const Eigen::Vector3d r = map(X, xi, &J) - x;
    if (r.norm() <= 1e-13 * size) return true;
    const double det = J.determinant();
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) return false;
    xi -= J.inverse() * r;
    if (xi.cwiseAbs().maxCoeff() > 10.0) return false;  // far outside: not this element
  }
  return false;
}
}  // namespace hex8

namespace {
std::uint32_t nodeId(double v, const std::string& what, const char* array) {
  if (!(v >= 0.0) || v != std::floor(v) || v > 4294967295.0)
    throw std::runtime_error(what + ": " + array + " holds " + std::to_string(v) + ", not a node id");
  return static_cast<std::uint32_t>(v);
}
}  // namespace

ZoneMesh ZoneMesh::fromArrays(std::span<const double> nodes, std::span<const double> positions,
                              std::span<const double> elements, const std::string& what) {
  ZoneMesh z;
  if (nodes.empty()) throw std::runtime_error(what + ": the zone has no nodes");
  if (positions.size() != 3 * nodes.size())
    throw std::runtime_error(what + ": node_positions holds " + std::to_string(positions.size()) + " values for " +
                             std::to_string(nodes.size()) + " nodes (need 3 each)");
  if (elements.empty() || elements.size() % 8 != 0)
    throw std::runtime_error(what + ": elements holds " + std::to_string(elements.size()) +
                             " values (need 8 node ids per element, at least one element)");
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    z.nodes.push_back(nodeId(nodes[k], what, "nodes"));
    if (k > 0 && z.nodes[k] <= z.nodes[k - 1]) throw std::runtime_error(what + ": nodes are not in ascending order");
    const Eigen::Vector3d x(positions[3 * k], positions[3 * k + 1], positions[3 * k + 2]);
    if (!x.allFinite()) throw std::runtime_error(what + ": node " + std::to_string(z.nodes[k]) + " has a non-finite position");
    z.positions.push_back(x);
  }
  for (std::size_t e = 0; e < elements.size() / 8; ++e) {
    std::array<std::uint32_t, 8> local{};
    for (std::size_t a = 0; a < 8; ++a) {
      const std::uint32_t id = nodeId(elements[8 * e + a], what, "elements");
      const long k = z.localIndex(id);
      if (k < 0)
        throw std::runtime_error(what + ": element " + std::to_string(e) + " names node " + std::to_string(id) +
                                 ", which is not a zone node");
      local[a] = static_cast<std::uint32_t>(k);
    }
    z.elements.push_back(local);
  }
  return z;
}

hex8::Corners ZoneMesh::corners(std::size_t e) const {
  hex8::Corners X;
  for (std::size_t a = 0; a < 8; ++a) X[a] = positions[elements[e][a]];
  return X;
}

long ZoneMesh::localIndex(std::uint32_t node) const {
  const auto it = std::lower_bound(nodes.begin(), nodes.end(), node);
  return it != nodes.end() && *it == node ? static_cast<long>(it - nodes.begin()) : -1;
}

Eigen::Vector3d ZoneMesh::lower() const {
  Eigen::Vector3d lo = positions.front();
  for (const auto& x : positions) lo = lo.cwiseMin(x);
  return lo;
}

Eigen::Vector3d ZoneMesh::upper() const {
  Eigen::Vector3d hi = positions.front();
  for (const auto& x : positions) hi = hi.cwiseMax(x);
  return hi;
}

SparseMatrix zoneMatrix(const ZoneMesh& zone, std::span<const double> triplets, const std::string& what) {
  if (triplets.empty() || triplets.size() % 3 != 0)
    throw std::runtime_error(what + ": matrix holds " + std::to_string(triplets.size()) +
                             " values (need (i, j, value) triplets)");
  std::vector<Eigen::Triplet<double>> t;
  for (std::size_t k = 0; k < triplets.size(); k += 3) {
    const long i = zone.localIndex(nodeId(triplets[k], what, "matrix"));
    const long j = zone.localIndex(nodeId(triplets[k + 1], what, "matrix"));
    if (i < 0 || j < 0) throw std::runtime_error(what + ": matrix entry " + std::to_string(k / 3) + " names a node outside the zone");
    if (!std::isfinite(triplets[k + 2])) throw std::runtime_error(what + ": matrix entry " + std::to_string(k / 3) + " is not finite");
    t.emplace_back(static_cast<int>(i), static_cast<int>(j), triplets[k + 2]);
  }
  const auto n = static_cast<Eigen::Index>(zone.nodes.size());
  SparseMatrix m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

SparseMatrix rowSumLumped(const SparseMatrix& m) {
  const Eigen::VectorXd rows = m * Eigen::VectorXd::Ones(m.cols());
  SparseMatrix d(m.rows(), m.cols());
  d.reserve(Eigen::VectorXi::Constant(m.rows(), 1));
  for (Eigen::Index i = 0; i < m.rows(); ++i) d.insert(i, i) = rows(i);
  d.makeCompressed();
  return d;
}

PenaltyCoupling::PenaltyCoupling(SparseMatrix pi, SparseMatrix zoneMatrix, double epsilon, SparseMatrix gather)
    : pi_(std::move(pi)), m_(std::move(zoneMatrix)), gather_(std::move(gather)), epsilon_(epsilon) {
  if (gather_.size() == 0) {
    gather_.resize(pi_.rows(), pi_.rows());
    gather_.setIdentity();
  }
  if (gather_.rows() != pi_.rows())
    throw std::runtime_error("penalty coupling: Pi has " + std::to_string(pi_.rows()) + " rows but the gather map " +
                             std::to_string(gather_.rows()));
  if (pi_.rows() != m_.rows() || m_.rows() != m_.cols())
    throw std::runtime_error("penalty coupling: Pi has " + std::to_string(pi_.rows()) + " rows but the zone matrix is " +
                             std::to_string(m_.rows()) + " x " + std::to_string(m_.cols()));
}

void PenaltyCoupling::compute(const Eigen::MatrixX3d& uParticles, const Eigen::MatrixX3d& uNodes, Forces& out) const {
  if (uParticles.rows() != pi_.cols() || uNodes.rows() != gather_.cols())
    throw std::runtime_error("penalty coupling: " + std::to_string(uParticles.rows()) + " particle and " +
                             std::to_string(uNodes.rows()) + " node values for a " + std::to_string(pi_.rows()) +
                             " x " + std::to_string(pi_.cols()) + " homogenisation operator on " +
                             std::to_string(gather_.cols()) + " nodes");
  out.uDe = pi_ * uParticles;                        // Cheng Eq. 27/28
  out.uFe = gather_ * uNodes;
  const Eigen::MatrixX3d gap = out.uDe - out.uFe;
  const Eigen::MatrixX3d Mgap = m_ * gap;
  const Eigen::MatrixX3d onRows = epsilon_ * Mgap;   // Eqs. 31, 38: int psi_i b^C dV
  out.onNodes = SparseMatrix(gather_.transpose()) * onRows;
  out.onParticles = -(pi_.transpose() * onRows);     // Eqs. 32, 39
  out.energy = 0.5 * epsilon_ * (gap.array() * Mgap.array()).sum();  // Eq. 29 as an energy
}

PenaltyCoupling::Frequencies PenaltyCoupling::maxFrequencies(const std::vector<double>& nodeMasses,
                                                            const std::vector<double>& particleMasses) const {
  if (nodeMasses.size() != static_cast<std::size_t>(gather_.cols()) ||
      particleMasses.size() != static_cast<std::size_t>(pi_.cols()))
    throw std::runtime_error("penalty coupling: " + std::to_string(nodeMasses.size()) + " node and " +
                             std::to_string(particleMasses.size()) + " particle masses for a " +
                             std::to_string(pi_.rows()) + " x " + std::to_string(pi_.cols()) + " operator");
  // K = eps [G^T M G, -G^T M Pi; -Pi^T M G, Pi^T M Pi] (G = I for the zone form).
  const SparseMatrix gT = gather_.transpose();
  const SparseMatrix mG = m_ * gather_, mPi = m_ * pi_;
  const SparseMatrix gMG = gT * mG, gMPi = gT * mPi;
  const SparseMatrix piMPi = SparseMatrix(pi_.transpose()) * mPi;
  std::vector<double> nodeRow(nodeMasses.size(), 0.0), particleRow(particleMasses.size(), 0.0);
  for (Eigen::Index i = 0; i < gMG.outerSize(); ++i) {
    for (SparseMatrix::InnerIterator it(gMG, i); it; ++it) nodeRow[static_cast<std::size_t>(i)] += std::abs(it.value());
    for (SparseMatrix::InnerIterator it(gMPi, i); it; ++it) {
      nodeRow[static_cast<std::size_t>(i)] += std::abs(it.value());
      particleRow[static_cast<std::size_t>(it.col())] += std::abs(it.value());
    }
  }
  for (Eigen::Index a = 0; a < piMPi.outerSize(); ++a)
    for (SparseMatrix::InnerIterator it(piMPi, a); it; ++it) particleRow[static_cast<std::size_t>(a)] += std::abs(it.value());
  const auto bound = [this](const std::vector<double>& rows, const std::vector<double>& masses) {
    double w2 = 0.0;
    for (std::size_t k = 0; k < rows.size(); ++k)
      if (masses[k] > 0.0) w2 = std::max(w2, epsilon_ * rows[k] / masses[k]);
    return std::sqrt(w2);
  };
  return {bound(nodeRow, nodeMasses), bound(particleRow, particleMasses)};
}

}  // namespace cosim::coupler
