// dem_solver: the DEM process. Everything is in the cosim_dem library.
#include "cosim/dem/solver/dem_solver.hpp"
#include "cosim/wire/solver_host.hpp"

int main(int argc, char** argv) {
  return cosim::wire::solverMain(argc, argv, [] { return std::make_unique<cosim::dem::DemSolver>(); });
}
