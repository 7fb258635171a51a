#pragma once
// Time synchronisation of the solvers. A schedule decides, exchange by
// exchange, how many steps of which size each solver advances; the
// ExchangeDriver does the messaging, the couplings and the bookkeeping.
#include <map>
#include <string>
#include <vector>

#include "cosim/util/registry.hpp"

namespace cosim::config {
class MapReader;
}

namespace cosim::coupler {

struct SolverSpec;

struct AdvancePlan {
  std::uint32_t steps = 1;
  double dt = 0.0;
};

/// What a schedule drives: one call = one exchange of all solvers it names.
class ExchangeDriver {
 public:
  virtual ~ExchangeDriver() = default;
  virtual void exchange(const std::map<std::string, AdvancePlan>& plans, double newTime) = 0;
  virtual const std::vector<std::string>& solverNames() const = 0;
  virtual double time() const = 0;
  /// Exchanges already done (non-zero when a run resumes from a checkpoint).
  virtual std::uint64_t completedExchanges() const = 0;
  /// True once the scene's analysis says the run has reached its end (e.g. the
  /// particles left the beam): the schedule stops before its end time.
  virtual bool stopRequested() const { return false; }
};

class Schedule {
 public:
  virtual ~Schedule() = default;
  virtual std::string kind() const = 0;
  virtual std::string describe() const = 0;
  /// Resolves `dt: auto` and checks the step against the solvers' critical
  /// steps (0 = no limit). Throws std::runtime_error with the numbers when
  /// the step is unstable, unless force.
  virtual void resolveTimeStep(const std::map<std::string, double>& criticalDt, bool force) = 0;
  /// Whether resolveTimeStep chooses the step (`dt: auto`) rather than checks a given one.
  virtual bool autoTimeStep() const { return false; }
  virtual std::uint64_t exchanges() const = 0;
  virtual double endTime() const = 0;
  virtual void run(ExchangeDriver& driver) = 0;
};

/// Schedules register by the `schedule.kind` a scene uses; the factory sees
/// the scene's solvers, so the names a schedule refers to are checked with the
/// rest of the scene (`coupler check`), not when the run starts.
using ScheduleRegistry = Registry<Schedule, config::MapReader&, const std::vector<SolverSpec>&>;

}  // namespace cosim::coupler
