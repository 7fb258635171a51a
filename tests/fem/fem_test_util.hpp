#pragma once
#include <memory>
#include <string>

#include "cosim/fem/model/model.hpp"
#include "cosim/fem/time/integrator.hpp"

namespace cosim::fem::test {

std::unique_ptr<Model> makeModel(Mesh mesh, const std::string& formulation, double E, double nu, double rho,
                                 const std::string& material = "st-venant-kirchhoff", double hourglass = 0.05);

/// Cantilever 0.8 x 0.8 x L along y, clamped at y = 0, total tip load P in z
/// as a uniform traction on the ymax face. Returns the mean tip deflection.
struct CantileverResult {
  double tipDeflection = 0.0;
  double strainEnergy = 0.0;
  double hourglassEnergy = 0.0;
};
CantileverResult solveCantilever(const std::string& formulation, int nx, int ny, int nz, double P,
                                 double hourglass = 0.05);
/// Timoshenko tip deflection P L^3 / (3 E I) + P L / (k G A), k = 10 (1 + nu) / (12 + 11 nu).
double timoshenkoTip(double P, double L, double b, double h, double E, double nu);

}  // namespace cosim::fem::test
