#include "cosim/fem/analysis/modal.hpp"

#include <cmath>
#include <numbers>

#include "cosim/fem/linalg/sparse_system.hpp"
#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem {

double lowestNaturalFrequency(Model& model, double relTol, int maxIterations) {
  SparseSystem K, M;
  K.build(model.mesh(), model.dofMap(), model.numFree());
  M.build(model.mesh(), model.dofMap(), model.numFree());
  std::vector<double> u(model.numDofs(), 0.0), f;
  ElementEnergy energy;
  model.assembleTangent(u, K, f, energy);
  model.assembleMass(M);
  auto solver = makeLinearSolver("direct");
  solver->factorize(K.matrix());
  // Inverse iteration converges to the lowest mode (for a square section one
  // of two degenerate bending modes: either has the same frequency).
  Eigen::VectorXd x = Eigen::VectorXd::Ones(model.numFree());
  double lambda = 0.0;
  for (int it = 0; it < maxIterations; ++it) {
    const Eigen::VectorXd y = solver->solve(M.matrix() * x);
    const double next = x.dot(M.matrix() * x) / x.dot(M.matrix() * y);  // Rayleigh-type estimate of w^2
    x = y / std::sqrt(y.dot(M.matrix() * y));
    const bool converged = std::abs(next - lambda) < relTol * next;
    lambda = next;
    if (converged) break;
  }
  return std::sqrt(lambda) / (2.0 * std::numbers::pi);
}

}  // namespace cosim::fem
