// multirate: one solver (`fine`, e.g. DEM) takes k steps of dt while the others
// take one step of k dt per exchange, so a stiff fine scale does not force its
// step on the coarse one (Hartmann 2022 Alg. 2 for dt_coarse >= dt_fine;
// Cheng 2022 Sec. 5.3 where FEM and DEM run at one dt is the k = 1 case).
//   order: parallel     both advance at once from the last exchange's data;
//          coarse-first the coarse solvers advance first, then the fine one
//                       with the coarse state at both ends of the interval
//                       (what interpolated wall kinematics need);
//          fine-first   the fine solver advances first (extrapolating the
//                       coarse state), then the coarse ones with what the fine
//                       one returned for the same interval: the interface
//                       forces lag half a coarse step instead of one or more.
// dt and ratio may be `auto`: dt from the fine solver's critical step, k from
// the quotient of the coarse and fine critical steps (both times `safety`).
#include <algorithm>
#include <set>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/schedule/schedule.hpp"
#include "cosim/coupler/schedule/time_step.hpp"

namespace cosim::coupler {
namespace {

class Multirate final : public Schedule {
 public:
  Multirate(config::MapReader& m, const std::vector<SolverSpec>& solvers) {
    readFine(m, solvers);
    const auto dtText = m.optionalString("dt");
    if (!dtText) m.error("dt", "missing: give the fine step in seconds or 'auto'");
    else if (*dtText == "auto") autoDt_ = true;
    else dt_ = m.optionalNumber("dt", config::Range::positive()).value_or(0.0);
    const auto ratioText = m.optionalString("ratio");
    if (!ratioText) m.error("ratio", "missing: fine steps per coarse step (an integer >= 1, or 'auto')");
    else if (*ratioText == "auto") autoRatio_ = true;
    else ratio_ = static_cast<std::uint32_t>(m.optionalInteger("ratio", 1, 100000000).value_or(1));
    safety_ = m.number("safety", 0.5, {0.0, 1.0, true});
    const std::string order = m.string("order", "parallel");
    if (order != "parallel" && order != "coarse-first" && order != "fine-first")
      m.error("order", "must be parallel, coarse-first or fine-first, got '" + order + "'");
    sequence_ = order == "coarse-first" ? Sequence::coarseFirst
                : order == "fine-first" ? Sequence::fineFirst : Sequence::parallel;
    endTime_ = m.optionalNumber("end_time", config::Range::positive());
    fixedSteps_ = m.optionalInteger("coarse_steps", 1, 1000000000000L);
    if (endTime_ && fixedSteps_) m.error("coarse_steps", "give end_time or coarse_steps, not both");
    if (!endTime_ && !fixedSteps_ && !m.has("end_time") && !m.has("coarse_steps"))
      m.diagnostics().error(m.mark(), "schedule: give the run's length as end_time (s) or coarse_steps");
  }

  std::string kind() const override { return "multirate"; }

  std::string describe() const override {
    std::ostringstream s;
    s << "multirate: '" << fineNames() << "' take(s) " << (autoRatio_ && ratio_ == 0 ? std::string("auto") : std::to_string(ratio_))
      << " step(s) of dt = " << (autoDt_ && dt_ == 0.0 ? std::string("auto") : formatNumber(dt_))
      << " s per coarse step, "
      << (sequence_ == Sequence::coarseFirst ? "coarse solvers first"
          : sequence_ == Sequence::fineFirst ? "fine solver first" : "all at once") << ", ";
    if (fixedSteps_) s << *fixedSteps_ << " coarse steps";
    else s << untilText(endTime_ ? *endTime_ : 0.0, coarseDt());
    return s.str();
  }

  bool autoTimeStep() const override { return autoDt_; }
  void resolveTimeStep(const std::map<std::string, double>& criticalDt, bool force) override {
    const CriticalStep fine = tightestStep(criticalDt, [this](const std::string& s) { return isFine(s); });
    const CriticalStep coarse = tightestStep(criticalDt, [this](const std::string& s) { return !isFine(s); });
    if (autoDt_) {
      if (!fine.limited())
        throw std::runtime_error("schedule.dt: 'auto' needs the fine solver '" + fineNames() + "' to report a critical step");
      dt_ = safety_ * fine.dt;
    }
    if (autoRatio_) {
      if (!coarse.limited())
        throw std::runtime_error("schedule.ratio: 'auto' needs a coarse solver with a critical step (an implicit "
                                 "one has none); give ratio as an integer");
      ratio_ = static_cast<std::uint32_t>(std::max(1.0, std::floor(safety_ * coarse.dt / dt_)));
    }
    if (!force && dt_ > fine.dt)
      throw std::runtime_error("schedule.dt = " + formatNumber(dt_) + " s exceeds the critical step " +
                               formatNumber(fine.dt) + " s of the fine solver '" + fine.solver +
                               "'; lower dt, use dt: auto, or run with --force");
    if (!force && coarseDt() > coarse.dt)
      throw std::runtime_error("schedule: the coarse step ratio x dt = " + formatNumber(coarseDt()) +
                               " s exceeds the critical step " + formatNumber(coarse.dt) + " s of solver '" +
                               coarse.solver + "'; lower ratio, use ratio: auto, or run with --force");
    if (coarseSteps() == 0 || static_cast<double>(coarseSteps()) > 1e12)
      throw std::runtime_error("schedule: " + formatNumber(endTime_.value_or(0.0) / coarseDt()) +
                               " coarse steps; a run needs between 1 and 1e12");
  }

  std::uint64_t exchanges() const override { return coarseSteps() * perStep(); }
  double endTime() const override { return static_cast<double>(coarseSteps()) * coarseDt(); }

  void run(ExchangeDriver& driver) override {
    std::map<std::string, AdvancePlan> fine, coarse, all;
    for (const auto& name : driver.solverNames()) {
      if (isFine(name)) fine[name] = all[name] = AdvancePlan{ratio_, dt_};
      else coarse[name] = all[name] = AdvancePlan{1, coarseDt()};
    }
    // Exchanges are counted one per driver call, so a run resumed between the
    // two halves of a sequential step continues with its second half.
    for (std::uint64_t e = driver.completedExchanges(); e < exchanges() && !driver.stopRequested(); ++e) {
      const double end = static_cast<double>(e / perStep() + 1) * coarseDt();
      const bool firstHalf = e % 2 == 0;
      if (sequence_ == Sequence::parallel || coarse.empty()) driver.exchange(all, end);
      else if (sequence_ == Sequence::coarseFirst) driver.exchange(firstHalf ? coarse : fine, end);
      else driver.exchange(firstHalf ? fine : coarse, end);
    }
  }

 private:
  enum class Sequence { parallel, coarseFirst, fineFirst };

  /// `fine`: one solver, or a list (a pool of DEM workers that sub-cycle
  /// together); each a declared solver, none twice, and at least one solver
  /// left to take the coarse step.
  void readFine(config::MapReader& m, const std::vector<SolverSpec>& solvers) {
    std::vector<std::string> listed;
    if (m.has("fine") && m.node("fine").IsSequence()) listed = m.stringList("fine");
    else if (auto one = m.optionalString("fine")) listed = {*one};
    else return m.error("fine", "missing: the solver (or list of solvers) that takes the small steps");
    if (listed.empty()) return m.error("fine", "an empty list: name the solver(s) that take the small steps");
    for (const auto& name : listed) {
      const auto named = solversNamed(name, solvers);  // a pool entry stands for its workers
      if (named.empty())
        m.error("fine", "'" + name + "' is not a solver declared under solvers (declared: " +
                            declaredSolverNames(solvers) + ")");
      for (const auto& s : named) {
        if (!fineSet_.insert(s).second) m.error("fine", "'" + s + "' is listed twice");
        else fine_.push_back(s);
      }
    }
    if (!solvers.empty() && std::all_of(solvers.begin(), solvers.end(), [this](const SolverSpec& s) { return isFine(s.name); }))
      m.error("fine", "names every solver: multirate needs a coarse solver besides the fine one(s); use lockstep");
  }

  std::uint64_t perStep() const { return sequence_ == Sequence::parallel ? 1 : 2; }
  double coarseDt() const { return dt_ * ratio_; }
  std::uint64_t coarseSteps() const {
    if (fixedSteps_) return static_cast<std::uint64_t>(*fixedSteps_);
    return endTime_ ? intervalsUntil(*endTime_, coarseDt()) : 0;
  }

  bool isFine(const std::string& solver) const { return fineSet_.count(solver) > 0; }
  std::string fineNames() const {
    std::string out;
    for (const auto& f : fine_) out += (out.empty() ? "" : ", ") + f;
    return out;
  }

  std::vector<std::string> fine_;    // in the order the scene lists them
  std::set<std::string> fineSet_;  // the same, to look up
  bool autoDt_ = false, autoRatio_ = false;
  Sequence sequence_ = Sequence::parallel;
  double dt_ = 0.0;
  std::uint32_t ratio_ = 0;
  double safety_ = 0.5;
  std::optional<double> endTime_;
  std::optional<long> fixedSteps_;
};

const bool registered =
    ScheduleRegistry::add("multirate", [](config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<Multirate>(m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
