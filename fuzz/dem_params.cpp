// Fuzz target: dem_solver's setup from a scene, what `dem_solver --check`
// does with the setup message `coupler check` writes: the solver entry found
// in the scene text, its params read (materials, particle sources, walls,
// periodic cell, bonds, zones, drives, hybrid, snapshots, or GMH unit cells),
// the system initialised and checked, the setup reply filled. A bad params
// section must end in a wire::SolverError whose message names the scene file
// (or the particle or cell file at fault); anything else, a message that
// names no file included, is a finding.
//
// One target per solver (dem_params, fem_params, pd_params) rather than one
// picking the solver by a byte: each solver's corpus and coverage stay its
// own, and a seed of one solver is never spent mutating into another's keys.
//
// Input layout: the scene YAML text; the entry of `solvers:` named "fuzz" is
// set up. Inputs with a '/' in any YAML value are refused unread, so the files
// a setup opens are the fixtures of the scratch directory (particles.csv,
// cell.ckpt); sizes are bounded by the solver's own memory check, capped low.
#include <capnp/message.h>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/solver/dem_solver.hpp"
#include "cosim/dem/solver/scene_params.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

// A periodic cell of 27 spheres as dem_prepare_cell writes one: the file the
// unit_cells seeds name.
const char* const kCellParams = R"(
particles:
  - lattice: {origin: [0.00125, 0.00125, 0.00125], spacing: 0.0025, counts: [3, 3, 3], radius: 0.001}
periodic: {cell: [[0.0075, 0, 0], [0, 0.0075, 0], [0, 0, 0.0075]]}
mass_damping: 100
)";

void writeCellFixture() {
  dem::DemSystem cell;
  dem::RunSettings settings;
  dem::configure(YAML::Load(kCellParams), "cell.yaml", cell, settings);
  cell.initialize();
  dem::writeCheckpoint(cell, (fuzz::scratchDir() / "cell.ckpt").string());
}

void prepare() {
  static const bool done = [] {
    fuzz::prepareSolverTarget();
    writeCellFixture();
    return true;
  }();
  (void)done;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  prepare();
  dem::DemSolver solver;
  return fuzz::setUpScene(solver, data, size, {fuzz::kSceneFile, "particles.csv", "cell.ckpt"});
}

namespace cosim::fuzz {

// Seeds: the dem entries of shipped scenes (made small where they are
// large), and entries for what no shipped scene uses: a particle file, a
// random packing, a triangle-mesh wall, a periodic cell, a servo wall.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  out.push_back(sceneWith(shippedSolver("configs/dem/hertz_collision.yaml", "particles")));
  out.push_back(sceneWith(shippedSolver("configs/c1/cantilever_surface.yaml", "particles")));
  {
    YAML::Node s = shippedSolver("configs/dem/settling.yaml", "particles");
    s["params"]["particles"][0]["lattice"]["counts"] = YAML::Load("[3, 3, 3]");
    out.push_back(sceneWith(s));
  }
  {
    YAML::Node s = shippedSolver("configs/c2/wave_full_dem_1p.yaml", "dem");
    s["params"]["particles"][1]["lattice"]["counts"] = YAML::Load("[2, 4, 2]");
    s["params"]["zones"][1]["box"] = YAML::Load("{min: [-1, 1.5, -1], max: [1, 2, 1]}");
    out.push_back(sceneWith(s));
  }
  out.push_back(sceneWith(shippedSolver("configs/h4/pd_squeeze.yaml", "spheres")));
  {
    YAML::Node s = shippedSolver("configs/gmh/l2_shear.yaml", "cells");
    s["params"]["unit_cells"]["file"] = "cell.ckpt";
    s["params"]["unit_cells"]["count"] = 2;
    s["params"]["unit_cells"]["max_steps"] = 100;
    out.push_back(sceneWith(s));
  }
  const char* const handMade[] = {
      R"(solvers:
  - name: fuzz
    kind: dem
    params:
      materials: [{name: a, density: 2500, young: 1.0e7, poisson: 0.3}]
      particles:
        - file: {path: particles.csv, material: a, velocity: [0, 0, 1]}
        - random: {min: [0.01, 0, 0], max: [0.02, 0.01, 0.01], radius: [0.001, 0.0015], count: 5, seed: 3}
      walls:
        - {type: mesh, name: plate, vertices: [[-1, -1, -0.01], [1, -1, -0.01], [0, 1, -0.01]], triangles: [[0, 1, 2]], velocity: [0, 0, 0.1]}
        - {type: plane, name: lid, point: [0, 0, 0.05], normal: [0, 0, -1], mode: servo, stress: 1000, area: 0.01, gain: 0.001}
      dt: 1.0e-7
      energy_tolerance: 0
)",
      R"(solvers:
  - name: fuzz
    kind: dem
    params:
      contact: {normal: linear, tangential: linear, damping: restitution}
      integrator: leapfrog
      materials: [{name: a, kn: 1.0e4, kt: 5.0e3, restitution: 0.5, friction: 0.4}]
      particles:
        - lattice: {origin: [0.00125, 0.00125, 0.00125], spacing: 0.004, counts: [2, 2, 2], radius: 0.001, kind: fcc, jitter: 0.2, seed: 4}
      periodic: {cell: [[0.01, 0, 0], [0, 0.01, 0], [0.001, 0, 0.01]], velocity_gradient: [[0, 0, 0.1], [0, 0, 0], [0, 0, 0]]}
      bonds: {stiffness: 1.0e3, neighbours: 1.5}
      zones: [{name: all}, {name: low, box: {min: [0, 0, 0], max: [0.01, 0.01, 0.003]}}]
      drives: [{zone: low, velocity: {kind: cosine-pulse, amplitude: [0, 0.05, 0], omega: 1950, cycles: 1}}]
      hybrid: {material: a, watch_margin: 0.0001}
      skin: 0.0002
)",
  };
  for (const char* text : handMade) out.push_back(bytesOf(text));
  return out;
}

}  // namespace cosim::fuzz
