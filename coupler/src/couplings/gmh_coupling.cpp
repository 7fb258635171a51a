// gmh: hierarchical FEM x DEM (Liu 2016 Sec. 2.3, Fig. 3; DESIGN.md 6.2). FEM
// (external material, explicit) sends one unit-cell job per quadrature point
// each coarse step: the corotational strain increment (Eq. 60; or the whole
// increment, spin included, where FEM's material says frame: spatial). A pool of
// dem_solver workers holds the cells, each cell on one worker (sticky: a
// cell's state lives where it was loaded; the workers announce their cells in
// their setup replies), unless that worker is lost and `on_worker_loss: move`
// hands its cells to the others: each adopter loads them from the latest
// checkpoint and replays the jobs sent since (handOver), so every cell's
// history, and so every answer, is the undisturbed run's. The coupling splits the jobs by owner,
// the workers run them at the same time, and it gathers their Cauchy
// stresses (Eq. 44b, in the cells' frame) with porosity, coordination number, unbalanced-
// force index (Eq. 57) and relaxation steps into one result list for FEM.
// Pair it with `schedule: {kind: multirate, fine: [workers...], ratio: 1,
// order: coarse-first}`: FEM predicts, then the workers answer.
// `nonlocal: {radius: R, local_fraction: beta}` passes the increments through
// the staggered nonlocal operator (Liu Eqs. 58-59, A.3-A.6; NonlocalOperator)
// before they go out. An operator with an eigenvalue at or below zero stops
// the run before the first job: its alternating strain modes would have no
// stiffness or a negative one (see nonlocal_operator.hpp).
// `nonlocal: {radius: R, averages: inelastic_stress, over_nonlocal: m,
// stiffness: {E, nu}}` instead sends each cell its own increment and
// averages the cells' inelastic stress on the way back to FEM
// (InelasticStressAveraging: ours, since averaging the strain does not bound
// the softening zone).
#include <algorithm>
#include <array>
#include <map>
#include <optional>
#include <ostream>
#include <set>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/analysis/run_report.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/coupler/mapping/inelastic_stress_averaging.hpp"
#include "cosim/coupler/mapping/nonlocal_operator.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/log.hpp"

namespace cosim::coupler {
namespace {

/// One worker's share of a step: the jobs it gets.
struct WorkerJobs {
  std::vector<std::uint32_t> ids;
  std::vector<double> increments;
};

/// The gathered results of every cell, in the order FEM's jobs named them.
struct GatheredResults {
  std::vector<std::uint32_t> ids, steps;
  std::vector<double> stresses, porosities, coordination, indices;
  std::vector<std::uint8_t> failed;  // 1: the job ended outside its worker's relaxation settings (on_failure: continue)
  void clear() {
    ids.clear(), steps.clear(), stresses.clear(), porosities.clear(), coordination.clear(), indices.clear();
    failed.clear();
  }
};

class GmhCoupling final : public Coupling {
 public:
  GmhCoupling(const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) : Coupling(name) {
    fem_ = requireSolverName(m, "fem", solvers);
    const bool given = m.has("workers");
    std::set<std::string> listedOnce;
    for (const auto& listed : m.stringList("workers")) {
      const auto named = solversNamed(listed, solvers);  // a pool entry stands for its workers
      if (named.empty()) m.error("workers", "'" + listed + "' is not a solver declared under solvers");
      for (const auto& w : named) {
        if (w == fem_) m.error("workers", "'" + w + "' is the FEM solver");
        else if (!listedOnce.insert(w).second) m.error("workers", "'" + w + "' is listed twice");
        else workers_.push_back(w);
      }
    }
    if (workers_.empty()) m.error("workers", given ? "is empty" : "missing: the dem_solver workers that hold the unit cells");
    moveOnLoss_ = m.choice("on_worker_loss", {"stop", "move"}, "stop") == "move";
    if (m.has("nonlocal")) readNonlocal(m);
  }

  /// `nonlocal: {radius, averages: strain_increments (Liu) | inelastic_stress, ...}`.
  void readNonlocal(config::MapReader& m) {
    config::MapReader nl(m.node("nonlocal"), m.keyPath("nonlocal"), m.diagnostics());
    nonlocalKey_ = m.keyPath("nonlocal");
    radius_ = nl.requireNumber("radius", config::Range::positive());
    const bool strain = nl.choice("averages", {"strain_increments", "inelastic_stress"}, "strain_increments") ==
                        "strain_increments";
    if (strain) {
      localFraction_ = nl.number("local_fraction", 0.0, config::Range{0.0, 1.0, false});
      if (localFraction_ >= 1.0) nl.error("local_fraction", "must be below 1 (1 is the local model: leave out nonlocal)");
      for (const char* key : {"over_nonlocal", "stiffness"})
        if (nl.has(key)) nl.error(key, "belongs to averages: inelastic_stress");
    } else {
      if (nl.has("local_fraction"))
        nl.error("local_fraction", "belongs to averages: strain_increments (the cells get their own increments here)");
      const double over = nl.number("over_nonlocal", 1.0, config::Range::positive());
      if (!nl.has("stiffness"))
        nl.error("stiffness", "missing: {E, nu}, the isotropic stiffness C that a cell's strain meets where it departs "
                              "from its neighbourhood's (at most the cells' own elastic stiffness, which "
                              "bench/gmh/l1_elastic_constants measures)");
      else {
        config::MapReader c(nl.node("stiffness"), nl.keyPath("stiffness"), nl.diagnostics());
        const double e = c.requireNumber("E", config::Range::positive());
        const double nu = c.requireNumber("nu", config::Range{-1.0, 0.5, true});
        if (nu >= 0.5) c.error("nu", "must be below 0.5 (0.5 is incompressible)");
        c.finish();
        if (c.diagnostics().ok()) inelastic_.emplace(e, nu, over);
      }
    }
    nl.finish();
  }

  std::string kind() const override { return "gmh"; }
  std::vector<std::string> participants() const override {
    std::vector<std::string> p{fem_};
    p.insert(p.end(), workers_.begin(), workers_.end());
    return p;
  }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == fem_) return {"advance"};
    if (moveOnLoss_) return {"unit-cells", "unit-cell-adoption"};
    return {"unit-cells"};
  }
  void describe(std::ostream& out) const override {
    out << fem_ << " unit-cell jobs -> " << workers_.size() << " worker(s):";
    for (const auto& w : workers_) out << " " << w;
    out << (moveOnLoss_ ? " (a lost worker's cells move to the others through the latest checkpoint)"
                        : " (each cell stays on the worker that loaded it; a lost worker stops the run)");
    if (inelastic_)
      out << "; nonlocal inelastic stress, bell kernel, R = " << radius_ << " m, over-nonlocal factor "
          << inelastic_->overNonlocal() << " (the cells get their own increments)";
    else if (radius_ > 0.0)
      out << "; nonlocal strain increments, bell kernel, R = " << radius_ << " m, local fraction " << localFraction_
          << " (Liu Eqs. 58-59)";
  }

  std::string describeLoss(const std::string& solver) const override {
    auto it = cellsOf_.find(solver);
    if (it == cellsOf_.end() || it->second.empty()) return {};
    const auto& ids = it->second;
    std::string list;
    for (std::size_t k = 0; k < ids.size() && k < 20; ++k) list += (k ? ", " : "") + std::to_string(ids[k]);
    if (ids.size() > 20) list += ", ... (" + std::to_string(ids.size()) + " cells)";
    return "worker '" + solver + "' held unit cells " + list + "; restart from a checkpoint to move them" +
           (moveOnLoss_ ? "" : " (or set on_worker_loss: move to move them within the run)");
  }

  bool canHandOver(const std::string& lost) const override {
    return moveOnLoss_ && std::find(workers_.begin(), workers_.end(), lost) != workers_.end() && !retired_.count(lost);
  }

  /// The lost worker's cells go to the survivors with the fewest cells, one
  /// by one in id order (so the pool stays balanced and the choice is the same
  /// on every run). Each adopter loads them from the file that held them at
  /// the latest checkpoint and runs the jobs sent to them since.
  std::vector<CellAdoption> handOver(const std::string& lost, std::uint64_t exchange) override {
    const std::string who = "coupling '" + name() + "': cannot move the unit cells of worker '" + lost + "'";
    if (!checkpointExchange_)
      throw std::runtime_error(who + ": no checkpoint has been taken yet, and the cells move from the latest one "
                                     "(output.checkpoint_interval)");
    std::vector<std::string> survivors;
    for (const auto& w : workers_)
      if (w != lost && !retired_.count(w)) survivors.push_back(w);
    if (survivors.empty()) throw std::runtime_error(who + ": no other worker is left");
    std::vector<std::uint32_t> cells = cellsOf_[lost];
    std::sort(cells.begin(), cells.end());
    std::map<std::pair<std::string, std::string>, std::vector<std::uint32_t>> groups;  // (adopter, source) -> ids
    for (std::uint32_t id : cells) {
      const auto adopter = *std::min_element(survivors.begin(), survivors.end(), [&](const auto& a, const auto& b) {
        return cellsOf_[a].size() < cellsOf_[b].size();
      });
      const auto source = holderAtCheckpoint_.find(id);
      if (source == holderAtCheckpoint_.end())
        throw std::runtime_error(who + ": unit cell " + std::to_string(id) + " was held by no worker at the checkpoint");
      groups[{adopter, source->second}].push_back(id);
      owner_[id] = adopter;
      cellsOf_[adopter].push_back(id);
    }
    cellsOf_[lost].clear();
    retired_.insert(lost);
    movedCells_ += cells.size();
    return adoptions(groups, exchange);
  }

  void checkpointTaken(std::uint64_t exchange) override {
    checkpointExchange_ = exchange;
    holderAtCheckpoint_ = owner_;
    std::erase_if(sent_, [&](const SentJobs& s) { return s.exchange <= exchange; });
  }

  void exchange(ExchangeContext& ctx) override {
    // At setup every worker announces its cells; a resumed run learns them
    // from the workers' replies saved with the checkpoint (every cell answers
    // its job each coarse step).
    if (ctx.exchange == 0 || owner_.empty()) learnOwners(ctx);
    // The answers first: with every solver advancing at once they answer the
    // jobs of the previous step, which dispatch() then replaces.
    // At setup this gathers the prepared cells' stresses: FEM's initial stresses (the confinement).
    if (std::any_of(workers_.begin(), workers_.end(), [&](const std::string& w) { return ctx.isNew(w); })) gather(ctx);
    if (ctx.isNew(fem_) && ctx.outputs.count(fem_)) dispatch(ctx);
    if (!gathered_.ids.empty())
      ctx.inputs[fem_].stageUnitCellResults({gathered_.ids, gathered_.stresses, gathered_.porosities,
                                             gathered_.coordination, gathered_.indices, gathered_.steps});
  }

 private:
  void learnOwners(const ExchangeContext& ctx) {
    owner_.clear();
    for (const auto& w : workers_) {
      auto out = ctx.outputs.find(w);
      if (out == ctx.outputs.end()) continue;
      auto& held = cellsOf_[w];
      held.clear();
      for (auto r : out->second.getUnitCellResults())
        for (std::uint32_t id : wire::view(r.getCellIds())) {
          auto [it, fresh] = owner_.emplace(id, w);
          if (!fresh)
            throw std::runtime_error("coupling '" + name() + "': unit cell " + std::to_string(id) + " is held by both '" +
                                     it->second + "' and '" + w + "' (give the workers disjoint first_id/count)");
          held.push_back(id);
        }
      if (held.empty())
        throw std::runtime_error("coupling '" + name() + "': worker '" + w + "' announced no unit cells " +
                                 (ctx.exchange == 0 ? std::string("at setup")
                                                    : "in its reply of exchange " + std::to_string(ctx.exchange)));
    }
  }

  void dispatch(ExchangeContext& ctx) {
    collectJobs(ctx);
    const bool strainAveraging = radius_ > 0.0 && !inelastic_;
    if (radius_ > 0.0 && !ids_.empty()) buildOperator();  // FEM's setup reply carries no jobs
    if (strainAveraging && !ids_.empty()) smooth();
    if (inelastic_) inelastic_->send(ids_, increments_);  // the cells get their own increments
    for (auto& [w, jobs] : jobs_) jobs.ids.clear(), jobs.increments.clear();
    const auto& inc = strainAveraging ? smoothed_ : increments_;
    for (std::size_t k = 0; k < ids_.size(); ++k) {
      auto owner = owner_.find(ids_[k]);
      if (owner == owner_.end())
        throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(ctx.exchange) +
                                 ": FEM sent a job for unit cell " + std::to_string(ids_[k]) +
                                 ", which no worker holds (" + std::to_string(owner_.size()) + " cells in the pool)");
      auto& jobs = jobs_[owner->second];
      jobs.ids.push_back(ids_[k]);
      jobs.increments.insert(jobs.increments.end(), inc.begin() + 9 * static_cast<std::ptrdiff_t>(k),
                             inc.begin() + 9 * static_cast<std::ptrdiff_t>(k + 1));
    }
    for (auto& [w, jobs] : jobs_)
      if (!jobs.ids.empty()) ctx.inputs[w].stageUnitCellJobs({jobs.ids, jobs.increments, dt_});
    if (moveOnLoss_ && !ids_.empty()) remember(ctx.exchange + 1, inc);
    if (ctx.series) ctx.series->append(name() + "/jobs", static_cast<double>(ids_.size()));
  }

  /// The jobs sent in `exchange`, kept until a checkpoint covers them: what a
  /// hand-over replays. Before the first checkpoint only the latest are kept
  /// (a loss then stops the run), so memory stays bounded.
  void remember(std::uint64_t exchange, const std::vector<double>& increments) {
    if (!checkpointExchange_) sent_.clear();
    std::erase_if(sent_, [&](const SentJobs& s) { return s.exchange == exchange; });  // a resumed run's replay
    sent_.push_back({exchange, dt_, ids_, increments});
  }

  /// Each group's jobs from the record, up to the exchange whose requests are out.
  std::vector<CellAdoption> adoptions(const std::map<std::pair<std::string, std::string>, std::vector<std::uint32_t>>& groups,
                                      std::uint64_t exchange) {
    replay_.assign(groups.size(), {});
    std::vector<CellAdoption> out;
    std::size_t g = 0;
    for (const auto& [key, ids] : groups) {
      const std::set<std::uint32_t> members(ids.begin(), ids.end());
      CellAdoption a{key.first, key.second, ids, {}, false};
      for (const auto& s : sent_) {
        if (s.exchange > exchange) continue;
        WorkerJobs jobs;
        for (std::size_t k = 0; k < s.ids.size(); ++k) {
          if (!members.count(s.ids[k])) continue;
          jobs.ids.push_back(s.ids[k]);
          jobs.increments.insert(jobs.increments.end(), s.increments.begin() + 9 * static_cast<std::ptrdiff_t>(k),
                                 s.increments.begin() + 9 * static_cast<std::ptrdiff_t>(k + 1));
        }
        if (jobs.ids.empty()) continue;
        a.answersNow = s.exchange == exchange;
        replay_[g].push_back({std::move(jobs), s.dt});
      }
      for (const auto& [jobs, dt] : replay_[g]) a.jobs.push_back({jobs.ids, jobs.increments, dt});
      out.push_back(std::move(a));
      ++g;
    }
    return out;
  }

  /// FEM's jobs of this step as flat arrays, in its order.
  void collectJobs(const ExchangeContext& ctx) {
    ids_.clear(), increments_.clear(), positions_.clear();
    for (auto list : ctx.outputs.at(fem_).getUnitCellJobs()) {
      const auto ids = wire::view(list.getCellIds());
      const auto inc = wire::view(list.getStrainIncrements());
      const auto pos = wire::view(list.getPositions());
      if (inc.size() != 9 * ids.size() || (!pos.empty() && pos.size() != 3 * ids.size()))
        throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(ctx.exchange) + ": FEM sent " +
                                 std::to_string(ids.size()) + " jobs with " + std::to_string(inc.size()) +
                                 " increment and " + std::to_string(pos.size()) + " position values (9 and 3 per job)");
      dt_ = list.getDt();
      ids_.insert(ids_.end(), ids.begin(), ids.end());
      increments_.insert(increments_.end(), inc.begin(), inc.end());
      if (radius_ > 0.0) positions_.insert(positions_.end(), pos.begin(), pos.end());  // only the nonlocal operator reads them
    }
  }

  /// The operator over the jobs' points, built at the first jobs (again if
  /// FEM's job list changes). The inelastic form needs no eigenvalue check: an
  /// alternating pattern keeps the stiffness C whatever the operator does to
  /// it (InelasticStressAveraging).
  void buildOperator() {
    if (nonlocal_ && nonlocalIds_ == ids_) return;
    if (positions_.size() != 3 * ids_.size())
      throw std::runtime_error("coupling '" + name() + "': nonlocal needs the quadrature point positions of the jobs, "
                               "which '" + fem_ + "' did not send");
    nonlocalIds_ = ids_;
    nonlocal_.emplace(positions_, radius_, localFraction_);
    std::string what = "nonlocal operator over " + std::to_string(ids_.size()) + " points, R = " +
                       std::to_string(radius_) + " m, " + std::to_string(nonlocal_->meanNeighbours()) +
                       " neighbours per point on average";
    if (!inelastic_) {
      smallestEigenvalue_ = nonlocal_->smallestEigenvalue();
      what += ", smallest eigenvalue " + std::to_string(smallestEigenvalue_);
    }
    log::info("coupling '" + name() + "': " + what + (inelastic_ ? " (inelastic stress)" : ""));
    if (!inelastic_) refuseIndefinite();
  }

  /// Liu Eq. 58: every cell gets the bell-weighted mean increment of its neighbourhood.
  void smooth() {
    smoothed_.resize(increments_.size());
    nonlocal_->apply(increments_, 9, smoothed_);
  }

  /// An eigenvalue at or below zero: a strain pattern the averaging removes or
  /// reverses, so the coarse problem has a zero or negative stiffness for it.
  void refuseIndefinite() const {
    if (smallestEigenvalue_ > 0.0) return;
    const auto needed = [&](double target) {
      return std::to_string(NonlocalOperator::localFractionFor(smallestEigenvalue_, localFraction_, target));
    };
    throw std::runtime_error(
        "coupling '" + name() + "': the nonlocal operator over " + std::to_string(ids_.size()) + " points (" +
        nonlocalKey_ + ".radius = " + std::to_string(radius_) + " m, local_fraction = " +
        std::to_string(localFraction_) + ") has the eigenvalue " + std::to_string(smallestEigenvalue_) +
        ": the bell kernel sampled this finely is not positive definite, and strain patterns that alternate "
        "between neighbouring elements would get a negative or zero stiffness and grow without bound. Set " +
        nonlocalKey_ + ".local_fraction to at least " + needed(0.0) + " (" + needed(0.1) +
        " gives the smallest eigenvalue 0.1), or use a coarser mesh");
  }

  void gather(ExchangeContext& ctx) {
    for (const auto& w : workers_)
      if (!ctx.isNew(w) && !retired_.count(w)) return;  // the pool answers together (all workers advance in one exchange)
    gatherFrom(ctx);
    if (!ctx.replay) checkAnswers(ctx.exchange);
    noteFailures(ctx.exchange, ctx.replay);
    record(ctx);
    if (inelastic_) averageInelasticStress(ctx);
  }

  /// The stresses FEM gets: each cell's plus m (s_I - <s>_I) (InelasticStressAveraging).
  /// The series keep the cells' own stresses; the correction's RMS goes beside them.
  void averageInelasticStress(const ExchangeContext& ctx) {
    if (!inelastic_->hasReference()) {  // setup: the cells before their first increment
      inelastic_->setReference(gathered_.ids, gathered_.stresses);
      return;
    }
    // A resumed run's replayed answers find nothing pending (restore() clears
    // it; they come before the replayed jobs): they were counted before.
    inelastic_->answered(gathered_.ids);
    if (!nonlocal_) return;
    const double rms = inelastic_->correct(*nonlocal_, nonlocalIds_, gathered_.ids, gathered_.stresses);
    maxCorrection_ = std::max(maxCorrection_, rms);
    if (ctx.series) ctx.series->append(name() + "/inelastic_correction_rms", rms);
  }

  /// Jobs that ended outside their worker's relaxation settings and were
  /// accepted as they stand (on_failure: continue): never silent. A cell is
  /// named with its numbers when it starts failing and when it recovers; the
  /// series counts them every step and the run report sums them. A resumed
  /// run's replayed replies were counted before the checkpoint: they only
  /// set which cells are failing now.
  void noteFailures(std::uint64_t exchange, bool replay) {
    for (std::size_t k = 0; k < gathered_.ids.size(); ++k) {
      const std::uint32_t id = gathered_.ids[k];
      const bool failed = gathered_.failed[k] != 0;
      const bool was = failing_.count(id) != 0;
      if (failed && !replay) ++failedJobs_, failedCells_.insert(id);
      if (failed == was) continue;
      if (failed) failing_.insert(id); else failing_.erase(id);
      if (replay) continue;
      const double* sigma = &gathered_.stresses[9 * k];
      log::warn("coupling '" + name() + "' at exchange " + std::to_string(exchange) + ": unit cell " +
                std::to_string(id) + (failed ? " failed its job, accepted as it stands (on_failure: continue)"
                                             : " relaxed again") +
                ": I_uf " + std::to_string(gathered_.indices[k]) + " after " + std::to_string(gathered_.steps[k]) +
                " steps, porosity " + std::to_string(gathered_.porosities[k]) + ", Z " +
                std::to_string(gathered_.coordination[k]) + ", mean stress " +
                std::to_string((sigma[0] + sigma[4] + sigma[8]) / 3.0) + " Pa");
    }
  }

  void gatherFrom(const ExchangeContext& ctx) {
    gathered_.clear();
    answeredBy_.clear();
    for (const auto& w : workers_) {
      auto out = ctx.outputs.find(w);
      if (out == ctx.outputs.end()) continue;
      const std::size_t first = gathered_.ids.size();
      for (auto r : out->second.getUnitCellResults()) append(r, w, ctx.exchange);
      answeredBy_[w].assign(gathered_.ids.begin() + static_cast<std::ptrdiff_t>(first), gathered_.ids.end());
      for (auto a : out->second.getArrays()) noteFineTimeStep(a);
    }
  }

  /// Every job went to one worker and comes back from it once: a lost answer
  /// would leave a quadrature point with last step's stress, a doubled one
  /// would hand FEM two stresses for it, both without a sign in the results.
  /// (At setup, and for the replayed replies of a resume, no jobs are out.)
  void checkAnswers(std::uint64_t exchange) {
    // Workers lost in this exchange are checked together: their adopters'
    // answers stand in for all of them (a cell can move twice in one exchange).
    const std::string lostWorkers = "the workers lost";
    std::map<std::string, std::pair<std::multiset<std::uint32_t>, std::vector<std::uint32_t>>> buckets;
    const auto bucket = [&](const std::string& w) -> auto& { return buckets[retired_.count(w) ? lostWorkers : w]; };
    for (const auto& [w, jobs] : jobs_) bucket(w).first.insert(jobs.ids.begin(), jobs.ids.end());
    for (const auto& [w, got] : answeredBy_) {
      auto& b = bucket(w);
      b.second.insert(b.second.end(), got.begin(), got.end());
    }
    for (auto& [w, b] : buckets) {
      auto& [sent, got] = b;
      if (sent.empty()) continue;
      const std::size_t count = sent.size();
      const std::string who = w == lostWorkers ? "the adopters of the workers lost in this exchange" : "worker '" + w + "'";
      for (std::uint32_t id : got) {
        auto it = sent.find(id);
        if (it == sent.end())
          throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(exchange) + ": " + who +
                                   " answered unit cell " + std::to_string(id) +
                                   (std::count(got.begin(), got.end(), id) > 1 ? " twice" : ", whose job it was not sent"));
        sent.erase(it);
      }
      if (!sent.empty())
        throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(exchange) + ": " + who +
                                 " left " + std::to_string(sent.size()) + (w == lostWorkers ? " of their " : " of its ") +
                                 std::to_string(count) + " jobs unanswered (unit cell " + std::to_string(*sent.begin()) + " first)");
      answeredJobs_ += got.size();
    }
  }

  /// The tightest fine step any worker reported over the run (Liu Eqs. 63-64):
  /// [relaxation dt, dt_cr, omega_max, xi, omega_n, omega_theta].
  void noteFineTimeStep(proto::NamedArray::Reader a) {
    if (a.getName() != proto::FINE_TIME_STEP_ARRAY || a.getValues().size() != 6) return;
    const auto v = wire::view(a.getValues());
    if (v[1] > 0.0 && (fine_[1] == 0.0 || v[1] < fine_[1])) std::copy(v.begin(), v.end(), fine_.begin());
    if (fine_[0] == 0.0) fine_[0] = v[0];
  }

 public:
  /// Liu Eqs. 63-66: the fine (unit cell, Eq. 63) and coarse (FEM, Eq. 65)
  /// critical steps, the steps used, and alpha = dt_cr^c / dt_cr^f (Eq. 66),
  /// the optimal ratio of coarse to fine step.
  void conclude(RunReport& report) const override {
    double coarseCritical = 0.0;
    for (const auto& p : report.peers)
      if (p.name == fem_) coarseCritical = p.criticalDt;
    auto& f = report.figures;
    f["fine_dt_s"] = fine_[0];
    f["fine_critical_dt_s"] = fine_[1];
    f["fine_omega_max_rad_s"] = fine_[2];
    f["fine_damping_fraction"] = fine_[3];
    f["coarse_dt_s"] = dt_;
    f["coarse_critical_dt_s"] = coarseCritical;
    if (fine_[1] > 0.0) f["fine_dt_over_critical"] = fine_[0] / fine_[1];
    if (coarseCritical > 0.0) f["coarse_dt_over_critical"] = dt_ / coarseCritical;
    if (fine_[1] > 0.0 && coarseCritical > 0.0) f["time_step_ratio_alpha"] = coarseCritical / fine_[1];
    f["answered_cell_jobs"] = static_cast<double>(answeredJobs_);
    if (moveOnLoss_) {
      f["lost_workers"] = static_cast<double>(retired_.size());
      f["moved_unit_cells"] = static_cast<double>(movedCells_);
    }
    f["failed_cell_jobs"] = static_cast<double>(failedJobs_);
    f["failed_cells"] = static_cast<double>(failedCells_.size());
    if (failedJobs_ > 0)
      report.warnings.push_back("coupling '" + name() + "': " + std::to_string(failedJobs_) + " unit-cell jobs of " +
                                std::to_string(failedCells_.size()) +
                                " cells ended outside their relaxation settings and were accepted as they stood "
                                "(on_failure: continue; series " + name() + "/failed_cells, the log names them)");
    if (nonlocal_ && !inelastic_) {
      f["nonlocal_local_fraction"] = localFraction_;
      f["nonlocal_smallest_eigenvalue"] = smallestEigenvalue_;
    }
    if (inelastic_) {
      f["nonlocal_over_nonlocal"] = inelastic_->overNonlocal();
      f["nonlocal_max_inelastic_correction_rms_pa"] = maxCorrection_;
    }
  }

  // The failure counts of the report. Which cells are failing now comes back
  // with the replay of the checkpoint's replies, which counts nothing.
  bool keepsState() const override { return true; }
  void save(util::BinaryWriter& out) const override {
    out.pod(failedJobs_);
    out.vec(std::vector<std::uint32_t>(failedCells_.begin(), failedCells_.end()));
    if (inelastic_) inelastic_->save(out), out.pod(maxCorrection_);
    out.pod(fine_);  // the run's smallest fine critical step so far: Liu's time-step figures
    out.pod(answeredJobs_);
    saveOwners(out);
  }
  void restore(util::BinaryReader& in) override {
    failedJobs_ = in.pod<std::uint64_t>("failed unit-cell jobs");
    const auto cells = in.vec<std::uint32_t>("failed unit cells");
    if (cells.size() > failedJobs_) in.fail("failed unit cells", "more cells than failed jobs");
    failedCells_ = std::set<std::uint32_t>(cells.begin(), cells.end());
    if (inelastic_) inelastic_->restore(in), maxCorrection_ = in.pod<double>("largest inelastic correction");
    fine_ = in.pod<decltype(fine_)>("fine time step figures");
    answeredJobs_ = in.pod<std::uint64_t>("answered unit-cell jobs");
    restoreOwners(in);
  }

 private:
  /// Which worker holds each cell and which workers the run lost (moved
  /// cells live on their adopters' checkpoints, not where they were loaded).
  void saveOwners(util::BinaryWriter& out) const {
    std::vector<std::uint32_t> ids, holders, retired;
    const auto indexOf = [&](const std::string& w) {
      return static_cast<std::uint32_t>(std::find(workers_.begin(), workers_.end(), w) - workers_.begin());
    };
    for (const auto& [id, w] : owner_) ids.push_back(id), holders.push_back(indexOf(w));
    for (const auto& w : retired_) retired.push_back(indexOf(w));
    out.vec(ids), out.vec(holders), out.vec(retired);
    out.pod(movedCells_);
  }
  void restoreOwners(util::BinaryReader& in) {
    const auto ids = in.vec<std::uint32_t>("unit-cell ids"), holders = in.vec<std::uint32_t>("unit-cell workers");
    const auto retired = in.vec<std::uint32_t>("lost workers");
    if (ids.size() != holders.size()) in.fail("unit-cell workers", "not one per cell id");
    const auto worker = [&](std::uint32_t k) -> const std::string& {
      if (k >= workers_.size()) in.fail("unit-cell workers", "worker index " + std::to_string(k) + " out of range");
      return workers_[k];
    };
    owner_.clear(), cellsOf_.clear(), retired_.clear();
    for (std::size_t k = 0; k < ids.size(); ++k) owner_[ids[k]] = worker(holders[k]), cellsOf_[worker(holders[k])].push_back(ids[k]);
    for (std::uint32_t k : retired) retired_.insert(worker(k));
    movedCells_ = in.pod<std::uint64_t>("moved unit cells");
  }

  void append(proto::UnitCellResults::Reader r, const std::string& worker, std::uint64_t exchange) {
    const auto ids = wire::view(r.getCellIds());
    const auto stresses = wire::view(r.getStresses());
    const auto porosities = wire::view(r.getPorosities());
    const auto coordination = wire::view(r.getCoordinationNumbers());
    const auto indices = wire::view(r.getUnbalancedForceIndices());
    const auto steps = wire::view(r.getRelaxationSteps());
    const auto failed = r.getFailed();
    const std::size_t n = ids.size();
    if (stresses.size() != 9 * n || porosities.size() != n || coordination.size() != n || indices.size() != n ||
        steps.size() != n || (failed.size() != 0 && failed.size() != n))
      throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(exchange) + ": worker '" +
                               worker + "' sent " + std::to_string(n) + " cell ids with mismatched result arrays");
    gathered_.ids.insert(gathered_.ids.end(), ids.begin(), ids.end());
    gathered_.stresses.insert(gathered_.stresses.end(), stresses.begin(), stresses.end());
    gathered_.porosities.insert(gathered_.porosities.end(), porosities.begin(), porosities.end());
    gathered_.coordination.insert(gathered_.coordination.end(), coordination.begin(), coordination.end());
    gathered_.indices.insert(gathered_.indices.end(), indices.begin(), indices.end());
    gathered_.steps.insert(gathered_.steps.end(), steps.begin(), steps.end());
    for (std::size_t k = 0; k < n; ++k)
      gathered_.failed.push_back(failed.size() != 0 && failed[static_cast<unsigned>(k)] ? 1 : 0);
  }

  /// Pool statistics per coarse step: what the stability diagnostics look at;
  /// then every cell's own results (one row per coarse step, columns in cell
  /// id order): what a scene that follows one quadrature point reads (L3's
  /// element 9, Liu 2016 Fig. 8).
  void record(const ExchangeContext& ctx) {
    if (!ctx.series || gathered_.ids.empty()) return;
    // In cell id order: which worker answered which cell (moved cells
    // included) changes neither a figure nor the rounding of a sum.
    const std::size_t n = gathered_.ids.size();
    order_.resize(n);
    for (std::size_t k = 0; k < n; ++k) order_[k] = k;
    std::sort(order_.begin(), order_.end(),
              [&](std::size_t a, std::size_t b) { return gathered_.ids[a] < gathered_.ids[b]; });
    recordPool(ctx);
    recordCells(ctx);
  }

  void recordPool(const ExchangeContext& ctx) const {
    const auto n = static_cast<double>(gathered_.ids.size());
    double porosity = 0.0, coordination = 0.0, maxIndex = 0.0, maxSteps = 0.0, pressure = 0.0, failed = 0.0;
    for (const std::size_t k : order_) {
      const double* sigma = &gathered_.stresses[9 * k];
      pressure -= (sigma[0] + sigma[4] + sigma[8]) / (3.0 * n);
      porosity += gathered_.porosities[k] / n;
      coordination += gathered_.coordination[k] / n;
      maxIndex = std::max(maxIndex, gathered_.indices[k]);
      maxSteps = std::max(maxSteps, static_cast<double>(gathered_.steps[k]));
      failed += gathered_.failed[k];
    }
    ctx.series->append(name() + "/mean_pressure", pressure);
    ctx.series->append(name() + "/mean_porosity", porosity);
    ctx.series->append(name() + "/mean_coordination", coordination);
    ctx.series->append(name() + "/max_unbalanced_force_index", maxIndex);
    ctx.series->append(name() + "/max_relaxation_steps", maxSteps);
    ctx.series->append(name() + "/failed_cells", failed);
  }

  /// cell_ids (the column order), cell_porosity, cell_coordination, and
  /// cell_stress (9 values per cell, row-major, the Cauchy stress the cell
  /// returned in its frame, Eq. 44b, tension positive).
  void recordCells(const ExchangeContext& ctx) {
    const std::size_t n = gathered_.ids.size();
    cellIds_.resize(n), cellPorosity_.resize(n), cellCoordination_.resize(n), cellStress_.resize(9 * n);
    for (std::size_t c = 0; c < n; ++c) {
      const std::size_t k = order_[c];
      cellIds_[c] = static_cast<double>(gathered_.ids[k]);
      cellPorosity_[c] = gathered_.porosities[k];
      cellCoordination_[c] = gathered_.coordination[k];
      std::copy_n(gathered_.stresses.begin() + static_cast<std::ptrdiff_t>(9 * k), 9,
                  cellStress_.begin() + static_cast<std::ptrdiff_t>(9 * c));
    }
    ctx.series->append(name() + "/cell_ids", cellIds_);
    ctx.series->append(name() + "/cell_porosity", cellPorosity_);
    ctx.series->append(name() + "/cell_coordination", cellCoordination_);
    ctx.series->append(name() + "/cell_stress", cellStress_);
  }

  std::string fem_;
  std::vector<std::string> workers_;
  double radius_ = 0.0;  // nonlocal interaction radius R; 0: local
  double localFraction_ = 0.0;  // beta: the share of a point's own increment, Eringen's two-phase blend
  double smallestEigenvalue_ = 1.0;
  std::string nonlocalKey_;
  std::vector<std::uint32_t> ids_, nonlocalIds_;
  std::vector<double> increments_, positions_, smoothed_;
  double dt_ = 0.0;
  std::optional<NonlocalOperator> nonlocal_;
  std::optional<InelasticStressAveraging> inelastic_;  // averages: inelastic_stress
  double maxCorrection_ = 0.0;                         // its largest RMS correction over the run [Pa]
  std::map<std::uint32_t, std::string> owner_;              // cell id -> worker
  std::map<std::string, std::vector<std::uint32_t>> cellsOf_;  // worker -> its cells
  std::map<std::string, WorkerJobs> jobs_;
  std::map<std::string, std::vector<std::uint32_t>> answeredBy_;  // this step's answers, per worker
  GatheredResults gathered_;
  std::vector<std::size_t> order_;  // record: gathered index of each cell, by id
  std::vector<double> cellIds_, cellPorosity_, cellCoordination_, cellStress_;
  std::array<double, 6> fine_{};  // see noteFineTimeStep
  std::set<std::uint32_t> failing_, failedCells_;  // failing now; failed at least once
  std::uint64_t failedJobs_ = 0;
  std::uint64_t answeredJobs_ = 0;
  // on_worker_loss: move
  struct SentJobs {
    std::uint64_t exchange = 0;  // the exchange whose requests carried them
    double dt = 0.0;
    std::vector<std::uint32_t> ids;
    std::vector<double> increments;
  };
  bool moveOnLoss_ = false;
  std::set<std::string> retired_;                          // workers the run lost (their cells moved)
  std::vector<SentJobs> sent_;                             // the jobs since the latest checkpoint
  std::optional<std::uint64_t> checkpointExchange_;        // the latest checkpoint's exchange
  std::map<std::uint32_t, std::string> holderAtCheckpoint_;  // whose checkpoint file holds each cell
  std::vector<std::vector<std::pair<WorkerJobs, double>>> replay_;  // the last hand-over's jobs (CellAdoption views)
  std::uint64_t movedCells_ = 0;
};

const bool registered = CouplingRegistry::add(
    "gmh", [](const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<GmhCoupling>(name, m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
