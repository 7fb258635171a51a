#pragma once
// A scene's reference solution and error metric (DESIGN.md 6.4): it watches
// the solvers' outputs and energies every exchange, may end the run when the
// scene's physics is over (particles left the beam ...), and puts its error
// and figures into the run report. One class per file, registered by the
// name scenes use under `analysis: {reference: <name>, ...}`.
#include <map>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "cosim/coupler/analysis/run_report.hpp"
#include "cosim/coupler/analysis/solver_energies.hpp"
#include "cosim/util/registry.hpp"
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

struct Observation {
  std::uint64_t exchange = 0;  // 0 = the outputs of setup
  double time = 0.0;
  const std::map<std::string, proto::CouplingData::Reader>& outputs;        // by solver name
  const SolverEnergies& energies;                                           // by solver name
  io::SeriesWriter* series = nullptr;
};

class Reference {
 public:
  virtual ~Reference() = default;
  virtual std::string kind() const = 0;
  virtual void describe(std::ostream& out) const = 0;
  /// Capabilities it needs from one solver (outputs it reads).
  virtual std::vector<std::string> requiredCapabilities(const std::string& solver) const = 0;
  virtual void observe(const Observation& o) = 0;
  /// True when the run has nothing left to show (the schedule stops early).
  virtual bool finished() const { return false; }
  /// Whether observe() reads the solvers' energies at every exchange (they
  /// are asked for only then, or when a series row is written).
  virtual bool usesEnergies() const { return true; }
  /// Adds the error metric (first) and the scene's figures to the report.
  virtual void conclude(RunReport& report) const = 0;
  /// What it has gathered so far, into a checkpoint, and back on a resume:
  /// a resumed run observes only the exchanges after its checkpoint, so its
  /// error and figures are the uninterrupted run's only with this state.
  virtual void save(util::BinaryWriter& out) const = 0;
  virtual void restore(util::BinaryReader& in) = 0;
};

/// The particle states a DEM solver sent for one of its zones (params.zones);
/// throws naming the solver and zone when it sent none.
proto::ParticleStates::Reader zoneStates(const Observation& o, const std::string& solver, const std::string& zone);

/// A run's record over time: `perTime` values per entry of `times`.
struct TimeRecord {
  std::vector<double> times, values;
  std::size_t perTime = 1;
  void append(double t, std::span<const double> v) {
    times.push_back(t);
    values.insert(values.end(), v.begin(), v.end());
  }
  /// Column c at time t, linear between the recorded times, held beyond them.
  double at(std::size_t c, double t) const;
  void save(util::BinaryWriter& out) const;
  void restore(util::BinaryReader& in);
};

/// The error of `record` against the same dataset of a stored run (its
/// coupler.h5): sqrt(mean over the stored times both runs cover and over the
/// columns of (record(t) - stored(t))^2) / max |stored|. Throws naming the
/// file when it holds another number of columns or does not overlap in time.
double rmsAgainstStoredRun(const TimeRecord& record, const std::string& file, const std::string& dataset);

using ReferenceRegistry = Registry<Reference, config::MapReader&, const std::vector<SolverSpec>&>;

}  // namespace cosim::coupler
