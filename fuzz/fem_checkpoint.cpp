// Fuzz target: fem_solver's restore from a checkpoint file, as `coupler run
// --resume` asks for it after the setup, and one step from the restored
// state. Two set-up solvers take the files: an elastic Newmark model, and a
// GMH block of the external material (whose checkpoints also hold the
// stresses, deformation gradients and split step). A bad file must end in a
// wire::SolverError whose message names the file; an error of the step after
// a restore that was accepted must be a SolverError too. Anything else is a
// finding.
//
// Input layout: byte 0 picks the model (even: elastic, odd: external); the
// rest is the checkpoint, written to fem.chk in the scratch directory.
#include <memory>

#include "cosim/fem/solver/fem_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

constexpr const char* kFile = "fem.chk";

const char* const kElastic = R"(solvers:
  - name: fuzz
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [1, 2, 1], divisions: [1, 2, 1]}}
      material: {model: st-venant-kirchhoff, E: 1.0e6, nu: 0.3, density: 1000}
      boundary: [{set: ymin, value: 0.0}]
      loads: [{set: ymax, traction: [0, 0, -10]}]
      integrator: {type: newmark, mass: lumped}
)";

const char* const kExternal = R"(solvers:
  - name: fuzz
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [0.01, 0.01, 0.01], divisions: [1, 1, 1]}}
      material: {model: external, E: 1.0e9, nu: 0.2, density: 1.6e4}
      formulation: one-point
      boundary: [{set: zmin, value: 0.0}, {set: zmax, dofs: [x], value: 0.2, kind: velocity}]
      integrator: {type: central-difference, damping: 1.0e4}
)";

// Set up once: a restore replaces the whole state, so inputs do not depend on each other.
fem::FemSolver& solver(bool external) {
  static const auto solvers = [] {
    fuzz::prepareSolverTarget();
    std::array<std::unique_ptr<fem::FemSolver>, 2> s{std::make_unique<fem::FemSolver>(), std::make_unique<fem::FemSolver>()};
    fuzz::setUp(*s[0], kElastic);
    fuzz::setUp(*s[1], kExternal);
    return s;
  }();
  return *solvers[external ? 1 : 0];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0 || size > fuzz::kMaxInputBytes) return -1;
  fem::FemSolver& fem = solver(data[0] % 2 == 1);
  fuzz::resume(fem, data + 1, size - 1, kFile, 1e-7);
  return 0;
}

namespace cosim::fuzz {

// Seeds: checkpoints the solver itself writes, of both models, at setup and
// after a few steps, in the input layout above.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  for (const bool external : {false, true})
    for (const std::uint32_t steps : {0u, 3u}) {
      fem::FemSolver fresh;
      setUp(fresh, external ? kExternal : kElastic);
      for (std::uint32_t k = 0; k < steps; ++k) advance(fresh, 1, 1e-7);  // the external material takes one per exchange
      const auto file = scratchDir() / "seed.chk";
      fresh.checkpoint(file.string());
      Bytes bytes{static_cast<std::uint8_t>(external ? 1 : 0)};
      const Bytes chk = readBytes(file);
      bytes.insert(bytes.end(), chk.begin(), chk.end());
      out.push_back(std::move(bytes));
    }
  return out;
}

}  // namespace cosim::fuzz
