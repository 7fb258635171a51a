#pragma once
// A sparse symmetric matrix over the free dofs with a pattern fixed at build
// time and a precomputed slot for every element matrix entry, so assembly is
// a scatter of values and the symbolic factorisation can be reused.
#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/fem/types.hpp"

namespace cosim::fem {

class SparseSystem {
 public:
  using Matrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
  void build(const Mesh& mesh, const std::vector<int>& dofMap, int numFree);
  void setZero();
  void add(std::size_t element, const Mat24& Ke, double scale = 1.0);
  Matrix& matrix() { return matrix_; }
  const Matrix& matrix() const { return matrix_; }
  int size() const { return static_cast<int>(matrix_.rows()); }

 private:
  Matrix matrix_;
  std::vector<int> slots_;  // 576 per element, -1 where a dof is prescribed
};

/// Linear solvers for the Newton systems, symbolic analysis once: "direct"
/// (CHOLMOD's supernodal Cholesky where the build has it and the system is
/// large enough, else "profile" or "ldlt", whichever factor is smaller),
/// "cholmod", "ldlt" (Eigen's SimplicialLDLT), "profile" (envelope L D L^T in
/// reverse Cuthill-McKee order) and "cg" (conjugate gradients, incomplete
/// Cholesky).
class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  /// Numeric factorisation; the first call also analyses the pattern.
  virtual void factorize(const SparseSystem::Matrix& A) = 0;
  virtual Eigen::VectorXd solve(const Eigen::VectorXd& b) = 0;
  /// Index of a free dof with (near) zero pivot, or -1.
  virtual int singularDof() const { return -1; }
};
/// Throws InputError for an unknown name, or "cholmod" in a build without CHOLMOD.
std::unique_ptr<LinearSolver> makeLinearSolver(const std::string& name, double tolerance = 1e-10);
/// The names makeLinearSolver knows.
const std::vector<std::string>& linearSolverNames();

}  // namespace cosim::fem
