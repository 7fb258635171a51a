// pd_solver: the peridynamics solver process (all of it lives in cosim_pd).
#include <memory>

#include "cosim/pd/pd_solver.hpp"
#include "cosim/wire/solver_host.hpp"

int main(int argc, char** argv) {
  return cosim::wire::solverMain(argc, argv, [] { return std::make_unique<cosim::pd::PdSolver>(); });
}
