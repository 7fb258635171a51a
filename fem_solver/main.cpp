// fem_solver: the FEM solver process (finite-strain hexahedra, Newmark and
// central difference) behind the shared SolverHost loop.
#include <memory>

#include "cosim/fem/solver/fem_solver.hpp"
#include "cosim/wire/solver_host.hpp"

int main(int argc, char** argv) {
  return cosim::wire::solverMain(argc, argv, [] { return std::make_unique<cosim::fem::FemSolver>(); });
}
