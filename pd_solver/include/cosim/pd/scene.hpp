#pragma once
// The pd_solver's `params:` section of a scene, read with yaml-cpp. Errors are
// std::invalid_argument "<sceneFile>:<line>: message" naming the key or body.
#include <cstdint>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "cosim/pd/system.hpp"

namespace cosim::pd {

/// Fraction of the measured Verlet limit 2 / omega_max a measured critical
/// step keeps: power iteration approaches omega_max from below, and large
/// strains and contacts stiffen the body (docs/pd.md, "Measured critical step").
constexpr double kMeasuredStepSafety = 0.9;

struct PdConfig {
  std::vector<BodySpec> bodies;
  std::vector<int> bodyLines;  // scene line of each body entry
  std::vector<BoundaryCondition> boundaries;
  std::vector<int> boundaryLines;  // scene line of each boundary entry
  std::vector<AppliedLoad> loads;
  std::vector<int> loadLines;      // scene line of each load entry
  Vec3 bodyForce{};
  bool staggered = false;    // integrator: staggered (Hartmann Eq. 47) | verlet
  bool interpolate = false;  // inputs: interpolate | hold
  bool force = false;        // accept dt above the critical step
  /// work_ahead: after an advance's reply, compute the next step's half kick,
  /// drift and bond forces while the coupler and DEM work (Solver::workAhead);
  /// results are bitwise the same either way.
  bool workAhead = true;
  /// critical_step: rule (0.45 delta / c_p) | measured (kMeasuredStepSafety x
  /// 2 / omega_max of each body, power iteration at setup; critical_step.cpp)
  bool measuredCriticalStep = false;
  double energyTolerance = 0.5;  // EnergyBalance tolerance (0 = off)
  bool hybrid = true;        // export hybrid surface particles
  bool quasiStatic = false;  // advance = adaptive dynamic relaxation to equilibrium
  double relaxTolerance = 1e-6;
  std::size_t relaxMaxIterations = 100000;
  std::string outputFile;    // HDF5 snapshots (relative to the run directory)
  std::uint64_t outputEvery = 0;  // snapshot every N advance requests (0 = never)
};

PdConfig parsePdParams(const YAML::Node& params, const std::string& sceneFile,
                       const std::string& baseDir);

/// Builds (and finalises) a system from a config; errors of a body, boundary
/// or load entry name its line (and `boundary[i]` / `loads[i]`).
void buildSystem(const PdConfig& config, PdSystem& system, const std::string& sceneFile);

}  // namespace cosim::pd
