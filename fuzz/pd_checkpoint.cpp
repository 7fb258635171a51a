// Fuzz target: pd_solver's restore from a checkpoint file, as `coupler run
// --resume` asks for it after the setup (the state arrays, the bond flags of
// every body, the hybrid watch), and one step from the restored state. A bad
// file must end in a wire::SolverError whose message names the file; an
// error of the step after a restore that was accepted must be a SolverError
// too. Anything else is a finding.
//
// Input layout: the checkpoint bytes, written to pd.chk in the scratch directory.
#include "cosim/pd/pd_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

constexpr const char* kFile = "pd.chk";

// Two small bodies, one breaking bonds, with hybrid surface particles.
const char* const kScene = R"(solvers:
  - name: fuzz
    kind: pd
    params:
      bodies:
        - {name: block, min: [0, 0, 0], max: [0.004, 0.002, 0.002], spacing: 0.001, horizon: 2, model: lps,
           material: {E: 1.0e9, nu: 0.3, rho: 1000}}
        - {name: bar, min: [0, 0, 0.01], max: [0.003, 0.001, 0.011], spacing: 0.001, horizon: 1.5, model: pmb,
           critical_stretch: 0.001, material: {E: 1.0e9, nu: 0.25, rho: 1000}}
      boundary:
        - {select: {body: bar, min: [-1, -1, -1], max: [0.0005, 1, 1]}, type: velocity, velocity: [-10, 0, 0]}
)";

// Set up once: a restore replaces the whole state, so inputs do not depend on each other.
pd::PdSolver& solver() {
  static pd::PdSolver* const s = [] {
    fuzz::prepareSolverTarget();
    auto* made = new pd::PdSolver;
    fuzz::setUp(*made, kScene);
    return made;
  }();
  return *s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > fuzz::kMaxInputBytes) return -1;
  pd::PdSolver& pd = solver();
  fuzz::resume(pd, data, size, kFile, 0.5 * pd.criticalDt());
  return 0;
}

namespace cosim::fuzz {

// Seeds: checkpoints the solver itself writes, at setup and after a few
// steps (with a hybrid watch and, as the bar stretches, broken bonds).
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  pd::PdSolver& pd = solver();
  const auto file = scratchDir() / "seed.chk";
  for (int k = 0; k < 3; ++k) {
    pd.checkpoint(file.string());
    out.push_back(readBytes(file));
    for (int s = 0; s < 20; ++s) advance(pd, 1, 0.5 * pd.criticalDt());
  }
  return out;
}

}  // namespace cosim::fuzz
