#pragma once
// The dem_solver process's side of the protocol: a wire::Solver around a DemSystem.
#include <map>
#include <memory>
#include <string>

#include "cosim/dem/cell/unit_cell_worker.hpp"
#include "cosim/dem/dem_system.hpp"
#include "cosim/dem/io/snapshot_writer.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/solver/hybrid_spheres.hpp"
#include "cosim/dem/solver/scene_params.hpp"
#include "cosim/util/energy_balance.hpp"
#include "cosim/wire/solver.hpp"

namespace cosim::dem {

class DemSolver final : public wire::Solver {
 public:
  wire::SolverInfo info() const override;
  void setup(const wire::SetupContext& context, proto::CouplingData::Builder outputs) override;
  void advance(const wire::AdvanceRequest& request, proto::CouplingData::Builder outputs) override;
  /// Names: positions, velocities, angular_velocities, orientations, forces,
  /// radii, masses, ids, energies, coordination, plane_wall_forces, and with a periodic
  /// cell stress (Love-Weber, 9), porosity; unbalanced_force_index (Liu Eq. 57). Empty list = all.
  void fields(const std::vector<std::string>& names, proto::CouplingData::Builder out) override;
  std::uint64_t checkpoint(const std::string& path) override;
  void restore(const std::string& path) override;
  void adoptCells(proto::AdoptCells::Reader request, proto::CouplingData::Builder outputs) override;
  double time() const override { return cells_ ? cells_->time : system_.time; }
  std::uint64_t step() const override { return cells_ ? cells_->steps : system_.step; }
  double criticalDt() const override;
  /// The step the hybrid PD particles' contacts allow (0 without hybrids).
  double hybridCriticalDt() const;
  wire::NamedValues energies() const override;
  std::size_t outputWordsHint() const override { return 2048 + 32 * system_.particles.size(); }
  const HybridSpheres& hybrids() const { return hybrids_; }

  DemSystem& system() { return system_; }
  const RunSettings& settings() const { return settings_; }
  /// The GMH unit cells when params has unit_cells (then system_ is unused), else nullptr.
  UnitCellWorker* unitCells() { return cells_.get(); }

 private:
  void checkDt(double dt, const std::string& where);
  void applyInputs(proto::CouplingData::Reader inputs);
  void applyWeightProfile(proto::CouplingData::Reader inputs);
  void applyHybridParticles(proto::CouplingData::Reader inputs);
  /// skin 0 (no spheres of its own at setup): a fifth of the smallest hybrid radius.
  void defaultSkinFromHybrids();
  void fillOutputs(proto::CouplingData::Builder outputs) const;
  void fillZones(proto::CouplingData::Builder outputs) const;
  void accumulateWallContacts();
  void averageWallContacts(std::uint32_t steps);
  void selectZoneMembers();
  /// params.drives: their zones' particles become driven, at the history's velocity.
  void selectDriveMembers();
  void drive(double dt);
  void checkFinite() const;
  void checkServoWalls(double dt) const;
  /// Throws when the energy balance broke (params.energy_tolerance).
  void checkEnergyBalance(const Energies& e) const;
  DemSystem system_;
  // The run-time stability check (params.energy_tolerance), started at the
  // first energies asked for after setup, a restore or the hybrid particles' arrival.
  mutable util::EnergyBalance energyBalance_;
  mutable bool energyBalanceStarted_ = false;
  mutable double potentialAtStart_ = 0.0;
  bool tookCouplingForces_ = false;  // some exchange brought external forces (named when the balance breaks)
  std::unique_ptr<UnitCellWorker> cells_;  // GMH worker mode (docs/gmh_unit_cells.md)
  std::vector<std::vector<std::uint32_t>> zoneMembers_;  // particle indices per settings_.zones entry
  std::vector<std::size_t> driveZones_;  // the zoneMembers_ entry of each settings_.drives entry
  std::vector<Vec3> referencePositions_;
  std::vector<Vec3> zoneForceSums_;  // per particle, over the last advance; its mean after the advance                 // at setup: displacements are measured from here
  // Wall contacts summed over the sub-steps of one advance, keyed by (particle, triangle)
  // per wall group; reported as their time average (the impulse over the interval).
  std::vector<std::map<std::pair<std::uint32_t, std::uint32_t>, TriangleContact>> contactSums_;
  std::vector<std::vector<TriangleContact>> reported_;
  HybridSpheres hybrids_;  // coupled PD surface particles, driven spheres (Hartmann Sec. 3)
  RunSettings settings_;
  std::string sceneFile_, instance_, runDir_;
  std::unique_ptr<SnapshotWriter> snapshots_;
  double checkedDt_ = 0.0;
  bool ready_ = false;
};

}  // namespace cosim::dem
