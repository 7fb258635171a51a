#include "cosim/fem/time/integrator.hpp"

#include "cosim/fem/linalg/dof_loop.hpp"

namespace cosim::fem {

void Integrator::applyPrescribed(State& state, double t) const {
  model_.applyConstraints(t, state.u, &state.v);
}

void Integrator::accumulateWork(State& state, const std::vector<double>& uOld, const std::vector<double>& fNew) const {
  state.fApplied.resize(fNew.size(), 0.0);
  state.externalWork += sumOverDofs(fNew.size(), [&](std::size_t d) {
    const double w = 0.5 * (state.fApplied[d] + fNew[d]) * (state.u[d] - uOld[d]);
    state.fApplied[d] = fNew[d];
    return w;
  });
}

void requireNoViscousForces(const Model& model, const std::string& solver) {
  if (model.formulation().hasViscousForce())
    throw InputError(solver + ": viscous element forces (hourglass type viscous, stiffness_damping) need the "
                     "central-difference integrator");
}

void Integrator::predict(State&, double) {
  throw InputError(name() + ": split steps (external stresses) need the central-difference integrator");
}
void Integrator::correct(State&, double) {
  throw InputError(name() + ": split steps (external stresses) need the central-difference integrator");
}

Energies Integrator::energies(const State& state) const {
  Energies en;
  std::vector<double> f;
  ElementEnergy ee;
  model_.internalForce(state.u, f, ee);
  en.strain = ee.strain;
  en.hourglass = ee.hourglass;
  en.kinetic = model_.kineticEnergy(state.v, lumpedMass_);
  en.externalWork = state.externalWork;
  en.viscousDissipated = state.viscousDissipated;
  return en;
}

}  // namespace cosim::fem
