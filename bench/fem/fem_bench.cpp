// fem_bench explicit [R]: element-steps/s of explicit central-difference steps
//                        on a 100 x 100 x 10 (1e5 element) mesh, one-point and
//                        full integration, 1 and 2 threads; best of R batches
//                        (default 3) by wall time, and per CPU-second.
// fem_bench cantilever : tip deflection / Timoshenko for every formulation
//                        under mesh refinement (the docs/fem.md table).
// fem_bench frequency  : first bending frequency of the cantilever against
//                        beam theory (inverse iteration on K phi = w^2 M phi).
// fem_bench solvers [R]: factorisation and solve times of every linear solver
//                        on Newmark systems K_0 + M / (beta dt^2) of slender
//                        beams and a cube; best of R batches (default 3).
#include <omp.h>

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "cosim/fem/analysis/modal.hpp"
#include "cosim/fem/linalg/sparse_system.hpp"
#include "cosim/fem/model/model.hpp"
#include "cosim/fem/time/integrator.hpp"

using namespace cosim::fem;

namespace {

std::unique_ptr<Model> makeModel(Mesh mesh, const std::string& formulation, double rho = 1000.0) {
  return std::make_unique<Model>(std::move(mesh), MaterialRegistry::instance().create("st-venant-kirchhoff", {1e8, 0.0, rho}),
                                 FormulationRegistry::instance().create(formulation), FormulationOptions{});
}

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/// Element-steps per second of wall time (best of `repeats` batches) and per
/// second of process CPU time (that batch): on a shared machine the second
/// shows whether the threads add work (overhead) or only wait for a core.
void benchExplicit(int repeats) {
  double load[3] = {0, 0, 0};
  getloadavg(load, 3);
  std::printf("explicit central difference, 100 x 100 x 10 = 1e5 hexahedra, SVK; %d cores online, load average %.2f\n",
              omp_get_num_procs(), load[0]);
  std::printf("%-12s %8s %10s %16s %16s %10s\n", "formulation", "threads", "steps", "element-steps/s", "per CPU-second",
              "CPU/wall");
  for (const char* f : {"one-point", "full"}) {
    auto model = makeModel(makeBoxMesh({0, 0, 0}, {1, 1, 0.1}, {100, 100, 10}), f);
    for (Index n : model->mesh().nodeSet("zmin"))
      for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
    model->addTraction(model->mesh().faceSet("zmax"), Vec3(0, 0, -1e4));
    auto integrator = makeCentralDifference(*model, {});
    State state;
    state.resize(model->numDofs());
    integrator->initialise(state);
    const double dt = 0.9 * integrator->criticalDt();
    const double elements = static_cast<double>(model->mesh().numElements());
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      const int steps = std::string(f) == "full" ? 20 : 60;
      integrator->step(state, dt);  // warm-up
      double wall = 1e300, cpu = 0.0;
      for (int r = 0; r < repeats; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        const double c0 = cpuSeconds();
        for (int s = 0; s < steps; ++s) integrator->step(state, dt);
        const double t = seconds(t0);
        if (t < wall) {
          wall = t;
          cpu = cpuSeconds() - c0;
        }
      }
      const double work = static_cast<double>(steps) * elements;
      std::printf("%-12s %8d %10d %16.3e %16.3e %10.2f\n", f, threads, steps, work / wall, work / cpu, cpu / wall);
    }
  }
}

double timoshenko(double P) {
  const double L = 12, b = 0.8, E = 1e8, I = b * b * b * b / 12, A = b * b, G = E / 2, k = 5.0 / 6.0;
  return P * L * L * L / (3 * E * I) + P * L / (k * G * A);
}

void benchCantilever() {
  const double P = 100.0, ref = timoshenko(P);
  std::printf("cantilever 0.8 x 0.8 x 12 m, E = 1e8 Pa, nu = 0, tip load %.0f N; Timoshenko tip %.5e m\n", P, ref);
  std::printf("%-20s %-10s %8s %14s %10s %12s %9s\n", "formulation", "mesh", "dofs", "tip [m]", "tip/ref",
              "hg/internal", "time [s]");
  const int meshes[][3] = {{1, 15, 1}, {2, 30, 2}, {4, 60, 4}, {8, 120, 8}};
  for (const char* f : {"full", "incompatible-modes", "one-point"}) {
    for (const auto& m : meshes) {
      auto model = makeModel(makeBoxMesh({0, 0, 0}, {0.8, 12, 0.8}, {m[0], m[1], m[2]}), f);
      for (Index n : model->mesh().nodeSet("ymin"))
        for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
      model->addTraction(model->mesh().faceSet("ymax"), Vec3(0, 0, -P / 0.64));
      State state;
      state.resize(model->numDofs());
      const auto t0 = std::chrono::steady_clock::now();
      solveStatic(*model, state, NewtonOptions{});
      const double t = seconds(t0);
      double tip = 0.0;
      const auto& tipNodes = model->mesh().nodeSet("ymax");
      for (Index n : tipNodes) tip -= state.u[3 * n + 2] / static_cast<double>(tipNodes.size());
      std::vector<double> fi;
      ElementEnergy en;
      model->internalForce(state.u, fi, en);
      char name[32];
      std::snprintf(name, sizeof name, "%dx%dx%d", m[0], m[1], m[2]);
      std::printf("%-20s %-10s %8d %14.6e %10.4f %11.3f%% %9.3f\n", f, name, model->numFree(), tip, tip / ref,
                  100.0 * en.hourglass / (en.strain + en.hourglass), t);
    }
  }
}

void benchFrequency() {
  // Lowest eigenpair of K phi = w^2 M phi by inverse iteration with the sparse
  // LDLT factor of K (consistent mass); compared with Euler-Bernoulli
  // f1 = 1.875104^2 / (2 pi) sqrt(E I / (rho A L^4)).
  const double rho = 1309.0, E = 1e8, b = 0.8, L = 12.0, I = b * b * b * b / 12, A = b * b;
  const double fEB = 1.875104 * 1.875104 / (2 * M_PI) * std::sqrt(E * I / (rho * A * L * L * L * L));
  std::printf("first bending frequency, Euler-Bernoulli %.5f Hz\n", fEB);
  const int meshes[][3] = {{2, 30, 2}, {4, 60, 4}};
  for (const char* f : {"incompatible-modes", "full"}) {
    for (const auto& m : meshes) {
      auto model = makeModel(makeBoxMesh({0, 0, 0}, {b, L, b}, {m[0], m[1], m[2]}), f, rho);
      for (Index n : model->mesh().nodeSet("ymin"))
        for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
      const double freq = lowestNaturalFrequency(*model);
      std::printf("%-20s %dx%dx%d  f1 = %.5f Hz  ratio to Euler-Bernoulli %.4f\n", f, m[0], m[1], m[2], freq, freq / fEB);
    }
  }
}

/// Newmark's system matrix for the clamped 0.8 x 12 x 0.8 m beam (or a 1 m cube) on the given mesh.
SparseSystem newmarkSystem(const std::array<int, 3>& cells, bool cube) {
  const Vec3 hi = cube ? Vec3(1, 1, 1) : Vec3(0.8, 12.0, 0.8);
  auto model = makeModel(makeBoxMesh({0, 0, 0}, hi, cells), "incompatible-modes", 1309.0);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  return model->shiftedStiffness(1.0 / (0.25 * 6.43e-5 * 6.43e-5));  // C1's step
}

void benchSolvers(int repeats) {
  std::printf("linear solvers on Newmark systems (C1's dt); best of %d batches\n", repeats);
  std::printf("%-10s %-14s %8s %10s %14s %14s %12s\n", "mesh", "", "dofs", "solver", "factorise [ms]", "solve [us]",
              "residual");
  struct Case {
    const char* name;
    std::array<int, 3> cells;
    bool cube;
  };
  const Case cases[] = {{"beam", {2, 30, 2}, false}, {"beam", {4, 60, 4}, false}, {"cube", {10, 10, 10}, true}};
  for (const auto& c : cases) {
    const SparseSystem A = newmarkSystem(c.cells, c.cube);
    Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(A.size(), -1.0, 1.0);
    char mesh[32];
    std::snprintf(mesh, sizeof mesh, "%dx%dx%d", c.cells[0], c.cells[1], c.cells[2]);
    for (const auto& name : linearSolverNames()) {
      if (name == "cg") continue;
      std::unique_ptr<LinearSolver> solver;
      try {
        solver = makeLinearSolver(name);
      } catch (const InputError&) {
        continue;  // cholmod in a build without it
      }
      solver->factorize(A.matrix());  // analysis and choices once, as in a run
      double factorise = 1e300, solve = 1e300;
      Eigen::VectorXd x;
      for (int r = 0; r < repeats; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        solver->factorize(A.matrix());
        factorise = std::min(factorise, seconds(t0));
        const int solves = std::max(20, static_cast<int>(2e6 / A.matrix().nonZeros()));
        t0 = std::chrono::steady_clock::now();
        for (int k = 0; k < solves; ++k) x = solver->solve(b);
        solve = std::min(solve, seconds(t0) / solves);
      }
      std::printf("%-10s %-14s %8d %10s %14.3f %14.1f %12.2e\n", c.name, mesh, A.size(), name.c_str(), 1e3 * factorise,
                  1e6 * solve, (A.matrix() * x - b).norm() / b.norm());
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "all";
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
  if (mode == "explicit" || mode == "all") benchExplicit(repeats);
  if (mode == "cantilever" || mode == "all") benchCantilever();
  if (mode == "frequency" || mode == "all") benchFrequency();
  if (mode == "solvers" || mode == "all") benchSolvers(repeats);
  if (mode != "all" && mode != "explicit" && mode != "cantilever" && mode != "frequency" && mode != "solvers") {
    std::fprintf(stderr, "usage: fem_bench [explicit|cantilever|frequency|solvers|all] [repeats of each batch, default 3]\n");
    return 2;
  }
  return 0;
}
