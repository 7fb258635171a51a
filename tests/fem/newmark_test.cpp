// Newmark-beta (beta = 1/4, gamma = 1/2) free vibration of a clamped beam:
// the total energy (kinetic + strain) must stay constant to 1e-6 over 1000
// steps (the trapezoidal rule conserves energy of the linearised system; the
// amplitude is small so geometric nonlinearity is negligible).
#include <gtest/gtest.h>

#include <cmath>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

TEST(FemNewmark, FreeVibrationEnergyDrift) {
  const double L = 2.0;
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {0.4, L, 0.4}, {2, 10, 2}), "incompatible-modes", 1e8, 0.25, 1000.0);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  NewmarkOptions opts;
  opts.newton.tolerance = 1e-12;
  auto integrator = makeNewmark(*model, opts);
  State state;
  state.resize(model->numDofs());
  const Mesh& m = model->mesh();
  for (Index n = 0; n < m.numNodes(); ++n) {
    const double y = m.node(n)[1] / L;
    state.v[3 * n + 2] = 1e-3 * y * y;
    state.v[3 * n + 0] = 5e-4 * y;
  }
  integrator->initialise(state);
  auto total = [&] {
    const Energies e = integrator->energies(state);
    return e.kinetic + e.strain + e.hourglass;
  };
  const double E0 = total();
  double maxDrift = 0.0, maxStrain = 0.0;
  int maxIterations = 0;
  for (int s = 0; s < 1000; ++s) {
    integrator->step(state, 2e-3);
    maxIterations = std::max(maxIterations, integrator->lastNewton().iterations);
    if (s % 10 == 9) {
      maxDrift = std::max(maxDrift, std::abs(total() - E0) / E0);
      maxStrain = std::max(maxStrain, integrator->energies(state).strain);
    }
  }
  const double finalDrift = std::abs(total() - E0) / E0;
  std::printf("[newmark] E0 = %.6e J, max relative drift = %.3e, final = %.3e, max strain energy %.3e J, "
              "max Newton iterations %d\n", E0, maxDrift, finalDrift, maxStrain, maxIterations);
  EXPECT_GT(maxStrain, 0.5 * E0);  // it really vibrates
  EXPECT_LT(maxDrift, 1e-6);
}

}  // namespace
}  // namespace cosim::fem

// Modified Newton (tangent_reuse) converges to the same step solution as full
// Newton, since only the residual decides convergence: same displacements to
// 1e-9 relative after 200 steps of a large-amplitude vibration, and fewer
// tangent factorisations.
namespace cosim::fem {
namespace {

std::vector<double> vibrate(int tangentReuse, int& iterations, double speed = 15.0, bool linear = false,
                            double* energyDrift = nullptr) {
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {0.4, 2.0, 0.4}, {2, 10, 2}), "incompatible-modes", 1e8, 0.25, 1000.0);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  NewmarkOptions opts;
  opts.newton.tolerance = 1e-12;
  opts.newton.tangentReuse = tangentReuse;
  opts.linear = linear;
  auto integrator = makeNewmark(*model, opts);
  State state;
  state.resize(model->numDofs());
  for (Index n = 0; n < model->mesh().numNodes(); ++n) state.v[3 * n + 2] = speed * model->mesh().node(n)[1];
  integrator->initialise(state);
  auto total = [&] {
    const Energies e = integrator->energies(state);
    return e.kinetic + e.strain;
  };
  const double e0 = total();
  iterations = 0;
  double drift = 0.0;
  for (int s = 0; s < 200; ++s) {
    integrator->step(state, 2e-3);
    iterations += integrator->lastNewton().iterations;
    drift = std::max(drift, std::abs(total() - e0) / e0);
  }
  if (energyDrift) *energyDrift = drift;
  return state.u;
}

TEST(FemNewmark, ModifiedNewtonMatchesFullNewton) {
  int fullIterations = 0, modifiedIterations = 0;
  const auto full = vibrate(0, fullIterations);
  const auto modified = vibrate(4, modifiedIterations);
  double diff = 0.0, size = 0.0;
  for (std::size_t d = 0; d < full.size(); ++d) {
    diff = std::max(diff, std::abs(full[d] - modified[d]));
    size = std::max(size, std::abs(full[d]));
  }
  std::printf("[newmark] full Newton %d iterations, modified %d; max |u_full - u_modified| = %.3e of %.3e m\n",
              fullIterations, modifiedIterations, diff, size);
  EXPECT_GT(size, 1e-2);  // large enough to be nonlinear
  EXPECT_LT(diff, 1e-9 * size);
}

}  // namespace
}  // namespace cosim::fem

// Linear mode (f_int = K_0 u): for a small amplitude it agrees with the
// finite-strain solve to the size of the neglected quadratic terms, and it
// conserves its own energy (kinetic + u^T K_0 u / 2) to round-off.
namespace cosim::fem {
namespace {

TEST(FemNewmark, LinearModeMatchesFiniteStrainAtSmallAmplitude) {
  int iterations = 0;
  double drift = 0.0;
  const auto finite = vibrate(0, iterations, 0.05);
  const auto linear = vibrate(0, iterations, 0.05, true, &drift);
  double diff = 0.0, size = 0.0;
  for (std::size_t d = 0; d < finite.size(); ++d) {
    diff = std::max(diff, std::abs(finite[d] - linear[d]));
    size = std::max(size, std::abs(finite[d]));
  }
  std::printf("[newmark] linear vs finite strain: max difference %.3e of %.3e m, linear energy drift %.3e, %d iterations\n",
              diff, size, drift, iterations);
  EXPECT_GT(size, 1e-5);
  EXPECT_LT(diff, 1e-3 * size);
  EXPECT_LT(drift, 1e-10);
  EXPECT_LE(iterations, 200 * 1) << "one solve per step (plus the converged residual check)";
}

}  // namespace
}  // namespace cosim::fem
