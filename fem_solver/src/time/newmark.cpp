// Implicit Newmark-beta (Newmark 1959, as used by Cheng 2022 Sec. 3.2):
//   u_{n+1} = u_n + dt v_n + dt^2 [(1/2 - beta) a_n + beta a_{n+1}]
//   v_{n+1} = v_n + dt [(1 - gamma) a_n + gamma a_{n+1}]
// with M a_{n+1} + f_int(u_{n+1}) = f_ext(t_{n+1}) solved by Newton on the
// consistent tangent K_T + M / (beta dt^2) (Cheng Eqs. 5-7). beta = 1/4,
// gamma = 1/2 (trapezoidal rule) conserves energy for linear systems.
// With options.linear, f_int = K_0 u (K_0 the tangent at u = 0, on all dofs)
// and the strain energy is u^T K_0 u / 2: small-strain linear elastodynamics.
// Periodic ties: residuals are reduced onto independent dofs (T^T R), the
// system matrices are assembled through the dof map (T^T A T), and a slave's
// acceleration differs from its master's by a constant per step chosen so
// that u_s = u_m + jump(t_{n+1}) holds exactly.
#include "cosim/fem/time/integrator.hpp"
#include <algorithm>
#include <cmath>
#include <cstring>

#include "newton.hpp"

namespace cosim::fem {
namespace {

class Newmark final : public Integrator {
 public:
  Newmark(Model& model, const NewmarkOptions& options) : Integrator(model), options_(options) {
    if (!(options.beta > 0.0) || !(options.gamma >= 0.5))
      throw InputError("newmark: need beta > 0 and gamma >= 1/2");
    lumpedMass_ = options.lumpedMass;
    requireNoViscousForces(model, "newmark");
    solver_ = makeLinearSolver(options.newton.linearSolver);
  }
  std::string name() const override { return "newmark"; }

  void initialise(State& state) override {
    if (options_.linear) buildLinearStiffness();
    A_.build(model_.mesh(), model_.dofMap(), model_.numFree());
    M_.build(model_.mesh(), model_.dofMap(), model_.numFree());
    model_.assembleMass(M_);
    applyPrescribed(state, state.time);
    // Initial acceleration from M a0 = f_ext - f_int (free dofs).
    std::vector<double> fint, fext;
    internalForce(state.u, fint);
    model_.externalForce(state.time, fext);
    model_.addFollowerLoads(state.time, state.u, fext);
    const auto& map = model_.dofMap();
    for (std::size_t d = 0; d < fint.size(); ++d) fint[d] = fext[d] - fint[d];
    Eigen::VectorXd r, a0;
    model_.reduce(fint, r);
    if (lumpedMass_) {
      a0 = r.cwiseQuotient(reducedLumpedMass());
    } else {
      auto massSolver = makeLinearSolver("direct");
      massSolver->factorize(M_.matrix());
      a0 = massSolver->solve(r);
    }
    for (std::size_t d = 0; d < map.size(); ++d) state.a[d] = map[d] >= 0 ? a0(map[d]) : 0.0;
    state.fApplied = fext;
  }

  void step(State& state, double dt) override {
    const double beta = options_.beta, gamma = options_.gamma;
    const double t1 = state.time + dt;
    const std::vector<double> uOld = state.u;
    const std::vector<double> vOld = state.v, aOld = state.a;
    const std::size_t n = state.u.size();
    // Predictors (a_{n+1} = 0 part).
    std::vector<double> uPred(n), vPred(n);
    for (std::size_t d = 0; d < n; ++d) {
      uPred[d] = uOld[d] + dt * vOld[d] + dt * dt * (0.5 - beta) * aOld[d];
      vPred[d] = vOld[d] + dt * (1.0 - gamma) * aOld[d];
    }
    // Acceleration is the primary unknown (u = u_pred + beta dt^2 a): forming
    // M a from a difference of nearly equal displacements would cost digits.
    const double c0 = 1.0 / (beta * dt * dt);
    for (std::size_t d = 0; d < n; ++d) state.a[d] = 0.0;
    for (const Prescribed& p : model_.prescribed()) state.a[p.dof] = c0 * (p.displacement(t1) - uPred[p.dof]);
    // Newton adds the same increments to a slave and its master, so this
    // offset keeps u_s - u_m = jump(t1) throughout.
    for (const SlaveDof& s : model_.slaves())
      state.a[s.dof] = state.a[s.master] + c0 * (s.jump.displacement(t1) + uPred[s.master] - uPred[s.dof]);
    auto updateKinematics = [&] {
      for (std::size_t d = 0; d < n; ++d) {
        state.u[d] = uPred[d] + state.a[d] / c0;
        state.v[d] = vPred[d] + gamma * dt * state.a[d];
      }
      for (const Prescribed& p : model_.prescribed()) state.u[p.dof] = p.displacement(t1);
      model_.enforceSlaves(t1, state.u, nullptr);
    };
    const auto& map = model_.dofMap();
    std::vector<double> fint, fext, fdead, Ma;
    model_.externalForce(t1, fdead);
    // Follower loads change with u: re-evaluated at every iterate (their load
    // stiffness is not in the tangent, so Newton converges linearly then).
    auto linearise = [&](Eigen::VectorXd& R, double& scale, bool wantTangent) {
      updateKinematics();
      fext = fdead;
      model_.addFollowerLoads(t1, state.u, fext);
      ElementEnergy en;
      if (!wantTangent) {  // modified Newton: the factorised A of an earlier iterate stays
        internalForce(state.u, fint);
        residual(state, fint, fext, Ma, R, scale);
        return;
      }
      if (options_.linear) {
        internalForce(state.u, fint);
        A_.matrix() = kFree_;
      } else {
        model_.assembleTangent(state.u, A_, fint, en);
      }
      // A = K_T + c0 M on the fixed pattern.
      double* av = A_.matrix().valuePtr();
      const double* mv = M_.matrix().valuePtr();
      if (lumpedMass_) {
        const int* outer = A_.matrix().outerIndexPtr();
        const int* inner = A_.matrix().innerIndexPtr();
        const Eigen::VectorXd diag = reducedLumpedMass();
        for (int c = 0; c < A_.size(); ++c)
          for (int k = outer[c]; k < outer[c + 1]; ++k)
            if (inner[k] == c) av[k] += c0 * diag(c);
      } else {
        for (long k = 0; k < A_.matrix().nonZeros(); ++k) av[k] += c0 * mv[k];
      }
      residual(state, fint, fext, Ma, R, scale);
    };
    auto update = [&](const Eigen::VectorXd& du) {
      double n2 = 0.0;
      for (std::size_t d = 0; d < map.size(); ++d)
        if (map[d] >= 0) {
          state.a[d] += c0 * du(map[d]);
          const double inc = uPred[d] + state.a[d] / c0 - uOld[d];
          n2 += inc * inc;
        }
      return std::sqrt(n2);
    };
    if (dt != factorisedDt_) factorised_ = false;  // A = K_T + M / (beta dt^2) depends on dt
    NewtonOptions newton = options_.newton;
    if (options_.linear) newton.tangentReuse = std::max(newton.tangentReuse, 2);  // K_0 never changes
    factorisedDt_ = dt;
    const bool shortcut = linearShortcut();
    report_ = shortcut ? oneSolve(linearise, update)
                       : detail::newtonLoop(model_, newton, A_, *solver_, linearise, update,
                                            "newmark step " + std::to_string(state.step + 1) + " (t = " +
                                                std::to_string(t1) + ")",
                                            &factorised_);
    updateKinematics();
    model_.checkFinite(state.u, "displacement");
    if (shortcut) equilibriumInternalForce(state, fext, Ma, fint);
    // Applied forces: external on free dofs, reactions on prescribed dofs.
    std::vector<double> fApplied = fext, res(n);
    for (std::size_t d = 0; d < map.size(); ++d) {
      res[d] = Ma[d] + fint[d] - fext[d];
      if (map[d] < 0) fApplied[d] = Ma[d] + fint[d];
    }
    model_.addTieReactions(res, fApplied);  // periodic constraint forces
    accumulateWork(state, uOld, fApplied);
    state.time = t1;
    ++state.step;
  }

 public:
  Energies energies(const State& state) const override {
    if (!options_.linear) return Integrator::energies(state);
    // Without the element loop the base class would run: it would cost more than the step.
    Energies e;
    std::vector<double> f;
    internalForce(state.u, f);
    for (std::size_t d = 0; d < f.size(); ++d) e.strain += 0.5 * state.u[d] * f[d];
    e.kinetic = model_.kineticEnergy(state.v, lumpedMass_);
    e.externalWork = state.externalWork;
    return e;
  }

 private:
  /// Linear mode with A = K_0 + c0 M factorised for this dt, no follower load
  /// and no periodic tie: the residual is linear in a, so the one solve from
  /// the predictor is the Newton solution, and Newton's converged check (a
  /// second K_0 u and M a per step) can be left out.
  bool linearShortcut() const {
    return options_.linear && factorised_ && !model_.hasFollowerLoads() && model_.slaves().empty();
  }

  NewtonReport oneSolve(const detail::Linearise& linearise, const std::function<double(const Eigen::VectorXd&)>& update) {
    Eigen::VectorXd R;
    double scale = 0.0;
    linearise(R, scale, false);
    NewtonReport report;
    report.iterations = 1;
    report.residuals.push_back(R.norm() / (scale + 1e-300));
    update(solver_->solve(-R));
    return report;
  }

  /// f_int(u_{n+1}) after the shortcut's solve, without a second K_0 u:
  /// on the free dofs the step solved M a + K_0 u = f_ext (Cheng Eq. 5 at
  /// t_{n+1}), so f_int = f_ext - M a there (to the solve's round-off); the
  /// prescribed dofs take their rows of K_0, for the reactions. Kept as the
  /// last K_0 u, for the energies of this state.
  void equilibriumInternalForce(const State& state, const std::vector<double>& fext, std::vector<double>& Ma,
                                std::vector<double>& fint) const {
    model_.massTimes(state.a, Ma, lumpedMass_);
    const auto& map = model_.dofMap();
    fint.resize(Ma.size());
    const Eigen::Map<const Eigen::VectorXd> u(state.u.data(), static_cast<Eigen::Index>(state.u.size()));
    for (std::size_t d = 0; d < map.size(); ++d)
      fint[d] = map[d] >= 0 ? fext[d] - Ma[d] : kFull_.row(static_cast<Eigen::Index>(d)).dot(u);
    lastU_ = state.u;
    lastF_ = fint;
  }

  /// K_0 on all dofs (for f_int and reactions) and on the free ones (for A).
  void buildLinearStiffness() {
    const std::size_t n = model_.numDofs();
    std::vector<int> all(n);
    for (std::size_t d = 0; d < n; ++d) all[d] = static_cast<int>(d);
    SparseSystem full, free;
    full.build(model_.mesh(), all, static_cast<int>(n));
    free.build(model_.mesh(), model_.dofMap(), model_.numFree());
    std::vector<double> f;
    ElementEnergy en;
    const std::vector<double> zero(n, 0.0);
    model_.assembleTangent(zero, full, f, en);
    model_.assembleTangent(zero, free, f, en);
    kFull_ = full.matrix();
    kFree_ = free.matrix();
  }

  /// f_int(u): the elements' internal force, or K_0 u in linear mode. A step
  /// ends with f_int of its final u (the converged residual) and the energies
  /// ask for the same u again: linear mode keeps the last product and reuses
  /// it when u is bitwise the same (comparing u costs far less than K_0 u).
  void internalForce(const std::vector<double>& u, std::vector<double>& f) const {
    if (!options_.linear) {
      ElementEnergy en;
      model_.internalForce(u, f, en);
      return;
    }
    if (u.size() != lastU_.size() || std::memcmp(u.data(), lastU_.data(), u.size() * sizeof(double)) != 0) {
      lastF_.resize(u.size());
      // Row-major K_0: each row is a dot product, no scattered writes.
      Eigen::Map<Eigen::VectorXd>(lastF_.data(), static_cast<Eigen::Index>(lastF_.size())) =
          kFull_ * Eigen::Map<const Eigen::VectorXd>(u.data(), static_cast<Eigen::Index>(u.size()));
      lastU_ = u;
    }
    f = lastF_;
  }

  /// R = M a + f_int - f_ext on the free dofs; scale = |M a| + |f_int| + |f_ext| over all dofs.
  void residual(const State& state, const std::vector<double>& fint, const std::vector<double>& fext,
                std::vector<double>& Ma, Eigen::VectorXd& R, double& scale) const {
    // The first iterate's a is zero wherever no motion is prescribed (all of
    // it under fixed supports): M 0 = 0 without the element loop.
    if (std::all_of(state.a.begin(), state.a.end(), [](double x) { return x == 0.0; }))
      Ma.assign(state.a.size(), 0.0);
    else
      model_.massTimes(state.a, Ma, lumpedMass_);
    std::vector<double> r(Ma.size());
    double s1 = 0, s2 = 0, s3 = 0;
    for (std::size_t d = 0; d < r.size(); ++d) {
      r[d] = Ma[d] + fint[d] - fext[d];
      s1 += Ma[d] * Ma[d];
      s2 += fint[d] * fint[d];
      s3 += fext[d] * fext[d];
    }
    model_.reduce(r, R);
    scale = std::sqrt(s1) + std::sqrt(s2) + std::sqrt(s3);
  }

  /// Lumped mass on the free dofs, slave masses summed onto their masters.
  Eigen::VectorXd reducedLumpedMass() const {
    const std::vector<double> m = model_.constrainedLumpedMass();
    Eigen::VectorXd diag;
    model_.reduce(m, diag);
    return diag;
  }

  NewmarkOptions options_;
  Eigen::SparseMatrix<double, Eigen::RowMajor> kFull_;  // linear mode: K_0 on all dofs (f_int, reactions)
  Eigen::SparseMatrix<double> kFree_;                   // and on the free ones (the system matrix)
  mutable std::vector<double> lastU_, lastF_;           // the last K_0 u and its u
  bool factorised_ = false;
  double factorisedDt_ = 0.0;
  SparseSystem A_, M_;
  std::unique_ptr<LinearSolver> solver_;
};

}  // namespace

std::unique_ptr<Integrator> makeNewmark(Model& model, const NewmarkOptions& options) {
  return std::make_unique<Newmark>(model, options);
}

}  // namespace cosim::fem
