// Stiffness-proportional (Rayleigh, C = beta K) damping of the one-point
// element: the viscous stress beta C : D. Checked against the single-degree-
// of-freedom oscillator it makes of a free cube's uniform dilatation (damping
// fraction beta omega / 2, energy decay 2 zeta omega), the dissipation record,
// rigid motion (no force), the stable step of Liu 2016 Eq. 65, and the
// frequency selectivity that makes it the damping for element-scale noise.
#include <gtest/gtest.h>

#include <cmath>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

std::unique_ptr<Model> dampedModel(Mesh mesh, double E, double nu, double rho, double beta) {
  FormulationOptions o;
  o.stiffnessDamping = beta;
  return std::make_unique<Model>(std::move(mesh), MaterialRegistry::instance().create("st-venant-kirchhoff", {E, nu, rho}),
                                 FormulationRegistry::instance().create("one-point"), o);
}

double mechanicalEnergy(const Energies& e) { return e.kinetic + e.strain + e.hourglass; }

TEST(FemStiffnessDamping, FreeCubeDilatationDecaysAsTheDampedOscillator) {
  // Unit cube, lumped mass rho / 8 per node; uniform dilatation u_a = eps s_a / 2
  // gives nodal forces -(3 lambda + 2 mu) / 2 u_a: omega^2 = 4 (3 lambda + 2 mu) / rho,
  // and C = beta K: zeta = beta omega / 2, mechanical energy ~ exp(-2 zeta omega t).
  const double E = 1e8, nu = 0.25, rho = 1000.0;
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  const double omega = std::sqrt(4.0 * (3 * lambda + 2 * mu) / rho);
  const double zeta = 0.02, beta = 2.0 * zeta / omega;
  auto model = dampedModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1}), E, nu, rho, beta);
  auto integrator = makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  const double rate = 1e-6;  // small: the St. Venant-Kirchhoff cube stays linear
  for (std::size_t n = 0; n < model->numNodes(); ++n)
    for (int i = 0; i < 3; ++i)
      state.v[3 * n + static_cast<std::size_t>(i)] = rate * (model->mesh().node(static_cast<Index>(n))[i] - 0.5);
  integrator->initialise(state);
  const double e0 = mechanicalEnergy(integrator->energies(state));
  const double period = 2 * M_PI / omega, dt = period / 400;
  while (state.time < 10 * period - 0.5 * dt) integrator->step(state, dt);
  const Energies e = integrator->energies(state);
  const double expected = e0 * std::exp(-2 * zeta * omega * state.time);
  std::printf("[stiffness damping, cube] omega %.6e rad/s, zeta %.3f: energy %.6e -> %.6e J after 10 periods "
              "(oscillator %.6e, %+.3f %%), dissipated %.6e J of %.6e lost\n",
              omega, zeta, e0, mechanicalEnergy(e), expected, 100 * (mechanicalEnergy(e) - expected) / expected,
              e.viscousDissipated, e0 - mechanicalEnergy(e));
  EXPECT_NEAR(mechanicalEnergy(e) / expected, 1.0, 0.01);
  EXPECT_NEAR(e.viscousDissipated / (e0 - mechanicalEnergy(e)), 1.0, 1e-3);
}

TEST(FemStiffnessDamping, RigidMotionGivesNoForce) {
  auto model = dampedModel(makeBoxMesh({0, 0, 0}, {2, 1, 1}, {2, 1, 1}), 1e8, 0.3, 1000.0, 1e-4);
  std::vector<double> v(model->numDofs()), f;
  const Vec3 w(0.3, -0.2, 0.5), v0(1.0, 2.0, -1.0);
  for (std::size_t n = 0; n < model->numNodes(); ++n) {
    const Vec3 vn = v0 + w.cross(model->mesh().node(static_cast<Index>(n)));
    for (int i = 0; i < 3; ++i) v[3 * n + static_cast<std::size_t>(i)] = vn[i];
  }
  ASSERT_TRUE(model->viscousForce(v, f));
  double largest = 0.0;
  for (double x : f) largest = std::max(largest, std::abs(x));
  EXPECT_LT(largest, 1e-9);  // 1e-4 s x 1e8 Pa x 1 /s would be 1e4 N per face
}

TEST(FemStiffnessDamping, UniaxialStretchRateCarriesTheViscousStress) {
  const double E = 1e8, nu = 0.3, rho = 1000.0, beta = 1e-4, rate = 2.0;
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  auto model = dampedModel(makeBoxMesh({0, 0, 0}, {1, 2, 3}, {1, 1, 1}), E, nu, rho, beta);
  std::vector<double> v(model->numDofs(), 0.0), f;
  for (std::size_t n = 0; n < model->numNodes(); ++n) v[3 * n] = rate * model->mesh().node(static_cast<Index>(n))[0];
  model->viscousForce(v, f);
  double fx = 0.0, fy = 0.0;  // on the faces x = 1 and y = 2
  for (std::size_t n = 0; n < model->numNodes(); ++n) {
    if (model->mesh().node(static_cast<Index>(n))[0] > 0.5) fx += f[3 * n];
    if (model->mesh().node(static_cast<Index>(n))[1] > 1.0) fy += f[3 * n + 1];
  }
  EXPECT_NEAR(fx, beta * (lambda + 2 * mu) * rate * 2 * 3, 1e-9 * fx);  // sigma_xx times the 2 x 3 face
  EXPECT_NEAR(fy, beta * lambda * rate * 1 * 3, 1e-9 * fy);             // sigma_yy times the 1 x 3 face
}

TEST(FemStiffnessDamping, StableStepFollowsLiuEq65) {
  const double beta = 2e-5;
  auto plain = dampedModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {4, 4, 4}), 1e8, 0.3, 1000.0, 0.0);
  auto damped = dampedModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {4, 4, 4}), 1e8, 0.3, 1000.0, beta);
  const double omega = 2.0 / plain->criticalTimeStep();
  const double xi = 0.5 * beta * omega + 30.0 / (2.0 * omega);  // with mass damping alpha = 30 1/s as well
  EXPECT_NEAR(damped->criticalTimeStep(30.0), 2.0 / omega * (std::sqrt(1 + xi * xi) - xi), 1e-12 * plain->criticalTimeStep());
  EXPECT_LT(damped->criticalTimeStep(), plain->criticalTimeStep());
}

TEST(FemStiffnessDamping, DampsTheElementScaleModeAndSparesTheSlowOne) {
  // A free-free bar of 20 elements: the slowest axial mode (half a cosine) and
  // the fastest (neighbouring stations opposite), momentum-free. The energy of
  // a mode decays as exp(-beta omega^2 t): with beta = 0.4 / omega_max, over 8
  // of the fastest periods the exponent is about 20 for the fast pattern and
  // (omega_1 / omega_max)^2 = (pi / 40)^2 of that, about 0.12, for the slow one.
  const double E = 1e8, rho = 1000.0, length = 2.0;
  auto probe = dampedModel(makeBoxMesh({0, 0, 0}, {length, 0.1, 0.1}, {20, 1, 1}), E, 0.0, rho, 0.0);
  const double omegaMax = 2.0 / probe->criticalTimeStep();
  const double beta = 0.4 / omegaMax;
  auto run = [&](bool fast) {
    auto model = dampedModel(makeBoxMesh({0, 0, 0}, {length, 0.1, 0.1}, {20, 1, 1}), E, 0.0, rho, beta);
    auto integrator = makeCentralDifference(*model, {});
    State state;
    state.resize(model->numDofs());
    for (std::size_t n = 0; n < model->numNodes(); ++n) {
      const double x = model->mesh().node(static_cast<Index>(n))[0];
      const long i = std::lround(x / (length / 20));
      state.v[3 * n] = 1e-3 * (fast ? (i % 2 ? 1.0 : -1.0) : std::cos(M_PI * x / length));
    }
    const auto& m = model->lumpedMass();  // remove the rigid translation, which nothing damps
    double p = 0.0, mass = 0.0;
    for (std::size_t n = 0; n < model->numNodes(); ++n) {
      p += m[n] * state.v[3 * n];
      mass += m[n];
    }
    for (std::size_t n = 0; n < model->numNodes(); ++n) state.v[3 * n] -= p / mass;
    integrator->initialise(state);
    const double e0 = mechanicalEnergy(integrator->energies(state));
    const double dt = 0.5 * model->criticalTimeStep(), t = 8 * 2 * M_PI / omegaMax;  // 8 fastest periods
    while (state.time < t) integrator->step(state, dt);
    return mechanicalEnergy(integrator->energies(state)) / e0;
  };
  const double slow = run(false), fast = run(true);
  std::printf("[stiffness damping, bar] beta omega_max = 0.4: energy left after 8 fastest periods: slowest mode %.4f, "
              "fastest %.3e\n", slow, fast);
  EXPECT_GT(slow, 0.8);
  EXPECT_LT(fast, 1e-6);
}

}  // namespace
}  // namespace cosim::fem
