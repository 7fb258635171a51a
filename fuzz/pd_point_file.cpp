// Fuzz target: pd_solver's point files (readPointFile: "x y z volume" per
// line, '#' comments), read as a setup reads them for a `shape: points` body:
// the body sized from the file, its bonds found within the horizon, its
// model built, the hybrid surface particles found. A bad file must end in a
// wire::SolverError whose message names the point file or the scene.
//
// Input layout: the point file text, written to points.txt in the scratch directory.
#include "cosim/pd/pd_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

const char* const kScene = R"(solvers:
  - name: fuzz
    kind: pd
    params:
      bodies:
        - {name: cloud, shape: points, file: points.txt, horizon: 2, model: lps, material: {E: 1.0e9, nu: 0.3, rho: 1000}}
      boundary:
        - {select: {body: cloud, min: [-1, -1, -1], max: [1.0e-4, 1, 1]}, type: fixed}
)";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cosim;
  static const bool prepared = (fuzz::prepareSolverTarget(), true);
  (void)prepared;
  pd::PdSolver solver;
  return fuzz::setUpWithFile(solver, kScene, "points.txt", data, size);
}

namespace cosim::fuzz {

// Seeds: the fixture (a 3 x 2 x 2 lattice), and files with comments, blank
// lines, tabs, uneven volumes and a lone point.
std::vector<std::vector<std::uint8_t>> seeds() {
  return {bytesOf(kPointFile),
          bytesOf("0 0 0 1e-9  # first\n\n0.001\t0\t0\t2e-9\n0 0.001 0 5e-10\r\n0.001 0.001 0 1e-9\n"),
          bytesOf("1.5 -2.5 3e-1 0.125\n")};
}

}  // namespace cosim::fuzz
