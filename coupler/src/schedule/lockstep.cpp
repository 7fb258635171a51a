// Lockstep: every solver advances the same dt (and the same number of steps)
// between exchanges.
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/schedule/schedule.hpp"
#include "cosim/coupler/schedule/time_step.hpp"

namespace cosim::coupler {
namespace {

class Lockstep final : public Schedule {
 public:
  explicit Lockstep(config::MapReader& m) {
    const auto dtText = m.optionalString("dt");
    if (!dtText) {
      m.error("dt", "missing: give a step in seconds or 'auto'");
    } else if (*dtText == "auto") {
      autoDt_ = true;
    } else {
      dt_ = m.optionalNumber("dt", config::Range::positive()).value_or(0.0);
    }
    safety_ = m.number("safety", 0.5, {0.0, 1.0, true});
    stepsPerExchange_ = static_cast<std::uint32_t>(m.integer("steps_per_exchange", 1, 1, 100000000));
    endTime_ = m.optionalNumber("end_time", config::Range::positive());
    fixedExchanges_ = m.optionalInteger("exchanges", 1, 1000000000000L);
    if (endTime_ && fixedExchanges_) m.error("exchanges", "give end_time or exchanges, not both");
    if (endTime_ && dt_ > 0.0 && !withinExchangeLimit())
      m.error("end_time", "end_time / (dt x steps_per_exchange) = " + toString(*endTime_ / (dt_ * stepsPerExchange_)) +
                              " exchanges, more than the " + toString(kMaxExchanges) + " a run may have");
    // A step longer than the run would end it "completed" without an exchange.
    if (endTime_ && dt_ > 0.0 && withinExchangeLimit() && exchanges() == 0)
      m.error("dt", "dt x steps_per_exchange = " + toString(dt_ * stepsPerExchange_) + " s is longer than end_time = " +
                        toString(*endTime_) + " s: no exchange would run");
    if (!endTime_ && !fixedExchanges_ && !m.has("end_time") && !m.has("exchanges"))
      m.diagnostics().error(m.mark(), "schedule: give the run's length as end_time (s) or exchanges");
  }

  std::string kind() const override { return "lockstep"; }

  std::string describe() const override {
    std::ostringstream s;
    s << "lockstep: dt = " << (autoDt_ && dt_ == 0.0 ? std::string("auto") : toString(dt_)) << " s, "
      << stepsPerExchange_ << " step(s) per exchange, ";
    if (fixedExchanges_) s << *fixedExchanges_ << " exchanges";
    else s << untilText(endTime_ ? *endTime_ : 0.0, dt_ * stepsPerExchange_);
    return s.str();
  }

  bool autoTimeStep() const override { return autoDt_; }
  void resolveTimeStep(const std::map<std::string, double>& criticalDt, bool force) override {
    const CriticalStep limit = tightestStep(criticalDt, [](const std::string&) { return true; });
    if (autoDt_) {
      if (!limit.limited())
        throw std::runtime_error("schedule.dt: 'auto' needs a solver that reports a critical time step; none does");
      dt_ = safety_ * limit.dt;
      if (endTime_ && !withinExchangeLimit())
        throw std::runtime_error("schedule: dt: auto gives " + toString(dt_) + " s, so end_time needs " +
                                 toString(*endTime_ / (dt_ * stepsPerExchange_)) + " exchanges, more than the " +
                                 toString(kMaxExchanges) + " a run may have");
    } else if (dt_ > limit.dt && !force) {
      throw std::runtime_error("schedule.dt = " + toString(dt_) + " s exceeds the critical time step " +
                               toString(limit.dt) + " s of solver '" + limit.solver +
                               "'; lower dt, use dt: auto, or run with --force");
    }
  }

  std::uint64_t exchanges() const override {
    if (fixedExchanges_) return static_cast<std::uint64_t>(*fixedExchanges_);
    return endTime_ ? intervalsUntil(*endTime_, dt_ * stepsPerExchange_) : 0;
  }

  double endTime() const override { return static_cast<double>(exchanges()) * dt_ * stepsPerExchange_; }

  void run(ExchangeDriver& driver) override {
    std::map<std::string, AdvancePlan> plans;
    for (const auto& name : driver.solverNames()) plans[name] = AdvancePlan{stepsPerExchange_, dt_};
    const std::uint64_t n = exchanges();
    for (std::uint64_t k = driver.completedExchanges() + 1; k <= n && !driver.stopRequested(); ++k)
      driver.exchange(plans, static_cast<double>(k) * dt_ * stepsPerExchange_);
  }

 private:
  static constexpr double kMaxExchanges = 1e12;
  bool withinExchangeLimit() const { return *endTime_ / (dt_ * stepsPerExchange_) <= kMaxExchanges; }
  static std::string toString(double v) { return formatNumber(v); }
  bool autoDt_ = false;
  double dt_ = 0.0;
  double safety_ = 0.5;
  std::uint32_t stepsPerExchange_ = 1;
  std::optional<double> endTime_;
  std::optional<long> fixedExchanges_;
};

const bool registered =
    ScheduleRegistry::add("lockstep", [](config::MapReader& m, const std::vector<SolverSpec>&) { return std::make_unique<Lockstep>(m); });

}  // namespace
}  // namespace cosim::coupler
