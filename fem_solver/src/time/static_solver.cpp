// Static equilibrium f_int(u) = f_ext by Newton's method on the consistent
// tangent (Cheng 2022 Eqs. 6-7), with optional load increments.
#include "cosim/fem/time/integrator.hpp"
#include <cmath>

#include "newton.hpp"

namespace cosim::fem {

NewtonReport solveStatic(Model& model, State& state, const NewtonOptions& options, int loadSteps) {
  requireNoViscousForces(model, "static solve");
  SparseSystem K;
  K.build(model.mesh(), model.dofMap(), model.numFree());
  auto solver = makeLinearSolver(options.linearSolver);
  const auto& map = model.dofMap();
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
      double fe = 0.0, fi = 0.0;
      std::vector<double> r(map.size());
      for (std::size_t d = 0; d < map.size(); ++d) {
        fe += fext[d] * fext[d];
        fi += fint[d] * fint[d];
        r[d] = fint[d] - fext[d];
      }
      model.reduce(r, R);  // slave rows summed onto their masters
      scale = std::sqrt(fe) + std::sqrt(fi);
    };
    const std::vector<double> uStart = state.u;
    auto update = [&](const Eigen::VectorXd& du) {
      double n2 = 0.0;
      for (std::size_t d = 0; d < map.size(); ++d)
        if (map[d] >= 0) {
          state.u[d] += du(map[d]);
          n2 += (state.u[d] - uStart[d]) * (state.u[d] - uStart[d]);
        }
      return std::sqrt(n2);
    };
    report = detail::newtonLoop(model, options, K, *solver, linearise, update,
                                "static solve, load step " + std::to_string(ls));
  }
  model.checkFinite(state.u, "displacement");
  return report;
}

}  // namespace cosim::fem
