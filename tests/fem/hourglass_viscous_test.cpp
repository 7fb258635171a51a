// Viscous hourglass control of the one-point element (Flanagan & Belytschko
// 1981): a pure hourglass velocity mode decays at the rate 8 c / m and the
// reported dissipation equals the kinetic energy lost; rigid motion and
// uniform strain rate give no hourglass force; explicit bar wave and
// cantilever stay close to the stiffness-controlled results.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

std::unique_ptr<Model> viscousModel(Mesh mesh, double E, double nu, double rho, double kappa) {
  FormulationOptions o;
  o.hourglassType = FormulationOptions::Hourglass::viscous;
  o.hourglassCoefficient = kappa;
  return std::make_unique<Model>(std::move(mesh), MaterialRegistry::instance().create("st-venant-kirchhoff", {E, nu, rho}),
                                 FormulationRegistry::instance().create("one-point"), o);
}

TEST(FemHourglassViscous, PureModeDecaysAndDissipationMatchesKineticLoss) {
  const double E = 1e8, nu = 0.3, rho = 1000.0, kappa = 0.1, v0 = 1e-3;
  auto model = viscousModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1}), E, nu, rho, kappa);
  auto integrator = makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  // v_x = v0 xi eta: the h_3 = xi eta base vector (orthogonal to linear fields).
  for (std::size_t n = 0; n < model->numNodes(); ++n) {
    const Vec3 x = model->mesh().node(static_cast<Index>(n));
    state.v[3 * n] = v0 * (2 * x[0] - 1) * (2 * x[1] - 1);
  }
  integrator->initialise(state);
  const double ke0 = integrator->energies(state).kinetic;
  // Decay rate of the mode: lambda = 8 c / m, c = kappa rho c_d V^(2/3) / 4, m = rho V / 8 (|h|^2 = 8).
  const double cd = std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  const double lambda = 8.0 * (kappa * rho * cd / 4.0) / (rho / 8.0);
  const double dt = 1e-3 / lambda;
  while (state.time < 0.35 / lambda) integrator->step(state, dt);
  const Energies e = integrator->energies(state);
  const double lost = ke0 - e.kinetic;
  const double rateMeasured = -0.5 * std::log(e.kinetic / ke0) / state.time;
  std::printf("[hourglass viscous mode] KE %.6e -> %.6e J, dissipated %.9e J, KE lost %.9e J, relative difference "
              "%.3e; decay rate %.6e 1/s (8 c / m = %.6e); strain %.3e J\n",
              ke0, e.kinetic, e.viscousDissipated, lost, std::abs(e.viscousDissipated - lost) / lost, rateMeasured,
              lambda, e.strain);
  EXPECT_LT(e.kinetic, 0.6 * ke0);
  EXPECT_LT(std::abs(e.viscousDissipated - lost) / lost, 1e-6);
  EXPECT_LT(std::abs(rateMeasured - lambda) / lambda, 1e-3);
  EXPECT_LT(e.strain, 1e-12 * ke0);  // the mean gradient does not see the mode
}

TEST(FemHourglassViscous, LinearVelocityFieldsGiveNoForce) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {1, 1, 1}, {3, 3, 3});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> shift(-0.05, 0.05), r(-1.0, 1.0);
  for (double& x : mesh.X) x += shift(rng);
  auto model = viscousModel(std::move(mesh), 1e8, 0.3, 1000.0, 0.05);
  const std::size_t nn = model->numNodes();
  Mat3 L, W;
  for (int i = 0; i < 9; ++i) L.data()[i] = r(rng);
  W = 0.5 * (L - L.transpose());  // spin: rigid rotation rate
  const Vec3 vt(r(rng), r(rng), r(rng));
  std::vector<double> rigid(3 * nn), strainRate(3 * nn), mode(3 * nn), f;
  for (std::size_t n = 0; n < nn; ++n) {
    const Vec3 X = model->mesh().node(static_cast<Index>(n));
    const Vec3 a = vt + W * X, b = L * X;
    for (int i = 0; i < 3; ++i) {
      rigid[3 * n + static_cast<std::size_t>(i)] = a[i];
      strainRate[3 * n + static_cast<std::size_t>(i)] = b[i];
      mode[3 * n + static_cast<std::size_t>(i)] = r(rng);  // random: mostly non-linear
    }
  }
  auto maxForce = [&](const std::vector<double>& v) {
    EXPECT_TRUE(model->viscousForce(v, f));
    double m = 0.0;
    for (double x : f) m = std::max(m, std::abs(x));
    return m;
  };
  const double ref = maxForce(mode), fr = maxForce(rigid), fs = maxForce(strainRate);
  std::printf("[hourglass viscous linear fields] max |f| rigid %.3e, uniform strain rate %.3e, random velocity %.3e N\n",
              fr, fs, ref);
  EXPECT_GT(ref, 0.0);
  EXPECT_LT(fr, 1e-12 * ref);
  EXPECT_LT(fs, 1e-12 * ref);
}

struct WaveResult {
  double arrival = 0.0;
  std::vector<double> history;
  Energies energies;
};

WaveResult barWave(bool viscous) {
  const double E = 1e8, rho = 1000.0, L = 4.0, h = 0.02, sigma = 1e4;
  const int n = static_cast<int>(L / h + 0.5);
  Mesh mesh = makeBoxMesh({0, 0, 0}, {L, 2 * h, 2 * h}, {n, 2, 2});
  auto model = viscous ? viscousModel(std::move(mesh), E, 0.25, rho, 0.05)
                       : test::makeModel(std::move(mesh), "one-point", E, 0.25, rho);
  model->addTraction(model->mesh().faceSet("xmin"), Vec3(sigma, 0, 0));
  auto integrator = makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  integrator->initialise(state);
  const double dt = 0.9 * integrator->criticalDt();
  const std::vector<Index> probe = model->mesh().nodesInBox({L / 2, -1, -1}, {L / 2, 1, 1}, 1e-9);
  WaveResult r;
  const double c = std::sqrt(E / rho);
  const double vRef = sigma / (rho * c);
  double vPrev = 0.0, tPrev = 0.0;
  r.arrival = -1.0;
  while (state.time < 0.7 * L / c) {
    integrator->step(state, dt);
    double v = 0.0;
    for (Index p : probe) v += state.v[3 * p] / static_cast<double>(probe.size());
    if (r.arrival < 0 && v >= 0.5 * vRef) r.arrival = tPrev + (0.5 * vRef - vPrev) / (v - vPrev) * (state.time - tPrev);
    r.history.push_back(v / vRef);
    vPrev = v;
    tPrev = state.time;
  }
  r.energies = integrator->energies(state);
  return r;
}

TEST(FemHourglassViscous, BarWaveCloseToStiffnessControl) {
  const WaveResult v = barWave(true), s = barWave(false);
  ASSERT_EQ(v.history.size(), s.history.size());
  // The front is steep: a pointwise maximum measures its sharpness, the RMS
  // over the history the overall agreement.
  double diff = 0.0, rms = 0.0;
  for (std::size_t k = 0; k < v.history.size(); ++k) {
    diff = std::max(diff, std::abs(v.history[k] - s.history[k]));
    rms += (v.history[k] - s.history[k]) * (v.history[k] - s.history[k]);
  }
  rms = std::sqrt(rms / static_cast<double>(v.history.size()));
  const Energies& e = v.energies;
  const double balance = std::abs(e.kinetic + e.strain + e.viscousDissipated - e.externalWork) / e.externalWork;
  std::printf("[hourglass viscous bar wave] arrival viscous %.6e s, stiffness %.6e s (%.3f %%); max |v_visc - v_stiff| "
              "= %.3e of the plateau (RMS %.3e); dissipated %.3e J of work %.3e J, balance %.3e\n",
              v.arrival, s.arrival, 100.0 * (v.arrival - s.arrival) / s.arrival, diff, rms, e.viscousDissipated,
              e.externalWork, balance);
  EXPECT_LT(std::abs(v.arrival - s.arrival) / s.arrival, 1e-3);
  EXPECT_LT(rms, 0.02);
  EXPECT_GE(e.viscousDissipated, 0.0);
  EXPECT_LT(balance, 1e-3);
}

/// Explicit 4x60x4 cantilever (0.8 x 0.8 x 12, E = 1e8, nu = 0.3), sudden tip
/// load; mean tip deflection history over 1 s.
std::vector<double> explicitCantilever(bool viscous, Energies& energies) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {0.8, 12, 0.8}, {4, 60, 4});
  auto model = viscous ? viscousModel(std::move(mesh), 1e8, 0.3, 1000.0, 0.05)
                       : test::makeModel(std::move(mesh), "one-point", 1e8, 0.3, 1000.0);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int i = 0; i < 3; ++i) model->prescribe(n, i, Prescribed::Kind::displacement, 0.0);
  model->addTraction(model->mesh().faceSet("ymax"), Vec3(0, 0, -1e4 / 0.64));
  auto integrator = makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  integrator->initialise(state);
  const double dt = 0.9 * integrator->criticalDt();
  const auto& tip = model->mesh().nodeSet("ymax");
  std::vector<double> history;
  while (state.time < 1.0) {
    integrator->step(state, dt);
    double w = 0.0;
    for (Index n : tip) w += state.u[3 * n + 2] / static_cast<double>(tip.size());
    history.push_back(w);
  }
  energies = integrator->energies(state);
  return history;
}

TEST(FemHourglassViscous, ExplicitCantileverCloseToStiffnessControl) {
  Energies ev, es;
  const std::vector<double> v = explicitCantilever(true, ev), s = explicitCantilever(false, es);
  ASSERT_EQ(v.size(), s.size());
  double diff = 0.0, peak = 0.0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    diff = std::max(diff, std::abs(v[k] - s[k]));
    peak = std::max(peak, std::abs(s[k]));
  }
  std::printf("[hourglass viscous cantilever 4x60x4] tip at 1 s: viscous %.6e m, stiffness %.6e m; max history "
              "difference %.3e of the peak %.4e m; dissipated %.3e J, stiffness-type hourglass energy %.3e J, strain %.3e J\n",
              v.back(), s.back(), diff / peak, peak, ev.viscousDissipated, es.hourglass, es.strain);
  EXPECT_LT(diff / peak, 0.05);
}

TEST(FemHourglassViscous, ImplicitSolversRefuseIt) {
  auto model = viscousModel(makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1}), 1e8, 0.3, 1000.0, 0.05);
  EXPECT_THROW(makeNewmark(*model, NewmarkOptions{}), InputError);
  State state;
  state.resize(model->numDofs());
  EXPECT_THROW(solveStatic(*model, state, NewtonOptions{}), InputError);
}

}  // namespace
}  // namespace cosim::fem
