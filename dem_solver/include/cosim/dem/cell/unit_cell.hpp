#pragma once
// DEM unit cells for the hierarchical FEM x DEM model (GMH, Liu, Sun, Fish
// 2016 Sec. 2.3): preparation of a periodic, isotropically compressed packing,
// and the unit-cell job (prescribed corotational strain increment, dynamic
// relaxation, homogenised stress) that a GMH worker answers per quadrature point.
#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "cosim/dem/dem_system.hpp"

namespace cosim::dem {

/// What a unit cell reports (Liu Eqs. 44b, 57).
struct CellMeasures {
  std::array<double, 9> stress{};  // Cauchy stress, row-major, tension positive [Pa]
  double pressure = 0.0;           // -tr(stress)/3 [Pa]
  double porosity = 0.0;
  double coordination = 0.0;       // 2 C / N over all spheres (rattlers included)
  double unbalancedForceIndex = 0.0;
};
CellMeasures measureCell(const DemSystem& cell);

/// Random polydisperse packing compressed to an isotropic stress (Liu Sec. 3.1).
struct CellPreparation {
  std::size_t count = 500;
  double dMin = 0.43e-3, dMax = 1.18e-3;    // diameters uniform in [dMin, dMax] [m]
  double shearModulus = 29e9, poisson = 0.15, density = 2650.0;
  double friction = 0.5;
  double contactDamping = 0.12;             // damping ratio of the contact dashpots (Liu Table I)
  double pressure = 416e3;                  // target isotropic stress [Pa]
  double pressureTolerance = 0.01;          // relative, per normal stress component
  double unbalancedTolerance = 0.01;        // Liu Eq. 57
  bool frictionlessCompression = true;      // compress with mu = 0 (denser), then switch mu on
  double initialSolidFraction = 0.25;       // of the random gas the compression starts from
  double massDampingDt = 0.02;              // mass damping c * dt (dynamic relaxation, Liu Sec. 2.3.2)
  double dtFactor = 0.5;                    // dt = factor * critical step (Rayleigh)
  double maxStrainPerStep = 2e-5;           // servo rate limit per axis
  long maxSteps = 2000000;
  std::uint64_t seed = 1;
  /// Called about every progressEvery steps of each servo phase (its
  /// relaxations included) with the phase's steps so far, the mean stress p = -tr(sigma)/3 [Pa] and I_uf:
  /// a 4096-sphere cell takes minutes. Measures only; the packing is the same.
  std::function<void(long steps, double pressure, double unbalancedForceIndex)> progress;
  long progressEvery = 50000;
};

struct PreparationLog {
  long compressionSteps = 0, frictionSteps = 0;
  double dt = 0.0;
  double frictionlessPorosity = 0.0, frictionlessCoordination = 0.0;
};

/// Builds, compresses and relaxes a unit cell. Throws std::runtime_error
/// (naming the parameter) on bad parameters or when maxSteps is exhausted.
DemSystem prepareUnitCell(const CellPreparation& prep, PreparationLog* log = nullptr);

/// Servo on the periodic cell: each normal stress is driven to -pressure by a
/// strain rate proportional to its error (divided by the affine stiffness),
/// relaxed until I_uf < tolerance and every component within pressureTolerance.
/// Returns the steps taken; throws after maxSteps.
long servoToPressure(DemSystem& cell, double dt, const CellPreparation& prep);

/// The servo's relaxation at fixed cell: runs until I_uf < prep's tolerance,
/// the budget is spent, or a stress component leaves ten times prep's
/// pressure tolerance (the packing lost its load; the servo takes over again).
/// afterSlice, if given, gets the steps taken so far after each slice of
/// 5000. Returns the steps taken.
long relaxWhileLoaded(DemSystem& cell, double dt, const CellPreparation& prep, long budget,
                      const std::function<void(long)>& afterSlice = {});

/// A full copy (through the checkpoint format, so histories come along).
DemSystem cloneCell(const DemSystem& cell);

/// Removes `count` spheres chosen at random (seed) and relaxes the cell at
/// fixed shape (the weakened cell of Liu Sec. 3.4). Contact histories restart.
DemSystem weakenedCell(const DemSystem& cell, std::size_t count, std::uint64_t seed, double dt,
                       double tolerance, long maxSteps);

/// Writes base.ckpt (the full dem checkpoint: what unit-cell workers load) and
/// base.h5 (dem snapshot: positions, radii, contacts, plus /cell/h and the measures).
void saveUnitCell(const DemSystem& cell, const std::string& base, double dt);

/// How a unit-cell job is run (Liu Sec. 2.3.2).
struct RelaxSettings {
  double dt = 0.0;              // pseudo-time step of the dynamic relaxation [s]
  double tolerance = 0.01;      // I_uf (Liu Eq. 57)
  long maxSteps = 20000;        // relaxation budget per job
  long loadSteps = 100;         // steps over which the increment is applied
  long checkEvery = 10;         // I_uf is evaluated every so many steps
  double minCoordination = 2.0; // below this a cell has lost its skeleton
  // A failed job (above): false stops the run; true returns the cell's stress
  // as it stands, flagged failed, so the coarse problem can load or unload
  // the cell again (the coupler reports every such job with its numbers).
  bool continueOnFailure = false;
  // A cell that has lost its load (|mean stress| below stressFreePressure)
  // and is still above the tolerance after stressFreeAfter relaxation steps
  // ends its job there, failed: such a cell carries no stress whatever the
  // budget, and spending the budget on it dominated L4 and L5 (0 = off).
  double stressFreePressure = 0.0;  // [Pa]
  long stressFreeAfter = 0;
  bool operator==(const RelaxSettings&) const = default;
};

struct JobOutcome {
  CellMeasures measures;
  long steps = 0;  // load + relaxation steps
  bool relaxed = false;
  bool endedStressFree = false;  // ended early by the stress-free exit (RelaxSettings)
  std::string problem() const;  // empty when the job succeeded under the given settings
  double minCoordination = 0.0, tolerance = 0.0, stressFreePressure = 0.0;
  long budget = 0;
};

/// Applies the strain increment (row-major 3x3, Liu Eq. 60) affinely over
/// loadSteps (L = increment / (loadSteps dt)), then relaxes with L = 0 until
/// I_uf is below the tolerance, the budget is spent, or the stress-free exit
/// ends the job.
JobOutcome runUnitCellJob(DemSystem& cell, const std::array<double, 9>& strainIncrement, const RelaxSettings& settings);

}  // namespace cosim::dem
