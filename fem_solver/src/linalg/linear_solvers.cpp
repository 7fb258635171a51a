// Sparse direct solver: SimplicialLDLT with the fill-reducing ordering and
// symbolic analysis computed once and reused for every Newton iteration and
// time step (the pattern never changes).
//
// GCC 12's flow-sensitive -Wnull-dereference fires inside Eigen's sparse
// solver templates once inlined here (false positives in library code).
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Eigen/IterativeLinearSolvers>
#include <cmath>

#include "cosim/fem/linalg/sparse_system.hpp"

namespace cosim::fem {
namespace {

class DirectSolver final : public LinearSolver {
 public:
  void factorize(const SparseSystem::Matrix& A) override {
    if (!analysed_) {
      ldlt_.analyzePattern(A);
      analysed_ = true;
    }
    ldlt_.factorize(A);
    singular_ = -1;
    const Eigen::VectorXd D = ldlt_.vectorD();
    const double dmax = D.cwiseAbs().maxCoeff();
    for (int k = 0; k < D.size(); ++k) {
      if (!(std::abs(D(k)) > 1e-11 * dmax)) {
        // Map the permuted pivot back to the original free dof.
        const auto& perm = ldlt_.permutationP().indices();
        for (int i = 0; i < perm.size(); ++i)
          if (perm(i) == k) singular_ = i;
        break;
      }
    }
    if (ldlt_.info() != Eigen::Success && singular_ < 0) singular_ = 0;
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return ldlt_.solve(b); }
  int singularDof() const override { return singular_; }

 private:
  Eigen::SimplicialLDLT<SparseSystem::Matrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  bool analysed_ = false;
  int singular_ = -1;
};

class ConjugateGradientSolver final : public LinearSolver {
 public:
  explicit ConjugateGradientSolver(double tolerance) { cg_.setTolerance(tolerance); }
  void factorize(const SparseSystem::Matrix& A) override {
    if (!analysed_) {
      cg_.analyzePattern(A);
      analysed_ = true;
    }
    cg_.factorize(A);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    Eigen::VectorXd x = cg_.solve(b);
    if (cg_.info() != Eigen::Success)
      throw SolveError("conjugate gradients did not converge in " + std::to_string(cg_.iterations()) +
                       " iterations (error " + std::to_string(cg_.error()) + ")");
    return x;
  }

 private:
  Eigen::ConjugateGradient<SparseSystem::Matrix, Eigen::Lower | Eigen::Upper,
                           Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>>
      cg_;
  bool analysed_ = false;
};

}  // namespace

std::unique_ptr<LinearSolver> makeLinearSolver(const std::string& name, double tolerance) {
  if (name == "direct") return std::make_unique<DirectSolver>();
  if (name == "cg") return std::make_unique<ConjugateGradientSolver>(tolerance);
  throw InputError("unknown linear solver '" + name + "' (known: direct, cg)");
}

}  // namespace cosim::fem
