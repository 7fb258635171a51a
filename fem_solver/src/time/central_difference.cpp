// Explicit central difference with lumped mass (Liu 2016 Sec. 2.2, Eq. 51),
// written in the equivalent half-step velocity form:
//   v_{n+1/2} = v_n + dt/2 a_n,  u_{n+1} = u_n + dt v_{n+1/2},
//   a_{n+1} = M^-1 (f_ext - f_int(u_{n+1}) - alpha M v_{n+1/2}),
//   v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}.
// Mass-proportional damping alpha enters with the half-step velocity, which
// keeps the scheme explicit; the critical step is Liu Eq. 65.
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
    std::vector<double> fint, fext;
    ElementEnergy en;
    model_.internalForce(state.u, fint, en);
    model_.externalForce(state.time, fext);
    model_.addFollowerLoads(state.time, state.u, fext);
    acceleration(state, fint, fext, state.v);
    state.fApplied = fext;
  }
  double criticalDt() const override { return criticalDt_; }

  void step(State& state, double dt) override {
    predict(state, dt);
    correct(state, dt);
  }

  void predict(State& state, double dt) override {
    const double t1 = state.time + dt;
    const std::size_t n = state.u.size();
    uOld_ = state.u;
    for (std::size_t d = 0; d < n; ++d) {
      state.v[d] += 0.5 * dt * state.a[d];
      state.u[d] += dt * state.v[d];
    }
    for (const Prescribed& p : model_.prescribed()) {
      state.u[p.dof] = p.displacement(t1);
      state.v[p.dof] = (state.u[p.dof] - uOld_[p.dof]) / dt;
    }
    model_.checkFinite(state.u, "displacement");
    state.time = t1;
    ++state.step;
  }

  void correct(State& state, double dt) override {
    const double t1 = state.time;
    const std::size_t n = state.u.size();
    ElementEnergy en;
    model_.internalForce(state.u, fint_, en);
    model_.externalForce(t1, fext_);
    model_.addFollowerLoads(t1, state.u, fext_);
    acceleration(state, fint_, fext_, state.v);
    for (std::size_t d = 0; d < n; ++d) state.v[d] += 0.5 * dt * state.a[d];
    for (const Prescribed& p : model_.prescribed()) state.v[p.dof] = p.velocity(t1);
    model_.checkFinite(state.v, "velocity");
    // Reactions at prescribed dofs join the external work.
    for (const Prescribed& p : model_.prescribed()) fext_[p.dof] = fint_[p.dof];
    accumulateWork(state, uOld_, fext_);
  }

 private:
  void acceleration(State& state, const std::vector<double>& fint, const std::vector<double>& fext,
                    const std::vector<double>& vHalf) const {
    const auto& m = model_.lumpedMass();
    const double alpha = options_.damping;
    const std::size_t n = state.u.size();
    for (std::size_t d = 0; d < n; ++d)
      state.a[d] = model_.isFixed(d) ? 0.0 : (fext[d] - fint[d]) / m[d / 3] - alpha * vHalf[d];
  }
  CentralDifferenceOptions options_;
  double criticalDt_ = 0.0;
  std::vector<double> uOld_, fint_, fext_;
};

}  // namespace

std::unique_ptr<Integrator> makeCentralDifference(Model& model, const CentralDifferenceOptions& options) {
  return std::make_unique<CentralDifference>(model, options);
}

}  // namespace cosim::fem
