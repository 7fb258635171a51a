// Arlequin volume coupling: the shared weight profile, the homogenisation
// operator Pi of Cheng 2022 Eq. 27 (c = 0 and CG-enriched), and the penalty
// forces of Eqs. 31-32 with their balance (Eq. 41).
#include <gtest/gtest.h>

#include <capnp/message.h>

#include <numbers>
#include <random>

#include "cosim/coupler/mapping/cg_kernel.hpp"
#include "cosim/coupler/mapping/homogenisation.hpp"
#include "cosim/fem/coupling/volume_zone.hpp"
#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/util/weight_profile.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

TEST(ArlequinWeight, HalfCosineAndLinearProfiles) {
  util::WeightProfile w{"half-cosine", 1, 8.0, 12.0};
  EXPECT_TRUE(w.problem().empty());
  EXPECT_EQ(w.along(7.0), 1.0);
  EXPECT_EQ(w.along(8.0), 1.0);
  EXPECT_EQ(w.along(12.0), 0.0);
  EXPECT_EQ(w.along(13.0), 0.0);
  EXPECT_NEAR(w.along(10.0), 0.5, 1e-15);
  EXPECT_NEAR(w.along(9.0), 0.5 * (1 + std::cos(std::numbers::pi / 4)), 1e-15);
  // Antisymmetric about the middle, so DEM and FEM trade weight evenly.
  for (double s = 8.0; s <= 12.0; s += 0.37) EXPECT_NEAR(w.along(s) + w.along(20.0 - s), 1.0, 1e-15);
  EXPECT_EQ(w(std::array<double, 3>{5.0, 10.0, -3.0}), w.along(10.0));  // reads the axis only
  util::WeightProfile lin{"linear", 0, 0.0, 2.0};
  EXPECT_NEAR(lin.along(0.5), 0.75, 1e-15);
  util::WeightProfile reversed{"linear", 0, 2.0, 0.0};  // DEM on the high side
  EXPECT_NEAR(reversed.along(0.5), 0.25, 1e-15);
  EXPECT_EQ(reversed.along(3.0), 1.0);
  EXPECT_NE(util::WeightProfile({"cosine", 0, 0, 1}).problem().find("unknown kind 'cosine'"), std::string::npos);
  EXPECT_NE(util::WeightProfile({"linear", 3, 0, 1}).problem().find("axis"), std::string::npos);
  EXPECT_NE(util::WeightProfile({"linear", 0, 1, 1}).problem().find("differ"), std::string::npos);
}

TEST(ArlequinWeight, PublishedRangeJumpsAtTheClosedZoneEnds) {
  // The published runs: 0.9 at the DEM end (start = 6), 0.1 at the FE end
  // (end = 2), 1 and 0 outside; nodes on the zone's faces, even a few ulps
  // off, take the zone's values.
  util::WeightProfile w{"half-cosine", 1, 6.0, 2.0, 0.1, 0.9};
  EXPECT_TRUE(w.problem().empty());
  EXPECT_NEAR(w.along(6.0), 0.9, 1e-15);
  EXPECT_NEAR(w.along(6.0 + 1e-12), 0.9, 1e-15);
  EXPECT_NEAR(w.along(-6.0 + 0.4 * 20), 0.1, 1e-15);  // 2.0000000000000004
  EXPECT_EQ(w.along(6.2), 1.0);
  EXPECT_EQ(w.along(1.6), 0.0);
  EXPECT_NEAR(w.along(4.0), 0.5, 1e-15);
  const double s = 0.05;  // w = 0.1 + 0.4 - 0.4 cos(pi s), s from the FE end
  EXPECT_NEAR(w.along(2.0 + 4.0 * s), 0.5 - 0.4 * std::cos(std::numbers::pi * s), 1e-15);
  EXPECT_NE(util::WeightProfile({"linear", 0, 0, 1, 0.9, 0.1}).problem().find("weight range"), std::string::npos);
  EXPECT_NE(util::WeightProfile({"linear", 0, 0, 1, -0.1, 1.0}).problem().find("weight range"), std::string::npos);
}

/// A zone exported by fem_solver's own VolumeZone, so the coupler reads what the solver sends.
struct Zone {
  fem::Mesh mesh;
  capnp::MallocMessageBuilder msg;
  ZoneMesh zone;
  std::span<const double> matrix, qpPositions, qpShapes;

  Zone(const fem::Vec3& lo, const fem::Vec3& hi, std::array<int, 3> div) : mesh(fem::makeBoxMesh(lo, hi, div)) {
    fem::VolumeZone z("overlap", mesh, lo - fem::Vec3::Constant(1e-9), hi + fem::Vec3::Constant(1e-9));
    auto arrays = msg.initRoot<proto::CouplingData>().initArrays(fem::VolumeZone::kArrays);
    const std::vector<double> zero(3 * mesh.numNodes(), 0.0), mass(mesh.numNodes(), 1.0);
    z.fill(arrays, 0, mesh, zero, zero, mass);
    auto get = [&](const char* name) {
      proto::NamedArray::Reader a;
      EXPECT_TRUE(wire::findArray(arrays.asReader(), std::string("overlap/") + name, a)) << name;
      return wire::view(a.getValues());
    };
    zone = ZoneMesh::fromArrays(get("nodes"), get("node_positions"), get("elements"), "test zone");
    matrix = get("matrix");
    qpPositions = get("qp_positions");
    qpShapes = get("qp_shapes");
  }
};

/// n x n x n particles per element on sub-cell centres of the box [lo, hi]
/// (element size h), equal masses or unequal ones.
ParticleCloud lattice(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double h, int n, bool equal = false) {
  ParticleCloud c;
  const double d = h / n;
  for (double x = lo[0] + d / 2; x < hi[0]; x += d)
    for (double y = lo[1] + d / 2; y < hi[1]; y += d)
      for (double z = lo[2] + d / 2; z < hi[2]; z += d) {
        c.positions.emplace_back(x, y, z);
        c.masses.push_back(equal ? 1.0 : 1.0 + 0.1 * std::sin(3 * x + 5 * y + 7 * z));
      }
  return c;
}

/// Nodal values Pi u of a field u(x) sampled at the particles.
Eigen::MatrixX3d homogenise(const SparseMatrix& pi, const ParticleCloud& c, const auto& field) {
  Eigen::MatrixX3d u(static_cast<Eigen::Index>(c.positions.size()), 3);
  for (std::size_t a = 0; a < c.positions.size(); ++a) u.row(static_cast<Eigen::Index>(a)) = field(c.positions[a]).transpose();
  return pi * u;
}

// The coupler's hex8 map agrees with fem_solver's shape functions: mapping
// the exported quadrature points back gives the exported shape values.
TEST(ArlequinPenalty, FrequencyBoundOfOneNodeAndOneParticle) {
  // K = eps m_z [1 -1; -1 1] between a node of mass M_n and a particle of mass
  // M_p: omega_max^2 = eps m_z (1/M_n + 1/M_p). The row-sum bound is 2 eps m_z
  // / M on each side: exact for equal masses, above the exact value otherwise.
  SparseMatrix pi(1, 1), m(1, 1);
  pi.insert(0, 0) = 1.0;
  m.insert(0, 0) = 0.3;
  const double eps = 2.0e6;
  const PenaltyCoupling penalty(pi, m, eps);
  auto f = penalty.maxFrequencies({4.0}, {4.0});
  EXPECT_NEAR(f.nodes, std::sqrt(eps * 0.3 * 2.0 / 4.0), 1e-9);
  EXPECT_NEAR(f.particles, f.nodes, 1e-9);
  f = penalty.maxFrequencies({4.0}, {1.0});
  const double exact = std::sqrt(eps * 0.3 * (1.0 / 4.0 + 1.0 / 1.0));
  EXPECT_GE(std::max(f.nodes, f.particles), exact);
  EXPECT_NEAR(f.particles, std::sqrt(eps * 0.3 * 2.0 / 1.0), 1e-9);
  EXPECT_EQ(penalty.maxFrequencies({0.0}, {1.0}).nodes, 0.0);  // a massless node is skipped
  EXPECT_THROW(penalty.maxFrequencies({1.0, 2.0}, {1.0}), std::runtime_error);
}

TEST(ArlequinPi, InverseMapMatchesFemShapes) {
  Zone z({0, 0, 0}, {0.8, 1.2, 0.8}, {2, 3, 2});
  double worst = 0.0;
  for (std::size_t p = 0; p < z.qpPositions.size() / 3; ++p) {
    const hex8::Corners X = z.zone.corners(p / 8);
    Eigen::Vector3d xi;
    ASSERT_TRUE(hex8::inverseMap(X, {z.qpPositions[3 * p], z.qpPositions[3 * p + 1], z.qpPositions[3 * p + 2]}, xi));
    const auto N = hex8::shape(xi);
    for (std::size_t a = 0; a < 8; ++a) worst = std::max(worst, std::abs(N[a] - z.qpShapes[8 * p + a]));
  }
  EXPECT_LT(worst, 1e-13);
}

struct PiCase {
  const char* kernel;
  double widthOverH;
};

class ArlequinPiForms : public ::testing::TestWithParam<PiCase> {
 protected:
  SparseMatrix build(const Zone& z, const ParticleCloud& c, double h) const {
    if (GetParam().widthOverH == 0.0) return homogenisationDirac(z.zone, c);
    auto kernel = CgKernelRegistry::create(GetParam().kernel, "CG kernel");
    return homogenisationCg(z.zone, c, *kernel, GetParam().widthOverH * h);
  }
};

// Uniform displacement -> the same nodal displacement at every node (rows
// sum to one); a linear field is reproduced at nodes whose support plus the
// CG width lies inside the particle lattice (the lattice is symmetric there).
TEST_P(ArlequinPiForms, UniformAndLinearFields) {
  const double h = 0.4;
  const double L = 6 * h;
  Zone z({0, 0, 0}, {L, L, L}, {6, 6, 6});
  // Unequal masses for the uniform field; Pi is a mass-weighted average, so
  // the linear field needs equal masses (a lattice of one material).
  const ParticleCloud c = lattice({0, 0, 0}, {L, L, L}, h, 2), equal = lattice({0, 0, 0}, {L, L, L}, h, 2, true);
  const SparseMatrix pi = build(z, c, h), piEqual = build(z, equal, h);
  const Eigen::Vector3d u0(1e-3, -2e-3, 0.5e-3);
  const Eigen::MatrixX3d uniform = homogenise(pi, c, [&](const Eigen::Vector3d&) { return u0; });
  double worstUniform = 0.0;
  for (Eigen::Index i = 0; i < uniform.rows(); ++i) worstUniform = std::max(worstUniform, (uniform.row(i).transpose() - u0).norm());
  EXPECT_LT(worstUniform, 1e-10 * u0.norm());

  Eigen::Matrix3d A;
  A << 1e-3, 2e-3, -1e-3, 0.5e-3, -3e-3, 1e-3, 2e-3, 0, 1.5e-3;
  const auto linear = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d { return A * x + u0; };
  const Eigen::MatrixX3d nodal = homogenise(piEqual, equal, linear);
  const double reach = h + GetParam().widthOverH * h;
  double worstLinear = 0.0;
  int interior = 0;
  for (std::size_t i = 0; i < z.zone.nodes.size(); ++i) {
    const Eigen::Vector3d& x = z.zone.positions[i];
    if ((x.array() < reach - 1e-9).any() || (x.array() > L - reach + 1e-9).any()) continue;
    ++interior;
    worstLinear = std::max(worstLinear, (nodal.row(static_cast<Eigen::Index>(i)).transpose() - linear(x)).norm());
  }
  ASSERT_GT(interior, 0);
  std::printf("[Pi %s c = %.1f h] %d interior nodes, max error uniform %.1e, linear %.1e (field ~%.1e)\n",
              GetParam().kernel, GetParam().widthOverH, interior, worstUniform, worstLinear, linear({h, h, h}).norm());
  EXPECT_LT(worstLinear, 1e-10 * linear({h, h, h}).norm());
}

INSTANTIATE_TEST_SUITE_P(Forms, ArlequinPiForms,
                         ::testing::Values(PiCase{"dirac", 0.0}, PiCase{"lucy", 0.5}, PiCase{"lucy", 1.0},
                                           PiCase{"gaussian", 1.0}),
                         [](const auto& p) {
                           return std::string(p.param.kernel) + "_" + std::to_string(int(p.param.widthOverH * 10));
                         });

// A node that no particle reaches makes Pi singular: refused, naming the node.
TEST(ArlequinPi, RefusesNodesWithoutParticles) {
  const double h = 0.4;
  Zone z({0, 0, 0}, {2 * h, 4 * h, 2 * h}, {2, 4, 2});
  const ParticleCloud half = lattice({0, 0, 0}, {2 * h, 2 * h, 2 * h}, h, 1);  // lower half only
  try {
    homogenisationDirac(z.zone, half);
    FAIL() << "a zone half without particles was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("zone node"), std::string::npos) << e.what();
  }
  // The CG form reaches further: with c = 2.5 h the lower half covers every node.
  auto lucy = CgKernelRegistry::create("lucy", "CG kernel");
  EXPECT_NO_THROW(homogenisationCg(z.zone, half, *lucy, 2.5 * h));
  EXPECT_THROW(homogenisationCg(z.zone, half, *lucy, 0.5 * h), std::runtime_error);
}

// Cheng Eq. 41: the forces on the nodes and on the particles cancel, to
// round-off, for any displacements; and they are the negative gradients of
// the penalty energy (Eq. 29), so the coupling is conservative.
TEST_P(ArlequinPiForms, PenaltyForcesBalanceAndDeriveFromTheEnergy) {
  const double h = 0.4;
  Zone z({0, 0, 0}, {2 * h, 4 * h, 2 * h}, {2, 4, 2});
  const ParticleCloud c = lattice({0, 0, 0}, {2 * h, 4 * h, 2 * h}, h, 2);
  const double eps = 1e10;
  PenaltyCoupling penalty(build(z, c, h), zoneMatrix(z.zone, z.matrix, "test"), eps);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1e-3, 1e-3);
  Eigen::MatrixX3d up(static_cast<Eigen::Index>(c.positions.size()), 3), un(static_cast<Eigen::Index>(z.zone.nodes.size()), 3);
  for (Eigen::Index i = 0; i < up.size(); ++i) up.data()[i] = U(rng);
  for (Eigen::Index i = 0; i < un.size(); ++i) un.data()[i] = U(rng);
  PenaltyCoupling::Forces f;
  penalty.compute(up, un, f);
  const Eigen::Vector3d net = f.onNodes.colwise().sum() + f.onParticles.colwise().sum();
  const double scale = f.onNodes.cwiseAbs().sum();
  std::printf("[Eq. 41 %s] |sum f_nodes + sum f_particles| = %.2e N of sum |f| = %.2e N\n", GetParam().kernel,
              net.norm(), scale);
  EXPECT_LT(net.norm(), 1e-13 * scale);
  EXPECT_GT(f.energy, 0.0);
  // Central differences of the energy against the forces on one particle and one node.
  const double du = 1e-7;
  for (Eigen::Index k : {Eigen::Index{0}, up.rows() / 2}) {
    Eigen::MatrixX3d plus = up, minus = up;
    plus(k, 1) += du;
    minus(k, 1) -= du;
    PenaltyCoupling::Forces fp, fm;
    penalty.compute(plus, un, fp);
    penalty.compute(minus, un, fm);
    EXPECT_NEAR(-(fp.energy - fm.energy) / (2 * du), f.onParticles(k, 1), 1e-6 * f.onParticles.cwiseAbs().maxCoeff());
  }
  Eigen::MatrixX3d plus = un, minus = un;
  plus(3, 2) += du;
  minus(3, 2) -= du;
  PenaltyCoupling::Forces fp, fm;
  penalty.compute(up, plus, fp);
  penalty.compute(up, minus, fm);
  EXPECT_NEAR(-(fp.energy - fm.energy) / (2 * du), f.onNodes(3, 2), 1e-6 * f.onNodes.cwiseAbs().maxCoeff());
}

// The per-element form of the published runs, one particle per element:
// each particle is tied to the 8 corners of its own element with the lumped
// element matrix V_e / 8, so f_a = -eps V_e / 8 sum_k (u_a - u_k); the FE
// nodes receive the same forces as from the zone form (Pi_ia = 1 / n_i,
// M_ii = n_i V_e / 8), the particles do not.
TEST(ArlequinPiElement, OneParticlePerElementTiesEachParticleToItsCorners) {
  const double h = 0.4, eps = 1e10, ve = h * h * h;
  Zone z({0, 0, 0}, {0.8, 1.2, 0.8}, {2, 3, 2});
  const ParticleCloud c = lattice({0, 0, 0}, {0.8, 1.2, 0.8}, h, 1, true);
  const ElementPenalty e = elementPenalty(z.zone, c, Smoothing{}, true);
  ASSERT_EQ(e.pi.rows(), 8 * 12);
  EXPECT_NEAR((e.pi * Eigen::VectorXd::Ones(e.pi.cols())).maxCoeff(), 1.0, 1e-15);
  EXPECT_NEAR((e.matrix * Eigen::VectorXd::Ones(e.matrix.cols())).maxCoeff(), ve / 8, 1e-15);
  EXPECT_NEAR((e.matrix * Eigen::VectorXd::Ones(e.matrix.cols())).minCoeff(), ve / 8, 1e-15);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1e-3, 1e-3);
  Eigen::MatrixX3d up(static_cast<Eigen::Index>(c.positions.size()), 3), un(static_cast<Eigen::Index>(z.zone.nodes.size()), 3);
  for (Eigen::Index k = 0; k < up.size(); ++k) up.data()[k] = u(rng);
  for (Eigen::Index k = 0; k < un.size(); ++k) un.data()[k] = u(rng);
  PenaltyCoupling::Forces fe, fz;
  PenaltyCoupling(e.pi, e.matrix, eps, e.gather).compute(up, un, fe);
  const Eigen::Vector3d balance = fe.onNodes.colwise().sum() + fe.onParticles.colwise().sum();
  EXPECT_LT(balance.cwiseAbs().maxCoeff(), 1e-12 * fe.onNodes.cwiseAbs().maxCoeff());
  for (std::size_t a = 0; a < c.positions.size(); ++a) {
    // The element holding particle a: its centre is the particle.
    std::size_t el = 0;
    for (; el < z.zone.elements.size(); ++el) {
      Eigen::Vector3d mid = Eigen::Vector3d::Zero();
      for (const auto& x : z.zone.corners(el)) mid += x / 8;
      if ((mid - c.positions[a]).norm() < 1e-12) break;
    }
    ASSERT_LT(el, z.zone.elements.size());
    Eigen::RowVector3d expect = Eigen::RowVector3d::Zero();
    for (std::uint32_t k : z.zone.elements[el]) expect -= eps * ve / 8 * (up.row(static_cast<Eigen::Index>(a)) - un.row(k));
    EXPECT_LT((fe.onParticles.row(static_cast<Eigen::Index>(a)) - expect).cwiseAbs().maxCoeff(), 1e-9 * expect.norm());
  }
  PenaltyCoupling(homogenisationDirac(z.zone, c), rowSumLumped(zoneMatrix(z.zone, z.matrix, "test")), eps).compute(up, un, fz);
  EXPECT_LT((fz.onNodes - fe.onNodes).cwiseAbs().maxCoeff(), 1e-9 * fe.onNodes.cwiseAbs().maxCoeff());
  EXPECT_GT((fz.onParticles - fe.onParticles).cwiseAbs().maxCoeff(), 1e-3 * fe.onParticles.cwiseAbs().maxCoeff());
}

// Several particles per element, CG per element with the consistent element
// matrices: rows reproduce a uniform field, forces balance and derive from
// the energy, and the frequency bound covers the gathered stiffness.
TEST(ArlequinPiElement, CgRowsAreNormalisedAndForcesDeriveFromTheEnergy) {
  const double h = 0.4, eps = 1e8;
  Zone z({0, 0, 0}, {0.8, 1.2, 0.8}, {2, 3, 2});
  const ParticleCloud c = lattice({0, 0, 0}, {0.8, 1.2, 0.8}, h, 2);
  const auto lucy = CgKernelRegistry::create("lucy", "test");
  const ElementPenalty e = elementPenalty(z.zone, c, Smoothing{lucy.get(), 0.5 * h}, false);
  const Eigen::MatrixX3d uniform = homogenise(e.pi, c, [](const Eigen::Vector3d&) { return Eigen::Vector3d(1, -2, 3); });
  EXPECT_LT((uniform.rowwise() - Eigen::RowVector3d(1, -2, 3)).cwiseAbs().maxCoeff(), 1e-12);
  // The element matrices sum to the zone's.
  const SparseMatrix assembled = SparseMatrix(e.gather.transpose()) * e.matrix * e.gather;
  EXPECT_LT((Eigen::MatrixXd(assembled) - Eigen::MatrixXd(zoneMatrix(z.zone, z.matrix, "test"))).cwiseAbs().maxCoeff(), 1e-14);
  const PenaltyCoupling penalty(e.pi, e.matrix, eps, e.gather);
  Eigen::MatrixX3d up = Eigen::MatrixX3d::Zero(static_cast<Eigen::Index>(c.positions.size()), 3);
  Eigen::MatrixX3d un = Eigen::MatrixX3d::Zero(static_cast<Eigen::Index>(z.zone.nodes.size()), 3);
  for (Eigen::Index k = 0; k < up.rows(); ++k) up(k, 1) = 1e-3 * std::sin(1.0 + k);
  for (Eigen::Index k = 0; k < un.rows(); ++k) un(k, 1) = 1e-3 * std::cos(2.0 * k);
  PenaltyCoupling::Forces f, fp, fm;
  penalty.compute(up, un, f);
  const Eigen::Vector3d balance = f.onNodes.colwise().sum() + f.onParticles.colwise().sum();
  EXPECT_LT(balance.cwiseAbs().maxCoeff(), 1e-12 * f.onNodes.cwiseAbs().maxCoeff());
  const double du = 1e-7;
  up(5, 1) += du;
  penalty.compute(up, un, fp);
  up(5, 1) -= 2 * du;
  penalty.compute(up, un, fm);
  EXPECT_NEAR(-(fp.energy - fm.energy) / (2 * du), f.onParticles(5, 1), 1e-6 * f.onParticles.cwiseAbs().maxCoeff());
  const auto bound = penalty.maxFrequencies(std::vector<double>(z.zone.nodes.size(), 1.0), std::vector<double>(c.positions.size(), 1.0));
  EXPECT_GT(bound.nodes, 0.0);
  EXPECT_GT(bound.particles, 0.0);
  EXPECT_THROW(elementPenalty(z.zone, ParticleCloud{{Eigen::Vector3d(5, 5, 5)}, {1.0}}, Smoothing{}, true), std::runtime_error);
}

}  // namespace
}  // namespace cosim::coupler
