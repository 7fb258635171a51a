// Static equilibrium f_int(u) = f_ext by Newton's method on the consistent
// tangent (Cheng 2022 Eqs. 6-7), with optional load increments; or the
// geometrically linear problem K_0 u = f_ext (one factorisation, one solve).
#include "cosim/fem/time/integrator.hpp"
#include <cmath>

#include "newton.hpp"

namespace cosim::fem {

namespace {

/// R = f_int - f_ext on the free dofs (slave rows summed onto their
/// masters); returns the reference magnitude |f_ext| + |f_int| over all dofs.
double residual(const Model& model, const std::vector<double>& fint, const std::vector<double>& fext,
                Eigen::VectorXd& R) {
  double fe = 0.0, fi = 0.0;
  std::vector<double> r(fint.size());
  for (std::size_t d = 0; d < r.size(); ++d) {
    fe += fext[d] * fext[d];
    fi += fint[d] * fint[d];
    r[d] = fint[d] - fext[d];
  }
  model.reduce(r, R);
  return std::sqrt(fe) + std::sqrt(fi);
}

/// u += du on the free dofs (a slave moves with its master); returns |u - uStart|.
double addCorrection(const Model& model, const Eigen::VectorXd& du, const std::vector<double>& uStart,
                     std::vector<double>& u) {
  const auto& map = model.dofMap();
  double n2 = 0.0;
  for (std::size_t d = 0; d < map.size(); ++d)
    if (map[d] >= 0) {
      u[d] += du(map[d]);
      n2 += (u[d] - uStart[d]) * (u[d] - uStart[d]);
    }
  return std::sqrt(n2);
}

}  // namespace

NewtonReport solveLinearStatic(Model& model, State& state, const std::string& linearSolver) {
  requireNoViscousForces(model, "static solve");
  model.applyConstraints(state.time, state.u, nullptr);
  SparseSystem K;
  K.build(model.mesh(), model.dofMap(), model.numFree());
  std::vector<double> fint, fext;
  ElementEnergy en;
  model.assembleLinearStiffness(state.u, K, fint, en);
  model.externalForce(state.time, fext);
  model.addFollowerLoads(state.time, state.u, fext);  // on the configuration the solve starts from
  Eigen::VectorXd R;
  const double scale = residual(model, fint, fext, R);
  auto solver = makeLinearSolver(linearSolver);
  detail::factorise(model, *solver, K, "linear static solve");
  const Eigen::VectorXd du = solver->solve(-R);
  NewtonReport report;
  report.iterations = 1;
  // What the solve left of the residual: K_0 du + R (free dofs).
  const Eigen::VectorXd left = K.matrix().selfadjointView<Eigen::Lower>() * du + R;
  report.residuals = {R.norm() / (scale + 1e-300), left.norm() / (scale + 1e-300)};
  const std::vector<double> uStart = state.u;
  addCorrection(model, du, uStart, state.u);
  model.checkFinite(state.u, "displacement");
  return report;
}

NewtonReport solveStatic(Model& model, State& state, const NewtonOptions& options, int loadSteps) {
  requireNoViscousForces(model, "static solve");
  SparseSystem K;
  K.build(model.mesh(), model.dofMap(), model.numFree());
  auto solver = makeLinearSolver(options.linearSolver);
  const double tEnd = state.time;
  std::vector<double> fint, fext;
  NewtonReport report;
  for (int ls = 1; ls <= loadSteps; ++ls) {
    // Load increments follow the load ramp: evaluate loads and prescribed values at a fraction of tEnd.
    const double t = tEnd * static_cast<double>(ls) / static_cast<double>(loadSteps);
    model.applyConstraints(loadSteps > 1 ? t : tEnd, state.u, nullptr);  // prescribed values, periodic jumps
    std::vector<double> fdead;
    model.externalForce(loadSteps > 1 ? t : tEnd, fdead);
    auto linearise = [&](Eigen::VectorXd& R, double& scale, bool) {
      fext = fdead;
      model.addFollowerLoads(loadSteps > 1 ? t : tEnd, state.u, fext);  // not in the tangent
      ElementEnergy en;
      model.assembleTangent(state.u, K, fint, en);
      scale = residual(model, fint, fext, R);
    };
    const std::vector<double> uStart = state.u;
    auto update = [&](const Eigen::VectorXd& du) { return addCorrection(model, du, uStart, state.u); };
    report = detail::newtonLoop(model, options, K, *solver, linearise, update,
                                "static solve, load step " + std::to_string(ls));
  }
  model.checkFinite(state.u, "displacement");
  return report;
}

}  // namespace cosim::fem
