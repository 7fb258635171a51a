#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem {

void Integrator::applyPrescribed(State& state, double t) const {
  for (const Prescribed& p : model_.prescribed()) {
    state.u[p.dof] = p.displacement(t);
    state.v[p.dof] = p.velocity(t);
  }
}

void Integrator::accumulateWork(State& state, const std::vector<double>& uOld, const std::vector<double>& fNew) const {
  double w = 0.0;
  for (std::size_t d = 0; d < fNew.size(); ++d) w += 0.5 * (state.fApplied[d] + fNew[d]) * (state.u[d] - uOld[d]);
  state.externalWork += w;
  state.fApplied = fNew;
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
  return en;
}

}  // namespace cosim::fem
