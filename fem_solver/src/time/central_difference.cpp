// Explicit central difference with lumped mass (Liu 2016 Sec. 2.2, Eq. 51),
// written in the equivalent half-step velocity form:
//   v_{n+1/2} = v_n + dt/2 a_n,  u_{n+1} = u_n + dt v_{n+1/2},
//   a_{n+1} = M^-1 (f_ext - f_int(u_{n+1}) - alpha M v_{n+1/2}),
//   v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}.
// Mass-proportional damping alpha enters with the half-step velocity, which
// keeps the scheme explicit; the critical step is Liu Eq. 65. Viscous
// hourglass forces (one-point element) enter the same way, with v_{n+1/2};
// their work is integrated with the trapezoidal rule like the external work,
// so kinetic + strain + dissipated = external work up to the O(dt^2) term of
// the scheme. Periodic slave dofs move with their masters (forces and lumped
// masses summed onto the master, Model::constrainedAcceleration) and get the
// prescribed jump exactly at every step.
#include "cosim/fem/linalg/dof_loop.hpp"
#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem {
namespace {

class CentralDifference final : public Integrator {
 public:
  CentralDifference(Model& model, const CentralDifferenceOptions& options) : Integrator(model), options_(options) {
    lumpedMass_ = true;
    if (options.damping < 0.0) throw InputError("central difference: damping must be >= 0");
  }
  std::string name() const override { return "central-difference"; }
  void initialise(State& state) override {
    applyPrescribed(state, state.time);
    criticalDt_ = model_.criticalTimeStep(options_.damping);
    std::vector<double> fint, fext, fvisc;
    ElementEnergy en;
    model_.internalForce(state.u, fint, en);
    model_.externalForce(state.time, fext);
    model_.addFollowerLoads(state.time, state.u, fext);
    model_.viscousForce(state.v, fvisc);
    acceleration(state, fint, fext, fvisc, state.v);
    state.fApplied = fext;
    state.fViscous = fvisc;
  }
  double criticalDt() const override { return criticalDt_; }

  void step(State& state, double dt) override {
    predict(state, dt);
    correct(state, dt);
  }

  void predict(State& state, double dt) override {
    const double t1 = state.time + dt;
    std::vector<double>& uOld = state.uStepStart;
    uOld.resize(state.u.size());
    forEachDof(state.u.size(), [&](std::size_t d) {
      uOld[d] = state.u[d];
      state.v[d] += 0.5 * dt * state.a[d];
      state.u[d] += dt * state.v[d];
    });
    for (const Prescribed& p : model_.prescribed()) {
      state.u[p.dof] = p.displacement(t1);
      state.v[p.dof] = (state.u[p.dof] - uOld[p.dof]) / dt;
    }
    model_.enforceSlaves(t1, state.u, nullptr);
    for (const SlaveDof& s : model_.slaves()) state.v[s.dof] = (state.u[s.dof] - uOld[s.dof]) / dt;
    model_.checkFinite(state.u, "displacement");
    state.time = t1;
    ++state.step;
  }

  void correct(State& state, double dt) override {
    const double t1 = state.time;
    ElementEnergy en;
    model_.internalForce(state.u, fint_, en);
    model_.externalForce(t1, fext_);
    model_.addFollowerLoads(t1, state.u, fext_);
    if (model_.formulation().hasViscousForce() || fvisc_.size() != state.v.size())
      model_.viscousForce(state.v, fvisc_);  // at v_{n+1/2}; stays zero without viscous forces
    acceleration(state, fint_, fext_, fvisc_, state.v);
    // Constraint forces of periodic ties join the external work:
    // res = M a + f_int + f_visc + alpha M v - f_ext per dof.
    const auto& m = model_.lumpedMass();
    if (!model_.slaves().empty()) {
      res_.resize(state.u.size());
      forEachDof(res_.size(), [&](std::size_t d) {
        res_[d] = m[d / 3] * (state.a[d] + options_.damping * state.v[d]) + fint_[d] + fvisc_[d] - fext_[d];
      });
    }
    // Prescribed dofs: their reactions f_int + f_visc are the applied forces.
    const auto& map = model_.dofMap();
    forEachDof(state.u.size(), [&](std::size_t d) {
      state.v[d] += 0.5 * dt * state.a[d];
      if (map[d] < 0) fext_[d] = fint_[d] + fvisc_[d];
    });
    for (const Prescribed& p : model_.prescribed()) state.v[p.dof] = p.velocity(t1);
    for (const SlaveDof& s : model_.slaves()) state.v[s.dof] = state.v[s.master] + s.jump.velocity(t1);
    model_.checkFinite(state.v, "velocity");
    model_.addTieReactions(res_, fext_);
    accumulateViscousDissipation(state);
    accumulateWork(state, state.uStepStart, fext_);
  }

 private:
  void acceleration(State& state, const std::vector<double>& fint, const std::vector<double>& fext,
                    const std::vector<double>& fvisc, const std::vector<double>& vHalf) {
    const auto& m = model_.lumpedMass();
    const double alpha = options_.damping;
    net_.resize(state.u.size());
    forEachDof(net_.size(), [&](std::size_t d) { net_[d] = fext[d] - fint[d] - fvisc[d] - alpha * m[d / 3] * vHalf[d]; });
    model_.constrainedAcceleration(net_, state.a);
  }
  /// Trapezoidal work of the viscous element forces (hourglass, stiffness
  /// damping) over the step: they resist the motion, so this is the energy
  /// they removed.
  void accumulateViscousDissipation(State& state) const {
    if (!model_.formulation().hasViscousForce()) return;
    state.viscousDissipated += sumOverDofs(fvisc_.size(), [&](std::size_t d) {
      return 0.5 * (state.fViscous[d] + fvisc_[d]) * (state.u[d] - state.uStepStart[d]);
    });
    state.fViscous = fvisc_;
  }
  CentralDifferenceOptions options_;
  double criticalDt_ = 0.0;
  std::vector<double> fint_, fext_, fvisc_, res_, net_;
};

}  // namespace

std::unique_ptr<Integrator> makeCentralDifference(Model& model, const CentralDifferenceOptions& options) {
  return std::make_unique<CentralDifference>(model, options);
}

}  // namespace cosim::fem
