// Fuzz target: dem_solver's restore from a checkpoint file, as `coupler run
// --resume` asks for it: a GMH unit-cell worker's checkpoint or a plain DEM
// one (the system with its neighbour list, walls, bonds and contact
// histories, then the hybrid PD particles), and one step from the restored
// state, as the resumed run takes next. A bad file must end in a
// wire::SolverError whose message names the file; an error of the step after
// a restore that was accepted must be a SolverError too. Anything else is a
// finding.
//
// Input layout: the checkpoint bytes, written to dem.chk in the scratch directory.
#include <capnp/message.h>

#include "cosim/dem/solver/dem_solver.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

using namespace cosim;

constexpr const char* kFile = "dem.chk";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool prepared = (fuzz::prepareSolverTarget(), true);
  (void)prepared;
  if (size > fuzz::kMaxInputBytes) return -1;
  dem::DemSolver solver;
  fuzz::resume(solver, data, size, kFile, 1e-9);
  return 0;
}

namespace cosim::fuzz {
namespace {

// Four PD surface particles, as pd_solver sends them at its first exchange.
void hybridParticles(proto::CouplingData::Builder data) {
  auto h = data.initHybridParticles(1)[0];
  constexpr unsigned n = 4;
  h.setSerial(1);
  auto ids = h.initIds(n), bodies = h.initBodyIds(n);
  auto ref = h.initReferencePositions(3 * n), x = h.initPositions(3 * n), v = h.initVelocities(3 * n);
  auto radii = h.initRadii(n);
  for (unsigned k = 0; k < n; ++k) {
    ids.set(k, 10 + k);
    bodies.set(k, 0);
    radii.set(k, 0.0005);
    for (unsigned d = 0; d < 3; ++d) {
      const double at = d == 0 ? 0.001 * k : 0.05;
      ref.set(3 * k + d, at);
      x.set(3 * k + d, at);
      v.set(3 * k + d, 0.0);
    }
  }
  h.initHorizons(1).set(0, 0.0015);
}

Bytes checkpointOf(wire::Solver& solver) {
  const auto path = scratchDir() / "seed.chk";
  solver.checkpoint(path.string());
  return readBytes(path);
}

Bytes afterSteps(std::string_view scene, std::uint32_t steps, double dt) {
  dem::DemSolver solver;
  setUp(solver, scene);
  if (steps > 0) advance(solver, steps, dt);
  return checkpointOf(solver);
}

}  // namespace

// Seeds: checkpoints the solver itself writes: of shipped scenes (small) after
// a few steps, of a periodic bonded cell, of a DEM side with hybrid PD
// particles, and of a unit-cell worker holding two copies of that cell.
std::vector<std::vector<std::uint8_t>> seeds() {
  prepareSolverTarget();
  std::vector<std::vector<std::uint8_t>> out;
  const auto hertz = sceneWith(shippedSolver("configs/dem/hertz_collision.yaml", "particles"));
  out.push_back(afterSteps(std::string(hertz.begin(), hertz.end()), 0, 0.0));
  out.push_back(afterSteps(std::string(hertz.begin(), hertz.end()), 500, 5e-8));
  YAML::Node walls = shippedSolver("configs/dem/settling.yaml", "particles");
  walls["params"]["particles"][0]["lattice"]["counts"] = YAML::Load("[2, 2, 2]");
  walls["params"].remove("snapshots");
  walls["params"]["walls"].push_back(YAML::Load(
      "{type: mesh, name: plate, vertices: [[0, 0, 0.01], [0.05, 0, 0.01], [0, 0.05, 0.01]], triangles: [[0, 1, 2]]}"));
  const auto wallScene = sceneWith(walls);
  out.push_back(afterSteps(std::string(wallScene.begin(), wallScene.end()), 20, 1e-5));
  const char* const cell = R"(solvers:
  - name: fuzz
    kind: dem
    params:
      particles:
        - lattice: {origin: [0.00125, 0.00125, 0.00125], spacing: 0.0021, counts: [3, 3, 3], radius: 0.001}
      periodic: {cell: [[0.0063, 0, 0], [0, 0.0063, 0], [0, 0, 0.0063]], velocity_gradient: [[0, 0, 0.1], [0, 0, 0], [0, 0, 0]]}
      bonds: {stiffness: 1.0e3, neighbours: 1.1}
      mass_damping: 100
)";
  out.push_back(afterSteps(cell, 3, 1e-7));
  writeScratch("cell.ckpt", out.back().data(), out.back().size());
  out.push_back(afterSteps(R"(solvers:
  - name: fuzz
    kind: dem
    params:
      unit_cells: {file: cell.ckpt, first_id: 3, count: 2, max_steps: 10}
)", 0, 0.0));
  {
    dem::DemSolver solver;
    setUp(solver, R"(solvers:
  - name: fuzz
    kind: dem
    params:
      materials: [{name: pd-surface, density: 1000, young: 1.0e7, poisson: 0.3}]
      hybrid: {material: pd-surface}
      particles:
        - sphere: {position: [0.0015, 0.05, 0.0512], radius: 0.0007, velocity: [0, 0, -0.1]}
)");
    capnp::MallocMessageBuilder inputs;
    auto data = inputs.initRoot<proto::CouplingData>();
    hybridParticles(data);
    advance(solver, 2, 1e-7, data.asReader());
    out.push_back(checkpointOf(solver));
  }
  return out;
}

}  // namespace cosim::fuzz
