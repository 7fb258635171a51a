// Fuzz target: dem_solver's particle files (readSphereFile, CSV: x,y,z,r
// with optional vx,vy,vz, '#' comments, one header line), read as a setup
// reads them for `particles: [{file: {path: ...}}]`: the spheres added with
// their material, the system initialised (neighbour grid, contacts) and
// checked (radii, masses, initial overlaps). A bad file must end in a
// wire::SolverError whose message names the particle file or the scene.
// The HDF5 form is left to the HDF5 library's own testing.
//
// Input layout: the CSV text, written to particles.csv in the scratch directory.
#include "cosim/dem/solver/dem_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

const char* const kScene = R"(solvers:
  - name: fuzz
    kind: dem
    params:
      materials: [{name: glass, density: 2500, young: 7.0e10, poisson: 0.3}]
      particles: [{file: {path: particles.csv, material: glass}}]
      walls: [{type: plane, name: floor, point: [0, 0, -1], normal: [0, 0, 1]}]
      zones: [{name: all}]
)";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cosim;
  static const bool prepared = (fuzz::prepareSolverTarget(), true);
  (void)prepared;
  dem::DemSolver solver;
  return fuzz::setUpWithFile(solver, kScene, "particles.csv", data, size);
}

namespace cosim::fuzz {

// Seeds: the fixture (header, 7 columns), and files with 4 columns, comments,
// other separators, blank lines and a touching pair.
std::vector<std::vector<std::uint8_t>> seeds() {
  return {bytesOf(kParticleCsv),
          bytesOf("# spheres\n0 0 0 0.01\n\n0.03 0 0 0.01   # right\n0;0.03;0;0.02\n"),
          bytesOf("x\ty\tz\tr\n1e-3\t2e-3\t0\t5e-4\n-1e-3\t2e-3\t0\t5e-4\r\n"),
          bytesOf("0,0,0,1,0,0,0\n2,0,0,1,-1,0,0\n")};
}

}  // namespace cosim::fuzz
