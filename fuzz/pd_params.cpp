// Fuzz target: pd_solver's setup from a scene, what `pd_solver --check` does
// with the setup message `coupler check` writes: the params read (bodies of
// every shape with their models and materials, boundary conditions, loads,
// integrator, quasi-static relaxation, output), the system built (lattices,
// bonds, critical steps), the hybrid surface particles found and the setup
// reply filled. A bad params section must end in a wire::SolverError whose
// message names the scene file (or the point file at fault); anything else
// is a finding. (Why one target per solver: dem_params.cpp.)
//
// Input layout: the scene YAML text; the entry of `solvers:` named "fuzz" is
// set up. Inputs with a '/' in any YAML value are refused unread, so the only
// point file a setup opens is the fixture points.txt; body sizes are bounded
// by the solver's own memory check, capped low.
#include "cosim/pd/pd_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cosim;
  static const bool prepared = (fuzz::prepareSolverTarget(), true);
  (void)prepared;
  pd::PdSolver solver;
  return fuzz::setUpScene(solver, data, size, {fuzz::kSceneFile, "points.txt"});
}

namespace cosim::fuzz {

// Seeds: the pd entries of shipped scenes with their bodies made small (and
// the boundary boxes moved with the bodies' faces), and one with the shapes,
// models and keys no shipped scene uses.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  {
    YAML::Node s = shippedSolver("configs/pd/wave_bar.yaml", "bar");
    s["params"]["bodies"][0]["spacing"] = 0.0025;
    s["params"]["boundary"][0]["select"]["max"] = YAML::Load("[0.002, 1, 1]");
    out.push_back(sceneWith(s));
  }
  for (const char* config : {"configs/h1/pd_dem_hertz_lps.yaml", "configs/h1/pd_dem_hertz_pmb.yaml"}) {
    YAML::Node s = shippedSolver(config, "block");
    s["params"]["bodies"][0]["max"] = YAML::Load("[0.09, 0.09, 0.045]");
    s["params"]["boundary"][2]["select"]["min"] = YAML::Load("[0.0824, -1, -1]");
    s["params"]["boundary"][4]["select"]["min"] = YAML::Load("[-1, 0.0824, -1]");
    out.push_back(sceneWith(s));
  }
  {
    YAML::Node s = shippedSolver("configs/h2/pd_dem_multirate.yaml", "plate");
    s["params"]["bodies"][0]["max"] = YAML::Load("[0.1, 0.1, 0.04]");
    out.push_back(sceneWith(s));
  }
  {
    YAML::Node s = shippedSolver("configs/h3/pd_cube.yaml", "cube");
    s["params"]["bodies"][0]["max"] = YAML::Load("[0.06, 0.06, 0.06]");
    s["params"]["boundary"][0]["select"] = YAML::Load("{body: cube, min: [0.02, 0.02, 0.02], max: [0.04, 0.04, 0.04]}");
    out.push_back(sceneWith(s));
  }
  {
    YAML::Node s = shippedSolver("configs/h5/pd_sphere_pack.yaml", "pack");
    YAML::Node first = YAML::Clone(s["params"]["bodies"][0]);
    first["spacing"] = 0.075;
    s["params"]["bodies"] = YAML::Load("[]");
    s["params"]["bodies"].push_back(first);
    out.push_back(sceneWith(s));
  }
  out.push_back(bytesOf(R"(solvers:
  - name: fuzz
    kind: pd
    params:
      bodies:
        - {name: rod, shape: cylinder, center: [0, 0, 0.01], radius: 0.002, length: 0.006, axis: x, spacing: 0.001,
           horizon: 2.5, model: pmb, critical_stretch: 0.01, micromodulus: discrete, partial_volume: truncated,
           material: {E: 1.0e9, nu: 0.25, rho: 1000}, velocity: [0, 0, 0.1]}
        - {name: cloud, shape: points, file: points.txt, horizon: 2, model: lps, influence: gaussian,
           material: {E: 1.0e9, nu: 0.3, rho: 1000}}
      boundary:
        - {select: {body: rod, min: [-1, -1, -1], max: [-0.0015, 1, 1]}, type: velocity, velocity: [0.1, 0, 0]}
        - {select: {body: cloud}, type: normal}
      loads:
        - {select: {min: [0, 0, 0], max: [1, 1, 1]}, force: [0, 0, -1]}
      body_force: [0, 0, -9.81]
      integrator: staggered
      inputs: interpolate
      force: true
      work_ahead: false
      critical_step: measured
      energy_tolerance: 0.1
      quasi_static: {tolerance: 1.0e-5, max_iterations: 50}
      output: {file: pd.h5, every: 2}
)"));
  return out;
}

}  // namespace cosim::fuzz
