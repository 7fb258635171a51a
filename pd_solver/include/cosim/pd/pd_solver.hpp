#pragma once
// PdSolver: the peridynamics solver behind the wire's Solver interface.
#include <memory>
#include <string>
#include <vector>

#include "cosim/util/energy_balance.hpp"
#include "cosim/pd/hybrid_watch.hpp"
#include "cosim/pd/scene.hpp"
#include "cosim/pd/snapshot.hpp"
#include "cosim/pd/system.hpp"
#include "cosim/wire/solver.hpp"

namespace cosim::pd {

class PdSolver final : public cosim::wire::Solver {
 public:
  cosim::wire::SolverInfo info() const override;
  void setup(const cosim::wire::SetupContext& context, cosim::proto::CouplingData::Builder outputs) override;
  void advance(const cosim::wire::AdvanceRequest& request, cosim::proto::CouplingData::Builder outputs) override;
  void fields(const std::vector<std::string>& names, cosim::proto::CouplingData::Builder out) override;
  std::uint64_t checkpoint(const std::string& path) override;
  void restore(const std::string& path) override;
  double time() const override;
  std::uint64_t step() const override;
  double criticalDt() const override;
  cosim::wire::NamedValues energies() const override;
  std::size_t outputWordsHint() const override;
  /// After a one-step advance with the end-of-step coupling force: the next
  /// step's half kick, drift and bond forces (PdSystem::lookAhead), which do
  /// not depend on the force DEM evaluates meanwhile. The next advance with
  /// the same dt completes that step; any other request takes it back first.
  bool workAhead() override;

  PdSystem& system() { return system_; }
  const std::vector<std::uint32_t>& hybridParticles() const { return hybrid_; }
  /// Field names fields() offers.
  static const std::vector<std::string>& fieldNames();

 private:
  void requireSetup(const char* what) const;
  /// Hybrid forces by particle into `into`; with `linearised`, also the
  /// stiffness sent with them (cleared first; empty when none was sent).
  void readHybridForces(cosim::proto::CouplingData::Reader data, std::vector<double>& into,
                        std::vector<PdSystem::LinearisedCoupling>* linearised) const;
  /// Hybrid surface particles' states; with the set (ids, bodies, reference
  /// positions, radii, horizons) at setup and in fields, after an advance
  /// only positions and velocities in the set's order (pddem.capnp). An
  /// exchange's message (serial = exchange + 1; 0 for fields) counts for the
  /// hybrid watch and holds the watched states alone where it may.
  void writeHybrid(cosim::proto::CouplingData::Builder out, bool withSet, std::uint64_t serial);
  /// The hybrid watch fields of DEM's replies.
  void receiveWatch(cosim::proto::CouplingData::Reader data);
  /// Whether an advance of `steps` Verlet steps applies the received coupling
  /// force from after its drift (one step, force held: the end-of-step force).
  bool endOfStepCoupling(std::uint32_t steps, bool interpolate) const;
  /// How the critical step was found, for messages.
  std::string criticalStepRule() const;
  void checkFinite() const;
  /// Starts the energy balance from the current state (setup, restore).
  void startEnergyBalance();

  PdConfig config_;
  PdSystem system_;
  std::vector<std::uint32_t> hybrid_;
  std::vector<double> hybridHorizon_;  // per body
  HybridWatch watch_;
  std::vector<double> hybridX_, hybridV_;  // every hybrid's position and drift velocity, 3 each
  std::vector<double> forcesStart_, forcesEnd_;  // an interpolating advance's received forces, 3 per particle
  std::unique_ptr<SnapshotWriter> snapshots_;
  std::uint64_t advances_ = 0;
  double lastDt_ = 0.0;
  bool mayWorkAhead_ = false;  // the last advance was one step with the end-of-step coupling
  // Checked whenever energies are asked for; the check keeps the largest energy seen.
  mutable util::EnergyBalance energyBalance_;
  bool ready_ = false;
};

}  // namespace cosim::pd
