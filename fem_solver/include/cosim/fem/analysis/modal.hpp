#pragma once
// Modal analysis of the linearised model about the undeformed state.
#include "cosim/fem/model/model.hpp"

namespace cosim::fem {

/// Lowest natural frequency (Hz) of the constrained model: inverse iteration
/// on K x = w^2 M x with the consistent mass, from the undeformed state,
/// until the Rayleigh-type estimate of w^2 changes by less than relTol.
double lowestNaturalFrequency(Model& model, double relTol = 1e-12, int maxIterations = 200);

}  // namespace cosim::fem
