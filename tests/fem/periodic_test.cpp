// Periodic node-pair constraints (master-slave elimination in the dof map):
// a periodic block with the jumps of a macroscopic displacement gradient H
// must take the homogeneous solution u = H X (static Newton, distorted
// interior); explicit and Newmark runs keep u_slave = u_master + jump(t) to
// round-off and conserve the lumped mass; the energy balance includes the
// work of the constraint forces.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

const Vec3 kSize(2.0, 1.5, 1.0);

/// Ties opposite faces of the box in all three directions with jumps H L_k e_k.
void tieBox(Model& model, const Mat3& H, Prescribed::Kind kind, double ramp) {
  const Mesh& mesh = model.mesh();
  const char* faces[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
  for (int k = 0; k < 3; ++k) {
    Vec3 offset = Vec3::Zero();
    offset[k] = kSize[k];
    model.tie(matchPeriodicNodes(mesh, mesh.nodeSet(faces[k][0]), mesh.nodeSet(faces[k][1]), offset, 1e-9), H * offset,
              kind, ramp);
  }
}

/// The node at the origin: pinned to remove the translation.
Index originNode(const Mesh& mesh) {
  const auto nodes = mesh.nodesInBox(Vec3::Constant(-1e-9), Vec3::Constant(1e-9));
  EXPECT_EQ(nodes.size(), 1u);
  return nodes.at(0);
}

Mesh distortedBox(unsigned seed) {
  Mesh mesh = makeBoxMesh(Vec3::Zero(), kSize, {4, 3, 3});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> shift(-0.08, 0.08);
  for (std::size_t n = 0; n < mesh.numNodes(); ++n) {
    const Vec3 x = mesh.node(static_cast<Index>(n));
    bool interior = true;
    for (int k = 0; k < 3; ++k) interior = interior && x[k] > 1e-9 && x[k] < kSize[k] - 1e-9;
    if (interior)
      for (int k = 0; k < 3; ++k) mesh.X[3 * n + static_cast<std::size_t>(k)] += shift(rng);
  }
  return mesh;
}

Mat3 shearGradient() {
  Mat3 H = Mat3::Zero();
  H(0, 2) = 0.02;   // simple shear xz
  H(1, 0) = -0.01;  // and a general part
  H(2, 2) = 0.005;
  return H;
}

class FemPeriodicStatic : public ::testing::TestWithParam<std::string> {};

TEST_P(FemPeriodicStatic, ShearedBlockIsHomogeneous) {
  auto model = test::makeModel(distortedBox(3), GetParam(), 1e8, 0.3, 1000.0);
  const Mat3 H = shearGradient();
  tieBox(*model, H, Prescribed::Kind::displacement, 0.0);
  const Index o = originNode(model->mesh());
  for (int i = 0; i < 3; ++i) model->prescribe(o, i, Prescribed::Kind::displacement, 0.0);
  State state;
  state.resize(model->numDofs());
  state.time = 1.0;
  const NewtonReport r = solveStatic(*model, state, NewtonOptions{});
  double err = 0.0, scale = 0.0;
  for (std::size_t n = 0; n < model->numNodes(); ++n) {
    const Vec3 exact = H * model->mesh().node(static_cast<Index>(n));
    const Vec3 u(state.u[3 * n], state.u[3 * n + 1], state.u[3 * n + 2]);
    err = std::max(err, (u - exact).cwiseAbs().maxCoeff());
    scale = std::max(scale, exact.cwiseAbs().maxCoeff());
  }
  std::printf("[periodic static %s] %zu slave dofs, %d free, Newton %d iterations, max |u - H X| / max |H X| = %.3e\n",
              GetParam().c_str(), model->slaves().size(), model->numFree(), r.iterations, err / scale);
  // 4 x 3 x 3 cells: 36 independent nodes, one pinned.
  EXPECT_EQ(model->numFree(), 3 * 35);
  EXPECT_LT(err / scale, 1e-8);
}

INSTANTIATE_TEST_SUITE_P(Formulations, FemPeriodicStatic, ::testing::Values("full", "one-point"));

/// max |u_s - u_m - jump(t)| over all slave dofs.
double constraintError(const Model& model, const State& state) {
  double e = 0.0;
  for (const SlaveDof& s : model.slaves())
    e = std::max(e, std::abs(state.u[s.dof] - state.u[s.master] - s.jump.displacement(state.time)));
  return e;
}

double maxAbs(const std::vector<double>& x) {
  double m = 0.0;
  for (double v : x) m = std::max(m, std::abs(v));
  return m;
}

struct DynamicsRun {
  double constraint, umax, balance;
};

DynamicsRun runPeriodicDynamics(const std::string& integratorName, int steps) {
  auto model = test::makeModel(distortedBox(5), "full", 1e8, 0.3, 1000.0);
  // Ramp the shear over the run: the tied faces drive waves through the block.
  tieBox(*model, shearGradient(), Prescribed::Kind::displacement, 0.02);
  const Index o = originNode(model->mesh());
  for (int i = 0; i < 3; ++i) model->prescribe(o, i, Prescribed::Kind::displacement, 0.0);
  // Mass conservation: slave masses move onto masters, none is lost.
  const std::vector<double> m = model->constrainedLumpedMass();
  double total = 0.0, constrained = 0.0;
  for (double x : model->lumpedMass()) total += 3.0 * x;
  for (double x : m) constrained += x;
  EXPECT_NEAR(constrained, total, 1e-13 * total);
  for (const SlaveDof& s : model->slaves()) EXPECT_EQ(m[s.dof], 0.0);
  std::unique_ptr<Integrator> integrator = integratorName == "newmark" ? makeNewmark(*model, NewmarkOptions{})
                                                                        : makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  integrator->initialise(state);
  const double dt = integratorName == "newmark" ? 2e-4 : 0.9 * integrator->criticalDt();
  for (int k = 0; k < steps; ++k) integrator->step(state, dt);
  const Energies e = integrator->energies(state);
  std::printf("[periodic %s] mass %.12e (constrained) vs %.12e; %d steps to t = %.4e s; kinetic %.4e strain %.4e "
              "work %.4e J\n",
              integratorName.c_str(), constrained, total, steps, state.time, e.kinetic, e.strain, e.externalWork);
  return {constraintError(*model, state), maxAbs(state.u),
          std::abs(e.kinetic + e.strain - e.externalWork) / e.externalWork};
}

TEST(FemPeriodic, ExplicitKeepsTheConstraintExactly) {
  const DynamicsRun r = runPeriodicDynamics("central-difference", 400);
  std::printf("[periodic explicit] max constraint error %.3e m (max |u| %.3e m), energy balance %.3e\n", r.constraint,
              r.umax, r.balance);
  EXPECT_GT(r.umax, 1e-4);
  EXPECT_LE(r.constraint, 1e-15 * r.umax);
  EXPECT_LT(r.balance, 1e-2);
}

TEST(FemPeriodic, NewmarkKeepsTheConstraintExactly) {
  // The energy balance is only printed: the trapezoidal rule rings at dofs
  // whose velocity is switched on at once (the ramp start), independently of
  // the ties.
  const DynamicsRun r = runPeriodicDynamics("newmark", 40);
  std::printf("[periodic newmark] max constraint error %.3e m (max |u| %.3e m), energy balance %.3e\n", r.constraint,
              r.umax, r.balance);
  EXPECT_GT(r.umax, 1e-4);
  EXPECT_LE(r.constraint, 1e-15 * r.umax);
}

TEST(FemPeriodic, UnmatchedNodeIsNamed) {
  const Mesh mesh = makeBoxMesh(Vec3::Zero(), kSize, {2, 2, 2});
  try {
    matchPeriodicNodes(mesh, mesh.nodeSet("xmin"), mesh.nodeSet("xmax"), Vec3(1.9, 0, 0), 1e-9);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("periodic node"), std::string::npos) << e.what();
  }
}

TEST(FemPeriodic, InconsistentLoopIsRefused) {
  auto model = test::makeModel(makeBoxMesh(Vec3::Zero(), kSize, {2, 1, 1}), "full", 1e8, 0.3, 1000.0);
  const Mesh& mesh = model->mesh();
  const auto pairs = matchPeriodicNodes(mesh, mesh.nodeSet("xmin"), mesh.nodeSet("xmax"), Vec3(2, 0, 0), 1e-9);
  model->tie(pairs, Vec3(0.1, 0, 0));
  std::vector<std::pair<Index, Index>> back;
  for (const auto& [s, m] : pairs) back.emplace_back(m, s);
  try {
    model->tie(back, Vec3(0.1, 0, 0));  // u_min = u_max + 0.1 contradicts u_max = u_min + 0.1
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("net jump"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::fem
