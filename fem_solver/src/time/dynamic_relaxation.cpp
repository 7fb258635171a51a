// Quasi-static equilibrium by dynamic relaxation (the pseudo-time explicit
// iteration Liu 2016 Sec. 2.3.4 uses for its unit cells, here for the coarse
// FEM under GMH-type loading): central difference in pseudo-time with the
// lumped mass at 0.9 x the critical step (Liu Eq. 65) and kinetic damping
// (velocities are zeroed whenever the kinetic energy passes a maximum), until
// the unbalanced-force ratio ||f_ext - f_int||_free / ||f_ext + reactions||
// falls below the tolerance (cf. the unbalanced-force index, Liu Eq. 57).
#include <algorithm>
#include <cmath>
#include <sstream>

#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem {

NewtonReport relaxStatic(Model& model, State& state, const RelaxationOptions& options) {
  requireNoViscousForces(model, "dynamic relaxation");
  const double dt = 0.9 * model.criticalTimeStep(0.0);
  if (!(dt > 0.0)) throw SolveError("dynamic relaxation: no finite critical step");
  model.applyConstraints(state.time, state.u, nullptr);
  std::vector<double> fint, fext, v(state.u.size(), 0.0), a(state.u.size(), 0.0), net(state.u.size());
  std::vector<double> fdead;
  model.externalForce(state.time, fdead);
  const auto& m = model.lumpedMass();
  NewtonReport report;
  double keOld = 0.0;
  auto forces = [&]() {
    fext = fdead;
    model.addFollowerLoads(state.time, state.u, fext);
    ElementEnergy en;
    model.internalForce(state.u, fint, en);
    double s2 = 0.0;
    for (std::size_t d = 0; d < fint.size(); ++d) {
      s2 += fint[d] * fint[d] + fext[d] * fext[d];
      net[d] = fext[d] - fint[d];
    }
    const double r2 = model.constrainedAcceleration(net, a);  // free dofs, periodic slaves on their masters
    return std::sqrt(r2) / (std::sqrt(s2) + 1e-300);
  };
  double ratio = forces();
  for (int it = 0; it < options.maxIterations; ++it) {
    if (it % 100 == 0) report.residuals.push_back(ratio);
    report.iterations = it;
    if (ratio <= options.tolerance) return report;
    double ke = 0.0;
    for (std::size_t d = 0; d < v.size(); ++d) {
      v[d] += dt * a[d];
      ke += 0.5 * m[d / 3] * v[d] * v[d];
    }
    if (ke < keOld) {  // kinetic damping: the peak has passed
      std::fill(v.begin(), v.end(), 0.0);
      ke = 0.0;
    }
    keOld = ke;
    for (std::size_t d = 0; d < v.size(); ++d) state.u[d] += dt * v[d];
    model.enforceSlaves(state.time, state.u, nullptr);
    model.checkFinite(state.u, "displacement (dynamic relaxation)");
    ratio = forces();
  }
  std::ostringstream msg;
  msg << "dynamic relaxation did not reach an unbalanced-force ratio of " << options.tolerance << " in "
      << options.maxIterations << " iterations (ratio, sampled:";
  const std::size_t stride = std::max<std::size_t>(1, report.residuals.size() / 10);
  for (std::size_t i = 0; i < report.residuals.size(); i += stride) msg << ' ' << report.residuals[i];
  msg << ")";
  throw SolveError(msg.str());
}

}  // namespace cosim::fem
