#pragma once
// Shared Newton loop for the static and Newmark solves.
#include <functional>
#include <sstream>

#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem::detail {

/// Residual and tangent at the current iterate: fills R (free dofs), the
/// system matrix and the reference magnitude for the convergence test.
using Linearise = std::function<void(Eigen::VectorXd& R, double& scale, bool wantTangent)>;

inline std::string history(const NewtonReport& report) {
  std::ostringstream s;
  for (std::size_t i = 0; i < report.residuals.size(); ++i) s << (i ? ", " : "") << report.residuals[i];
  return s.str();
}

/// Factorises A; throws SolveError naming the node of a zero pivot.
inline void factorise(const Model& model, LinearSolver& solver, SparseSystem& A, const std::string& where) {
  solver.factorize(A.matrix());
  const int bad = solver.singularDof();
  if (bad < 0) return;
  const auto& map = model.dofMap();
  std::size_t dof = 0;
  for (std::size_t d = 0; d < map.size(); ++d)
    if (map[d] == bad) dof = d;
  throw SolveError(where + ": singular system (zero pivot at node " + std::to_string(dof / 3) + " direction " +
                   "xyz"[dof % 3] + "); the model is not sufficiently constrained");
}

/// Runs Newton: linearise, solve A du = -R, update(du); reports divergence
/// with the residual history, never loops forever.
/// Converged when the relative residual is below options.tolerance, or when
/// the last correction was below options.displacementTolerance of the
/// solution (the residual then sits at its round-off floor). update returns
/// the norm of the updated free-dof solution.
/// With options.tangentReuse > 0, `factorised` says whether solver holds a
/// usable factorisation from an earlier solve; the loop keeps it until a solve
/// needs more than tangentReuse iterations, then refreshes it.
inline NewtonReport newtonLoop(const Model& model, const NewtonOptions& options, SparseSystem& A, LinearSolver& solver,
                               const Linearise& linearise, const std::function<double(const Eigen::VectorXd&)>& update,
                               const std::string& where, bool* factorised = nullptr) {
  NewtonReport report;
  Eigen::VectorXd R;
  double correction = 1.0;
  const bool reuse = options.tangentReuse > 0 && factorised;
  for (int it = 0; it <= options.maxIterations; ++it) {
    double scale = 0.0;
    const bool fresh = !reuse || !*factorised || it >= options.tangentReuse;
    linearise(R, scale, fresh);
    const double norm = R.norm();
    const double rel = norm / (scale + 1e-300);
    report.residuals.push_back(rel);
    report.iterations = it;
    if (!std::isfinite(norm))
      throw SolveError(where + ": non-finite residual in Newton iteration " + std::to_string(it) +
                       " (relative residuals: " + history(report) + ")");
    if (rel <= options.tolerance || norm == 0.0 || correction <= options.displacementTolerance) return report;
    if (it == options.maxIterations) break;
    if (!fresh) {
      const Eigen::VectorXd du = solver.solve(-R);
      correction = du.norm() / (update(du) + 1e-300);
      continue;
    }
    factorise(model, solver, A, where);
    if (factorised) *factorised = true;
    const Eigen::VectorXd du = solver.solve(-R);
    const double unorm = update(du);
    correction = du.norm() / (unorm + 1e-300);
  }
  throw SolveError(where + ": Newton did not converge in " + std::to_string(options.maxIterations) +
                   " iterations (relative residuals: " + history(report) + ")");
}

}  // namespace cosim::fem::detail
