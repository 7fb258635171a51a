// Fuzz target: fem_solver's setup from a scene, what `fem_solver --check`
// does with the setup message `coupler check` writes: the params read (box or
// Gmsh mesh, sets, material, formulation, boundary, periodic ties, loads,
// initial velocity, integrator, Arlequin weight, coupling exports, output),
// the model built and the integrator initialised, the setup reply filled. A
// bad params section must end in a wire::SolverError whose message names the
// scene file (or the mesh file at fault); anything else is a finding.
// (Why one target per solver: dem_params.cpp.)
//
// Input layout: the scene YAML text; the entry of `solvers:` named "fuzz" is
// set up. Inputs with a '/' in any YAML value are refused unread, so the only
// mesh file a setup opens is the fixture bar.msh; mesh sizes are bounded by
// the solver's own memory check, capped low.
#include <tuple>

#include "cosim/fem/solver/fem_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cosim;
  static const bool prepared = (fuzz::prepareSolverTarget(), true);
  (void)prepared;
  fem::FemSolver solver;
  return fuzz::setUpScene(solver, data, size, {fuzz::kSceneFile, "bar.msh"});
}

namespace cosim::fuzz {

// Seeds: the fem entries of shipped scenes with fewer divisions, and one on
// the Gmsh fixture with the keys no shipped scene uses.
std::vector<std::vector<std::uint8_t>> seeds() {
  const std::vector<std::tuple<std::string, std::string, std::string>> shipped{
      {"configs/fem/cantilever.yaml", "beam", "[1, 6, 1]"},
      {"configs/fem/cantilever_static.yaml", "beam", "[1, 4, 1]"},
      {"configs/fem/bar_wave_explicit.yaml", "bar", "[20, 1, 1]"},
      {"configs/c2/wave_volume_1p.yaml", "fem", "[1, 6, 1]"},
      {"configs/gmh/l3_wave_column.yaml", "column", ""},
      {"configs/gmh/l4_simple_shear.yaml", "block", "[2, 3, 1]"},
  };
  std::vector<std::vector<std::uint8_t>> out;
  for (const auto& [config, name, divisions] : shipped) {
    YAML::Node s = shippedSolver(config, name);
    if (!divisions.empty()) s["params"]["mesh"]["box"]["divisions"] = YAML::Load(divisions);
    out.push_back(sceneWith(s));
  }
  out.push_back(bytesOf(R"(solvers:
  - name: fuzz
    kind: fem
    params:
      mesh: {gmsh: bar.msh}
      material: {model: neo-hookean, E: 1.0e6, nu: 0.3, density: 1000}
      formulation: one-point
      hourglass: {type: viscous, coefficient: 0.1}
      stiffness_damping: 1.0e-4
      boundary:
        - {set: left, dofs: [x, y, z], value: 0.0}
        - {set: right, dofs: [x], value: 0.01, ramp: 0.1}
      loads:
        - {set: right, nodal_force: [0, 0, -1]}
      body_force: [0, 0, -9.81]
      initial_velocity: {velocity: [0, 0, 0.1], origin: [0, 0, 0], gradient: {x: [0, 0, 1]}}
      load_ramp: 0.5
      arlequin: {kind: half-cosine, axis: x, start: 0.5, end: 1.5, w_min: 0.1, w_max: 0.9, fem_weights: nodes}
      integrator: {type: central-difference, mass_scaling: 2, damping: 1}
      coupling: {surfaces: [right], quadrature: setup, zones: {all: {box: {min: [-1, -1, -1], max: [3, 2, 2]}}}}
      output: {every: 1, file: bar.h5}
)"));
  out.push_back(bytesOf(R"(solvers:
  - name: fuzz
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [1, 1, 1], divisions: [2, 2, 2]}}
      material: {model: generalised-hooke, E: 1.0e6, nu: 0.3, density: 1000}
      sets:
        bottom: {box: {min: [-1, -1, -0.01], max: [2, 2, 0.01]}}
      periodic:
        - {min: xmin, max: xmax, offset: [1, 0, 0], jump: [0.01, 0, 0], kind: velocity, ramp: 1}
      boundary:
        - {set: bottom, dofs: [z], value: 0.001, frequency: 10}
      loads:
        - {set: zmax, pressure: 100}
      integrator: {type: dynamic-relaxation, tolerance: 1.0e-6, max_iterations: 100, linear_solver: cg, tangent_reuse: 2}
)"));
  return out;
}

}  // namespace cosim::fuzz
