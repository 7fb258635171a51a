#pragma once
// A coupling takes the latest outputs of the solvers it joins and stages the
// inputs of their next advance. Each kind is one class registered by the name
// scenes use (`kind: direct-transfer` ...), so a new coupling is a new file.
#include <map>
#include <ostream>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "cosim/coupler/analysis/solver_energies.hpp"
#include "cosim/util/registry.hpp"
#include "cosim/util/weight_profile.hpp"
#include "data.capnp.h"

namespace cosim::io {
class SeriesWriter;
}
namespace cosim::util {
class BinaryWriter;
class BinaryReader;
}
namespace cosim::config {
class MapReader;
}

namespace cosim::coupler {

struct SolverSpec;
struct RunReport;

/// The inputs of one solver's next request, as views into data that stays
/// alive until the request is built: replies of the last exchange, or
/// buffers the coupling owns. The coupler clears every assembler before the
/// couplings run, so each exchange stages its inputs afresh.
class InputAssembler {
 public:
  struct StagedArray {
    std::string name;
    std::uint32_t components = 1;
    std::span<const double> values;
  };
  struct StagedMesh {  // a TriangleMeshKinematics (surface.capnp)
    std::string surface;
    std::span<const double> positions, velocities;
    std::span<const std::uint32_t> triangles;  // empty = unchanged since the last send
  };
  struct StagedForces {  // a CouplingForces (volume.capnp)
    std::string zone;
    proto::CouplingForces::Target target = proto::CouplingForces::Target::NODES;
    std::span<const std::uint32_t> ids;
    std::span<const double> forces;  // 3 per id
  };
  struct StagedUnitCellJobs {  // a UnitCellJobs (gmh.capnp)
    std::span<const std::uint32_t> cellIds;
    std::span<const double> strainIncrements;  // 9 per cell
    double dt = 0.0;
  };
  struct StagedUnitCellResults {  // a UnitCellResults (gmh.capnp)
    std::span<const std::uint32_t> cellIds;
    std::span<const double> stresses;  // 9 per cell
    std::span<const double> porosities, coordinationNumbers, unbalancedForceIndices;
    std::span<const std::uint32_t> relaxationSteps;
  };
  struct StagedHybridParticles {  // a HybridParticles (pddem.capnp)
    std::span<const std::uint32_t> ids, bodyIds;
    std::span<const double> referencePositions, positions, velocities, radii, horizons;
    bool wantStiffness = false;  // ask DEM for the contact stiffness with its forces
    // The hybrid watch (pddem.capnp): PD's message serial and, for partial
    // states, the set positions they are of and the full message they rest on.
    std::uint64_t serial = 0, watchBasis = 0;
    bool partial = false;
    std::span<const std::uint32_t> indices = {};
  };
  struct StagedHybridWatch {  // the watch fields of a HybridForces (pddem.capnp)
    bool watchSet = false, sendAll = false;
    std::span<const std::uint32_t> watched = {};
    double margin = 0.0, interval = 0.0;
    std::uint64_t basis = 0;
  };
  struct StagedHybridForces {  // a HybridForces (pddem.capnp)
    std::span<const std::uint32_t> ids;
    std::span<const double> forces;  // 3 per id
    std::span<const double> positions = {}, stiffness = {};  // 3 and 6 per id, or empty (held forces)
    StagedHybridWatch watch = {};
  };
  void stageArray(std::string name, std::uint32_t components, std::span<const double> values);
  void stageUnitCellJobs(StagedUnitCellJobs jobs) { jobs_.push_back(jobs); }
  void stageUnitCellResults(StagedUnitCellResults results) { results_.push_back(results); }
  void stageMesh(StagedMesh mesh) { meshes_.push_back(std::move(mesh)); }
  void stageForces(StagedForces forces) { forces_.push_back(std::move(forces)); }
  void stageWeightProfile(util::WeightProfile profile) { profiles_.push_back(std::move(profile)); }
  void stageHybridParticles(StagedHybridParticles hybrid) { hybridParticles_.push_back(hybrid); }
  void stageHybridForces(StagedHybridForces forces) { hybridForces_.push_back(forces); }
  const std::vector<StagedHybridParticles>& hybridParticles() const { return hybridParticles_; }
  const std::vector<StagedHybridForces>& hybridForces() const { return hybridForces_; }
  const std::vector<StagedArray>& arrays() const { return arrays_; }
  const std::vector<StagedMesh>& meshes() const { return meshes_; }
  const std::vector<StagedForces>& forces() const { return forces_; }
  /// Copies everything staged into a request's CouplingData and forgets it.
  void build(proto::CouplingData::Builder data);
  std::size_t words() const;
  void clear();

 private:
  void buildUnitCells(proto::CouplingData::Builder data) const;
  std::vector<StagedArray> arrays_;
  std::vector<StagedMesh> meshes_;
  std::vector<StagedForces> forces_;
  std::vector<util::WeightProfile> profiles_;  // WeightProfile (volume.capnp), by value
  std::vector<StagedUnitCellJobs> jobs_;
  std::vector<StagedUnitCellResults> results_;
  std::vector<StagedHybridParticles> hybridParticles_;
  std::vector<StagedHybridForces> hybridForces_;
  void buildHybrid(proto::CouplingData::Builder data) const;
};

/// Work a lost participant held, for another participant to take over
/// (session.capnp AdoptCells): the unit cells, whose checkpoint holds them,
/// and the jobs they were sent since that checkpoint, oldest first.
struct CellAdoption {
  std::string adopter;  // the participant that takes them
  std::string source;   // the participant whose file in the latest checkpoint holds them
  std::vector<std::uint32_t> ids;
  std::vector<InputAssembler::StagedUnitCellJobs> jobs;  // views into the coupling's record of its jobs
  bool answersNow = false;  // the last jobs are the ones the lost participant owed in this exchange
};

struct ExchangeContext {
  std::uint64_t exchange = 0;  // 0 = the outputs of setup
  double time = 0.0;
  const std::map<std::string, proto::CouplingData::Reader>& outputs;  // by solver name
  std::map<std::string, InputAssembler>& inputs;                      // by solver name
  io::SeriesWriter* series = nullptr;                                  // null in `coupler check`
  /// Energies of each solver's latest reply, by solver name (null in `coupler check`).
  const SolverEnergies* energies = nullptr;
  /// Solvers whose outputs are new since the couplings last ran (all of them at setup; a
  /// staggered schedule advances some solvers per exchange).
  std::set<std::string> advanced = {};
  /// The outputs are the replies a checkpoint kept, restaged when a run resumes
  /// (they came from the solver processes before it).
  bool replay = false;
  bool isNew(const std::string& solver) const { return advanced.count(solver) > 0; }
};

class Coupling {
 public:
  explicit Coupling(std::string name) : name_(std::move(name)) {}
  virtual ~Coupling() = default;
  const std::string& name() const { return name_; }
  virtual std::string kind() const = 0;
  /// Solver instances this coupling joins.
  virtual std::vector<std::string> participants() const = 0;
  /// Capabilities it needs from one participant.
  virtual std::vector<std::string> requiredCapabilities(const std::string& solver) const = 0;
  /// One line for `coupler check`.
  virtual void describe(std::ostream& out) const = 0;
  /// Stages what the participants need at setup (weight profiles ...), sent with the setup request.
  virtual void stageSetup(std::map<std::string, InputAssembler>& /*inputs*/) const {}
  /// Maps outputs to inputs; records what it wants under /series/<name>.
  virtual void exchange(ExchangeContext& context) = 0;
  /// The solvers' setup outputs: the reference configuration. Called once after
  /// setup, also when a run resumes (before the checkpoint's replies replace
  /// them), so what a coupling derives from it is the same in both.
  virtual void setupReference(const std::map<std::string, proto::CouplingData::Reader>& /*outputs*/) {}
  /// What the run loses with a participant that died or hung (e.g. the unit
  /// cells a worker held), for the message that stops the run; empty if nothing.
  virtual std::string describeLoss(const std::string& /*solver*/) const { return {}; }
  /// Whether the run can go on without this participant, its work moved to
  /// the others (gmh with on_worker_loss: move).
  virtual bool canHandOver(const std::string& /*lost*/) const { return false; }
  /// Moves the lost participant's work to the others: from now on the
  /// coupling counts on them instead. `exchange` is the exchange whose
  /// requests are out; the adoptions replay the work since the latest
  /// checkpoint up to it. Throws std::runtime_error when it cannot.
  virtual std::vector<CellAdoption> handOver(const std::string& lost, std::uint64_t /*exchange*/) {
    throw std::runtime_error("coupling '" + name() + "' cannot go on without '" + lost + "'");
  }
  /// A checkpoint was taken after this exchange (or a run resumed from it):
  /// what a hand-over replays starts after it.
  virtual void checkpointTaken(std::uint64_t /*exchange*/) {}
  /// Lowers the participants' critical steps by the stiffness the coupling
  /// adds (penalty springs), after setupReference; what `dt: auto` uses.
  virtual void limitCriticalSteps(std::map<std::string, double>& /*criticalDt*/) const {}
  /// Adds the coupling's own figures to the run report at its end (the peers'
  /// timings and critical steps are in it already).
  virtual void conclude(RunReport& /*report*/) const {}
  /// Whether exchange() reads ctx.energies (they are asked for only then, or
  /// when a series row is written).
  virtual bool usesEnergies() const { return false; }
  /// What the coupling has counted over the run for its report (failed
  /// unit-cell jobs ...), into every checkpoint and back on a resume, so a
  /// resumed run reports the uninterrupted run's figures. What it derives
  /// from the solvers' replies comes back with the replay of the checkpoint's
  /// replies instead; couplings without such counts keep no state.
  virtual bool keepsState() const { return false; }
  virtual void save(util::BinaryWriter& /*out*/) const {}
  virtual void restore(util::BinaryReader& /*in*/) {}

 private:
  std::string name_;
};

/// Reads a key that names a declared solver (reporting a dangling reference at its line).
std::string requireSolverName(config::MapReader& m, const std::string& key, const std::vector<SolverSpec>& solvers);

/// Factories read their own keys from the coupling's map (name and kind are
/// already read) and may check solver names against the scene's solvers.
using CouplingRegistry = Registry<Coupling, const std::string&, config::MapReader&, const std::vector<SolverSpec>&>;

}  // namespace cosim::coupler
