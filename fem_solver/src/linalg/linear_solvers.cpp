// Sparse linear solvers for the Newton and linear systems. The fill-reducing
// ordering and symbolic analysis are computed once and reused for every
// Newton iteration and time step (the pattern never changes).
//  * "ldlt": Eigen's SimplicialLDLT (AMD ordering), column by column.
//  * "profile": envelope L D L^T in reverse Cuthill-McKee order
//    (profile_ldlt.hpp): contiguous rows, faster solves on slender meshes.
//  * "cholmod": CHOLMOD's supernodal Cholesky (Chen, Davis, Hager &
//    Rajamanickam 2008): it gathers columns with the same structure into
//    dense supernodes and factorises them with BLAS-3 kernels, which is
//    where a 3D solid's factor spends its flops. It needs A positive
//    definite; a matrix that is not (an indefinite tangent past a limit
//    point, a singular system) is factorised by "ldlt" instead, which also
//    names the dof of a zero pivot.
//  * "direct": cholmod where the build found CHOLMOD and CHOLMOD's analysis
//    finds supernodes worth it (flops per factor entry above its switch,
//    i.e. large 3D meshes), otherwise profile where its envelope holds at
//    most 1.5 times the entries of ldlt's sparse factor, else ldlt: on small
//    systems the BLAS calls cost more than they save (a 270-dof Newmark test
//    ran 4 times slower).
//  * "cg": conjugate gradients with an incomplete Cholesky preconditioner.
//
// GCC 12's flow-sensitive -Wnull-dereference fires inside Eigen's sparse
// solver templates once inlined here (false positives in library code).
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cmath>
#include <optional>

#ifdef COSIM_HAVE_CHOLMOD
#include <cholmod.h>
#include <dlfcn.h>

#include <cstdlib>
#endif

#include "cosim/fem/linalg/sparse_system.hpp"
#include "profile_ldlt.hpp"

namespace cosim::fem {
namespace {

/// Smallest pivot, relative to the largest, that still counts as nonzero.
constexpr double kSingularPivot = 1e-11;

class LdltSolver final : public LinearSolver {
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
      if (!(std::abs(D(k)) > kSingularPivot * dmax)) {
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
  /// Entries of the last factor's L (strictly lower).
  long factorEntries() const { return static_cast<long>(ldlt_.matrixL().nestedExpression().nonZeros()); }

 private:
  Eigen::SimplicialLDLT<SparseSystem::Matrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  bool analysed_ = false;
  int singular_ = -1;
};

class ProfileSolver final : public LinearSolver {
 public:
  void factorize(const SparseSystem::Matrix& A) override {
    if (!analysed_) {
      profile_.analyse(A);
      analysed_ = true;
    }
    singular_ = profile_.factorize(A, kSingularPivot);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    Eigen::VectorXd x(b.size());
    profile_.solve(b.data(), x.data());
    return x;
  }
  int singularDof() const override { return singular_; }

 private:
  ProfileLdlt profile_;
  bool analysed_ = false;
  int singular_ = -1;
};

/// Systems without supernodes worth BLAS: the first factorisation measures
/// ldlt's sparse factor against the reverse Cuthill-McKee envelope and keeps
/// profile where the envelope has at most 1.5 times its entries (a contiguous
/// entry costs less than a sparse one: the C1 beam, 810 free dofs, 1.02
/// times, solves 2-3x faster), ldlt otherwise (compact 3D meshes). Where
/// the caller has already compared the envelope with a sparse factor
/// (CHOLMOD's analysis), profile is taken without that trial factorisation.
class SimplicialSolver final : public LinearSolver {
 public:
  explicit SimplicialSolver(bool envelopeKnownSmall = false) : envelopeKnownSmall_(envelopeKnownSmall) {}
  void factorize(const SparseSystem::Matrix& A) override {
    if (!chosen_ && envelopeKnownSmall_) {
      chosen_ = true;
      profile_.emplace();
    }
    if (!chosen_) {
      chosen_ = true;
      ldlt_.emplace();
      ldlt_->factorize(A);
      if (ldlt_->singularDof() >= 0) return;  // ldlt names the dof of a zero pivot
      // The envelope's size comes from the ordering alone (O(nnz) memory):
      // a compact 3D mesh's envelope can be far larger than its sparse factor.
      ProfileLdlt envelope;
      envelope.analyse(A);
      if (static_cast<double>(envelope.envelopeSize()) > 1.5 * static_cast<double>(ldlt_->factorEntries())) return;
      ldlt_.reset();
      profile_.emplace();
      profile_->factorize(A);
      return;
    }
    if (profile_) profile_->factorize(A);
    else ldlt_->factorize(A);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override { return profile_ ? profile_->solve(b) : ldlt_->solve(b); }
  int singularDof() const override { return profile_ ? profile_->singularDof() : ldlt_->singularDof(); }

 private:
  bool envelopeKnownSmall_;
  bool chosen_ = false;
  std::optional<LdltSolver> ldlt_;
  std::optional<ProfileSolver> profile_;
};

#ifdef COSIM_HAVE_CHOLMOD
/// CHOLMOD's supernodes call BLAS. Debian's OpenBLAS starts a thread per
/// core, which here competes with the solver's own OpenMP threads and with
/// the other processes of a coupled run: on the 2-core VM a 3630-dof cube
/// factorised in 479 ms with its threads and in 113 ms with one
/// (`fem_bench solvers`). So one thread, unless OPENBLAS_NUM_THREADS says
/// otherwise; looked up at run time, since libblas may be another BLAS.
void limitBlasThreads() {
  static const bool done = [] {
    if (std::getenv("OPENBLAS_NUM_THREADS")) return true;
    using SetThreads = void (*)(int);
    if (void* f = dlsym(RTLD_DEFAULT, "openblas_set_num_threads")) reinterpret_cast<SetThreads>(f)(1);
    return true;
  }();
  (void)done;
}

class CholmodSolver final : public LinearSolver {
 public:
  /// automatic: ldlt where CHOLMOD's analysis would choose a simplicial factor.
  explicit CholmodSolver(bool automatic) : automatic_(automatic) {
    limitBlasThreads();
    cholmod_start(&common_);
    common_.supernodal = automatic ? CHOLMOD_AUTO : CHOLMOD_SUPERNODAL;
    common_.print = 0;  // failures are reported by status, not on stderr
  }
  ~CholmodSolver() override {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    cholmod_finish(&common_);
  }
  CholmodSolver(const CholmodSolver&) = delete;
  CholmodSolver& operator=(const CholmodSolver&) = delete;

  void factorize(const SparseSystem::Matrix& A) override {
    cholmod_sparse a = view(A);
    if (!factor_ && !simplicial_) {
      factor_ = cholmod_analyze(&a, &common_);
      if (!factor_) throw SolveError("CHOLMOD could not analyse the system (status " + std::to_string(common_.status) + ")");
      slender_ = factor_->is_super && automatic_ && slender(A);
      simplicial_ = !factor_->is_super || slender_;
      if (simplicial_) cholmod_free_factor(&factor_, &common_);
    }
    supernodal_ = false;
    if (!simplicial_) {
      cholmod_factorize(&a, factor_, &common_);
      if (common_.status < CHOLMOD_OK) throw SolveError("CHOLMOD factorisation failed (status " + std::to_string(common_.status) + ")");
      supernodal_ = factor_->minor == factor_->n && pivotsNonzero();
      if (supernodal_) return;
    }
    if (!fallback_) fallback_.emplace(slender_);
    fallback_->factorize(A);
  }
  Eigen::VectorXd solve(const Eigen::VectorXd& b) override {
    if (!supernodal_) return fallback_->solve(b);
    cholmod_dense rhs{};
    rhs.nrow = rhs.d = rhs.nzmax = static_cast<std::size_t>(b.size());
    rhs.ncol = 1;
    rhs.x = const_cast<double*>(b.data());  // read only
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* x = cholmod_solve(CHOLMOD_A, factor_, &rhs, &common_);
    if (!x) throw SolveError("CHOLMOD solve failed (status " + std::to_string(common_.status) + ")");
    Eigen::VectorXd out = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(x->x), b.size());
    cholmod_free_dense(&x, &common_);
    return out;
  }
  int singularDof() const override { return supernodal_ ? -1 : fallback_->singularDof(); }

 private:
  /// A as CHOLMOD sees it (no copy; CHOLMOD only reads it). The pattern
  /// holds both triangles; CHOLMOD is told to read the upper one, the form
  /// its column-oriented factorisation works on, which spares it a transpose.
  static cholmod_sparse view(const SparseSystem::Matrix& A) {
    cholmod_sparse a{};
    a.nrow = static_cast<std::size_t>(A.rows());
    a.ncol = static_cast<std::size_t>(A.cols());
    a.nzmax = static_cast<std::size_t>(A.nonZeros());
    a.p = const_cast<int*>(A.outerIndexPtr());
    a.i = const_cast<int*>(A.innerIndexPtr());
    a.x = const_cast<double*>(A.valuePtr());
    a.stype = 1;  // symmetric, entries below the diagonal ignored
    a.itype = CHOLMOD_INT;
    a.xtype = CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    return a;
  }
  /// L_kk^2 (the pivots of L D L^T) all above kSingularPivot of the largest:
  /// the diagonal of each supernode's dense column block.
  bool pivotsNonzero() const {
    const auto* super = static_cast<const int*>(factor_->super);
    const auto* pi = static_cast<const int*>(factor_->pi);
    const auto* px = static_cast<const int*>(factor_->px);
    const auto* x = static_cast<const double*>(factor_->x);
    double lo = INFINITY, hi = 0.0;
    for (std::size_t s = 0; s < factor_->nsuper; ++s) {
      const int cols = super[s + 1] - super[s], rows = pi[s + 1] - pi[s];
      for (int j = 0; j < cols; ++j) {
        const double d = x[px[s] + j * (rows + 1)];
        lo = std::min(lo, d * d);
        hi = std::max(hi, d * d);
      }
    }
    return lo > kSingularPivot * hi;
  }
  /// A system whose reverse Cuthill-McKee envelope holds at most 1.5 times
  /// the entries of CHOLMOD's supernodal factor (a slender mesh): there the
  /// envelope factor's contiguous rows beat the supernodes' BLAS calls, on a
  /// 4500-dof beam 9 against 265 ms to factorise and 261 against 428 us to
  /// solve (`fem_bench solvers`); compact 3D meshes keep CHOLMOD.
  bool slender(const SparseSystem::Matrix& A) const {
    ProfileLdlt envelope;
    envelope.analyse(A);
    return static_cast<double>(envelope.envelopeSize()) <= 1.5 * common_.lnz;
  }

  bool automatic_;
  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  bool simplicial_ = false;  // no supernodes (CHOLMOD's choice, or a slender system): the fallback throughout
  bool supernodal_ = false;  // the current factorisation is CHOLMOD's (else ldlt's)
  bool slender_ = false;  // the envelope holds at most 1.5 times CHOLMOD's factor: the fallback uses it
  std::optional<SimplicialSolver> fallback_;  // small, slender or not positive definite systems
};
#endif

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

const std::vector<std::string>& linearSolverNames() {
  static const std::vector<std::string> names = {"direct", "cholmod", "ldlt", "profile", "cg"};
  return names;
}

std::unique_ptr<LinearSolver> makeLinearSolver(const std::string& name, double tolerance) {
#ifdef COSIM_HAVE_CHOLMOD
  if (name == "direct" || name == "cholmod") return std::make_unique<CholmodSolver>(name == "direct");
#else
  if (name == "direct") return std::make_unique<SimplicialSolver>();
  if (name == "cholmod")
    throw InputError("linear solver 'cholmod': this build has no CHOLMOD (install libsuitesparse-dev and reconfigure)");
#endif
  if (name == "ldlt") return std::make_unique<LdltSolver>();
  if (name == "profile") return std::make_unique<ProfileSolver>();
  if (name == "cg") return std::make_unique<ConjugateGradientSolver>(tolerance);
  throw InputError("unknown linear solver '" + name + "' (known: direct, cholmod, ldlt, profile, cg)");
}

}  // namespace cosim::fem
