#pragma once
// Builds a DemSystem from the `params:` map of a dem solver entry in a scene:
//
//   params:
//     contact: {normal: hertz, tangential: mindlin, damping: restitution}
//     integrator: velocity-verlet        # or leapfrog
//     gravity: [0, 0, -9.81]
//     skin: 0.0005                       # Verlet skin [m] (default 0.2 r_min)
//     dt: 1.0e-6                         # optional: checked against the critical step
//     force: false                       # accept dt above the critical step
//     overlap_tolerance: 0.01            # initial overlap allowed, fraction of the smaller radius
//     energy_tolerance: 0.5              # stop when the energy balance is off by more (share of the largest energy; 0 = off)
//     materials: [{name, density, young, poisson, restitution, friction, kn, kt}]
//     particles:                         # a list of sources
//       - {lattice: {origin, spacing, counts, radius, kind, material, velocity}}
//       - {random: {min, max, radius: [rmin, rmax], count, seed, material}}
//       - {file: {path, material}}
//       - {sphere: {position, radius, velocity, material, driven}}   # driven: moves with velocity
//     walls:
//       - {type: plane, name, point, normal, velocity, mode: fixed|velocity|servo,
//          stress, area, gain, material}     # stress, area, gain: servo only; velocity: velocity only
//       - {type: mesh, name, vertices: [[x,y,z]...], triangles: [[a,b,c]...], velocity, material}
//     periodic: {cell: [[a], [b], [c]], velocity_gradient: [[row], [row], [row]]}
//     hybrid: {material: pd-surface}     # material of coupled hybrid PD particles (default: the first)
//     mass_damping: 0.0                  # c of -c m v (dynamic relaxation)
//     snapshots: {every: 1000, file: particles.h5}   # file needs every > 0
//     zones:                             # particle states sent with every setup/advance reply
//       - {name: all}                    # every particle
//       - {name: overlap, box: {min: [x, y, z], max: [x, y, z]}}   # those starting inside the box
//     drives:                            # a zone's particles moved with a velocity history, not integrated
//       - {zone: left, velocity: {kind: cosine-pulse, amplitude: [0, 0.05, 0], omega: 1950, cycles: 1}}
//       - {zone: lid, velocity: {kind: constant, value: [0, 0, -0.1]}}
#include <yaml-cpp/yaml.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "cosim/dem/dem_system.hpp"
#include "cosim/dem/drive/velocity_history.hpp"

namespace cosim::dem {

/// A set of particles whose states (ParticleStates) go out with every reply,
/// chosen by their initial positions: what couplings and analyses read.
struct ExportZone {
  std::string name;
  bool boxed = false;
  Vec3 lo, hi;
};

struct RunSettings {
  double dt = 0.0;
  bool force = false;
  double overlapTolerance = 0.01;
  double energyTolerance = 0.5;  // util::EnergyBalance tolerance (0 = off)
  bool skinGiven = false;         // params.skin set (else kDefaultSkinPerRadius x the smallest radius)
  long snapshotEvery = 0;
  std::string snapshotFile;
  std::vector<ExportZone> zones;
  std::vector<DriveSpec> drives;     // params.drives, by zone
  std::uint16_t hybridMaterial = 0;  // material of hybrid PD particles (params.hybrid.material)
  double hybridWatchMargin = -1.0;   // params.hybrid.watch_margin [m]: < 0 default, 0 off (hybrid_watch.hpp)
};

/// Finds the `solvers:` entry named instance in the scene text; throws SceneError.
YAML::Node findSolverParams(const std::string& sceneYaml, const std::string& sceneFile, const std::string& instance);
/// Fills system (before initialize()) and settings from a params map.
/// Relative particle files resolve against `baseDir` (empty: sceneFile's directory), then as given.
void configure(const YAML::Node& params, const std::string& sceneFile, DemSystem& system, RunSettings& settings,
               const std::string& baseDir = "");
/// Checks radii, densities, finiteness and initial overlaps; throws naming the particle.
void checkParticles(const DemSystem& system, double overlapTolerance, const std::string& context);
/// Spheres reaching into a plane wall by more than overlapTolerance x their radius; throws naming both.
void checkPlaneOverlaps(const DemSystem& system, double overlapTolerance, const std::string& context);

/// A neighbour pair overlapping by more than overlapTolerance x the smaller radius.
struct ExcessOverlap {
  std::uint32_t i = 0, j = 0;  // particle indices
  double overlap = 0.0, allowed = 0.0;
};
/// The first such pair among those `considered` (all when empty) in the
/// neighbour list, which leaves out excluded pairs (bonds, PD families).
std::optional<ExcessOverlap> excessOverlap(const DemSystem& system, double overlapTolerance,
                                           const std::function<bool(std::uint32_t, std::uint32_t)>& considered = {});

}  // namespace cosim::dem
