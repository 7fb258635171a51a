#include "cosim/coupler/run/coupler_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <sstream>

#include "cosim/coupler/analysis/progress.hpp"
#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/analysis/run_report.hpp"
#include "cosim/coupler/launch/process_group.hpp"
#include "cosim/coupler/launch/slurm.hpp"
#include "cosim/coupler/run/checkpoint_store.hpp"
#include "cosim/coupler/run/solver_check.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/util/cpu_affinity.hpp"
#include "cosim/util/host_cpu_time.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/clock.hpp"
#include "cosim/wire/log.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;

namespace {

/// Steal above this share of the machine's CPU time earns the run a warning,
/// once it is long enough to matter: /proc/stat counts in 10 ms ticks, so one
/// tick in a 0.1 s run would already read as 5 %.
constexpr double kStealWarning = 0.05;
constexpr double kStealWarningMinS = 0.5;

/// A refusal before time zero (handshake, capability, setup or stability).
struct Refused : std::runtime_error {
  explicit Refused(const std::string& message, std::string faultyPeer = {})
      : std::runtime_error(message), peer(std::move(faultyPeer)) {}
  std::string peer;  // a peer known to be broken, not to be waited for
};
struct Interrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string joined(const std::vector<std::string>& items, const std::string& separator = ", ") {
  std::string out;
  for (const auto& i : items) out += (out.empty() ? "" : separator) + i;
  return out;
}

// A solver's latest reply is its setupDone (before the first exchange) or its last advanced.
proto::CouplingData::Reader outputsOf(const wire::InMessage& reply) {
  auto body = reply.envelope().getBody();
  return body.isAdvanced() ? body.getAdvanced().getOutputs() : body.getSetupDone().getOutputs();
}
capnp::List<proto::NamedValue>::Reader energiesOf(const wire::InMessage& reply) {
  auto body = reply.envelope().getBody();
  return body.isAdvanced() ? body.getAdvanced().getEnergies() : body.getSetupDone().getEnergies();
}

std::vector<std::string> launchArgs(const SolverSpec& s, const std::string& endpoint) {
  std::vector<std::string> args{"--endpoint", endpoint, "--name", s.name};
  args.insert(args.end(), s.args.begin(), s.args.end());
  return args;
}

class CouplerRun final : public ExchangeDriver {
 public:
  CouplerRun(const Scene& scene, const RunOptions& options)
      : scene_(scene), options_(options), runDir_(options.outDir.empty() ? scene.output.dir : options.outDir),
        progress_(options.progress), checkpoints_(runDir_) {
    for (const auto& s : scene.solvers) names_.push_back(s.name);
    report_.scene = scene.name;
    report_.sceneFile = scene.file;
    report_.runDir = runDir_.string();
  }

  int run() {
    const double start = monotonicSeconds();
    const auto hostAtStart = util::readHostCpuTimes();
    try {
      prepareOutput();
      applyPlacement();
      startPeers();
      setUpPeers();
      report_.startupS = monotonicSeconds() - start;
      const double loopStart = monotonicSeconds();
      report_.status = "running";
      scene_.schedule->run(*this);
      report_.loopS = monotonicSeconds() - loopStart;
      finish("completed", stoppedByOption() ? "stopped after " + std::to_string(completed_) + " exchanges (--exchanges)" : "",
             kExitOk);
    } catch (const config::ConfigError& e) {
      finish("refused", e.what(), kExitBadConfig);
    } catch (const Refused& e) {
      if (!e.peer.empty()) faulty_.insert(e.peer);
      finish("refused", e.what(), kExitRefused);
    } catch (const Interrupted& e) {
      finish("interrupted", e.what(), kExitInterrupted);
    } catch (const wire::PeerFault& e) {
      faulty_.insert(e.peer());
      std::string message = e.what();
      for (const auto& c : scene_.couplings)
        if (const auto loss = c->describeLoss(e.peer()); !loss.empty()) message += "; " + loss;
      finish(report_.status == "running" ? "failed" : "refused", message,
             report_.status == "running" ? kExitPeerFault : kExitRefused);
    } catch (const std::exception& e) {
      finish("failed", e.what(), report_.status == "running" ? kExitPeerFault : kExitFailure);
    }
    if (report_.loopS == 0.0 && report_.startupS > 0.0) report_.loopS = monotonicSeconds() - start - report_.startupS;
    report_.wallS = monotonicSeconds() - start;
    noteHostLoad(hostAtStart);
    return conclude();
  }

  bool stoppedByOption() const {
    return options_.stopAfter && completed_ >= *options_.stopAfter && completed_ < scene_.schedule->exchanges();
  }

  // ExchangeDriver
  const std::vector<std::string>& solverNames() const override { return names_; }
  double time() const override { return time_; }
  std::uint64_t completedExchanges() const override { return completed_; }
  bool stopRequested() const override {
    return (options_.stopAfter && completed_ >= *options_.stopAfter) || (scene_.reference && scene_.reference->finished());
  }

  void exchange(const std::map<std::string, AdvancePlan>& plans, double newTime) override {
    checkInterrupt();
    ++exchange_;
    session_->setContext(context());
    forgetLostReplies();
    std::vector<std::pair<std::string, std::uint64_t>> pending;
    std::map<std::string, double> sentAt;
    std::set<std::string> owed;  // workers lost in this exchange whose answers their adopters gave
    // A row records every solver's latest reply. Where only some solvers
    // advance in this exchange (a sequential schedule's first half), the row
    // of the next exchange records their reply to this one: ask them now.
    const bool row = recordsThisExchange() ||
                     (plans.size() < solverNames().size() && recordsExchange(exchange_ + 1));
    for (const auto& [name, plan] : plans) {
      if (lost_.count(name)) continue;
      auto& inputs = inputs_[name];
      wire::OutMessage m = session_->message(name, inputs.words());
      {
        ScopedTimer t(report_.mappingS);
        auto adv = m.envelope().getBody().initAdvance();
        adv.setSteps(plan.steps);
        adv.setDt(plan.dt);
        adv.setTime(time_);
        adv.setExchange(exchange_);
        adv.setWantEnergies(wantsEnergies(row));
        adv.setWantCriticalDt(row);
        inputs.build(adv.initInputs());
      }
      // The send is part of the round trip, not of the mapping: where the
      // processes share a CPU the solver may run its whole step inside it,
      // and that time is already counted between sentAt and the reply.
      sentAt[name] = monotonicSeconds();
      try {
        pending.emplace_back(name, session_->request(name, m));
      } catch (const wire::PeerFault& e) {
        handOverOrRethrow(e, true, owed);
      }
    }
    auto replies = awaitRepliesHandingOver(pending, plans, owed);
    standInReplies(owed);
    time_ = newTime;
    std::set<std::string> advanced(owed.begin(), owed.end());
    std::vector<RoundTrip> round;
    for (std::size_t i = 0; i < replies.size(); ++i) {
      const auto& name = pending[i].first;
      round.push_back(takeAdvanced(name, std::move(replies[i]), sentAt.at(name), plans.at(name).dt));
      advanced.insert(name);
    }
    communication_.add(std::move(round));
    lastAdvanced_ = advanced;
    runCouplings(advanced);
    record();
    completed_ = exchange_;
    if (scene_.output.checkpointInterval > 0 &&
        exchange_ % static_cast<std::uint64_t>(scene_.output.checkpointInterval) == 0)
      checkpoint();
    progress_.update(time_, scene_.schedule->endTime(), exchange_, scene_.schedule->exchanges());
  }

 private:
  void checkInterrupt() const {
    if (const int sig = stopSignal())
      throw Interrupted("stopped by signal " + std::to_string(sig) + " at exchange " + std::to_string(exchange_));
  }

  /// The replies of this exchange; a participant lost meanwhile whose work a
  /// coupling can move (gmh, on_worker_loss: move) is handed over and the
  /// others' replies are still taken, also when one is lost in the middle of
  /// a hand-over (its cells, adopted ones included, move on again). Any other
  /// fault stops the run.
  std::vector<wire::Reply> awaitRepliesHandingOver(std::vector<std::pair<std::string, std::uint64_t>>& pending,
                                                   const std::map<std::string, AdvancePlan>& plans,
                                                   std::set<std::string>& owed) {
    while (true) {
      try {
        takeAdoptions();
        return session_->awaitReplies(pending);
      } catch (const wire::PeerFault& e) {
        handOverOrRethrow(e, plans.count(e.peer()) > 0, owed);
        std::erase_if(pending, [&](const auto& p) { return p.first == e.peer(); });
      }
    }
  }

  /// The answers of the adoptions in flight: those to the jobs of this
  /// exchange stand in for the lost workers' replies.
  void takeAdoptions() {
    if (adoptions_.empty()) return;
    std::vector<std::pair<std::string, std::uint64_t>> pending;
    for (const auto& a : adoptions_) pending.emplace_back(a.adopter, a.seq);
    auto replies = session_->awaitReplies(pending);
    for (std::size_t i = 0; i < replies.size(); ++i)
      if (adoptions_[i].answersNow) adoptedAnswers_.emplace_back(adoptions_[i].adopter, std::move(replies[i]));
    adoptions_.clear();
  }

  /// Called inside a handler of e. The lost worker's cells go to the others
  /// from the latest checkpoint (AdoptCells, answered in takeAdoptions).
  void handOverOrRethrow(const wire::PeerFault& e, bool owesReply, std::set<std::string>& owed) {
    const std::string lost = e.peer();
    Coupling* coupling = nullptr;
    for (const auto& c : scene_.couplings)
      if (c->canHandOver(lost)) coupling = c.get();
    if (!e.gone() || !coupling) throw;
    const auto point = checkpoints_.latest();
    std::vector<CellAdoption> adoptions;
    try {
      if (!point) throw std::runtime_error("its work cannot move: no checkpoint has been taken yet (output.checkpoint_interval)");
      adoptions = coupling->handOver(lost, exchange_);
    } catch (const std::runtime_error& why) {
      throw wire::PeerFault(lost, std::string(e.what()) + "; " + why.what(), true);
    }
    processes_.kill(lost);  // a hung one; a dead one is reaped already
    session_->dropPeer(lost);
    lost_.insert(lost);
    // What it was adopting, or had adopted in this exchange, moves on with
    // its own cells (the coupling counts them as its), answered anew.
    std::erase_if(adoptions_, [&](const InFlightAdoption& a) { return a.adopter == lost; });
    std::erase_if(adoptedAnswers_, [&](const auto& answer) { return answer.first == lost; });
    std::size_t cells = 0;
    std::string where;
    for (const auto& a : adoptions) {
      adoptions_.push_back({a.adopter, requestAdoption(a, point->dir), a.answersNow});
      cells += a.ids.size();
      where += (where.empty() ? "" : ", ") + std::to_string(a.ids.size()) + " to '" + a.adopter + "'";
    }
    // Its last reply stays until the next exchange starts: what this exchange's
    // couplings, and a checkpoint right after it, still read.
    if (owesReply) owed.insert(lost);
    const std::string m = "worker '" + lost + "' lost " + context() + " (" + e.what() + "): its " +
                          std::to_string(cells) + " unit cells moved from the checkpoint of exchange " +
                          std::to_string(point->exchange) + " (" + where + "), their jobs since replayed";
    log::warn(m);
    report_.warnings.push_back(m);
  }

  std::uint64_t requestAdoption(const CellAdoption& a, const fs::path& checkpointDir) {
    const auto put = [](auto list, const auto& values) { std::copy(values.begin(), values.end(), wire::view(list).begin()); };
    wire::OutMessage m = session_->message(a.adopter, 256 + a.ids.size() + 12 * a.jobs.size() * a.ids.size());
    auto adopt = m.envelope().getBody().initAdoptCells();
    adopt.setPath(fs::absolute(CheckpointStore::solverCheckpoint(checkpointDir, a.source)).string());
    put(adopt.initCellIds(static_cast<unsigned>(a.ids.size())), a.ids);
    auto jobs = adopt.initJobs(static_cast<unsigned>(a.jobs.size()));
    for (unsigned k = 0; k < a.jobs.size(); ++k) {
      put(jobs[k].initCellIds(static_cast<unsigned>(a.jobs[k].cellIds.size())), a.jobs[k].cellIds);
      put(jobs[k].initStrainIncrements(static_cast<unsigned>(a.jobs[k].strainIncrements.size())),
          a.jobs[k].strainIncrements);
      jobs[k].setDt(a.jobs[k].dt);
    }
    return session_->request(a.adopter, m);
  }

  /// The replies of the workers lost in this exchange, made of their
  /// adopters' answers: all of them in the first one's (a cell may have
  /// moved twice, so who answers for whom is the pool's business; the gmh
  /// coupling checks the lost workers' jobs against these answers together).
  void standInReplies(const std::set<std::string>& owed) {
    std::vector<proto::UnitCellResults::Reader> answers;
    std::size_t bytes = 0;
    for (const auto& [adopter, r] : adoptedAnswers_) {
      for (auto l : r.message.envelope().getBody().getCellsAdopted().getOutputs().getUnitCellResults()) answers.push_back(l);
      bytes += r.message.sizeInBytes();
    }
    for (const auto& lost : owed) {
      const bool first = lost == *owed.begin();
      wire::OutMessage m(256 + (first ? bytes / sizeof(capnp::word) : 0));
      auto advanced = m.envelope().getBody().initAdvanced();
      advanced.setTime(time_);
      auto out = advanced.initOutputs().initUnitCellResults(first ? static_cast<unsigned>(answers.size()) : 0u);
      for (unsigned k = 0; first && k < answers.size(); ++k) out.setWithCaveats(k, answers[k]);
      latest_.insert_or_assign(lost, wire::InMessage::decode(m.frames()));
      energySource_.erase(lost);
      keepViews(lost);
    }
    adoptedAnswers_.clear();
  }

  void forget(const std::string& solver) {
    latest_.erase(solver), outputs_.erase(solver), energies_.erase(solver), energySource_.erase(solver);
  }

  /// A lost worker's stand-in reply served the exchange it was lost in (and a
  /// checkpoint taken right after it); the couplings no longer see it.
  void forgetLostReplies() {
    for (const auto& name : lost_) forget(name);
  }

  /// The solvers this run has (all but the workers it lost and moved the work of).
  std::vector<const SolverSpec*> activeSolvers() const {
    std::vector<const SolverSpec*> active;
    for (const auto& s : scene_.solvers)
      if (!lost_.count(s.name)) active.push_back(&s);
    return active;
  }

  void prepareOutput() {
    if (options_.resume) return prepareResume();
    fs::create_directories(runDir_);
    fs::remove_all(runDir_ / "checkpoints");  // a fresh run must never resume from an older one's state
    h5_.emplace(io::H5File::create(runDir_ / "coupler.h5"));
    h5_->setAttribute("/", "scene", scene_.name);
    h5_->setAttribute("/", "scene_file", fs::absolute(scene_.file).string());
    h5_->setAttribute("/", "units", "SI");
    h5_->setAttribute("/", "protocol", std::to_string(proto::PROTOCOL_MAJOR) + "." + std::to_string(proto::PROTOCOL_MINOR));
    series_.emplace(*h5_, "/series");
    series_->setUnits("time", "s");
    series_->flush();
  }

  void prepareResume() {
    try {
      resumeFrom_ = checkpoints_.latest();
    } catch (const std::runtime_error& e) {
      throw Refused(e.what());  // a corrupt state: nothing has started yet
    }
    if (!resumeFrom_)
      throw Refused("nothing to resume in " + runDir_.string() + ": no complete checkpoint (set output.checkpoint_interval)");
    if (CheckpointStore::sceneText(*resumeFrom_) != scene_.text)
      throw Refused("cannot resume: " + scene_.file + " differs from the scene the run in " + runDir_.string() +
                    " was started with (saved in " + resumeFrom_->dir.string() + ")");
    lost_ = CheckpointStore::lostSolvers(resumeFrom_->dir);
    for (const auto* solver : activeSolvers())
      for (const auto& file : {CheckpointStore::solverCheckpoint(resumeFrom_->dir, solver->name),
                               CheckpointStore::solverLastReply(resumeFrom_->dir, solver->name)})
        if (!fs::is_regular_file(file))
          throw Refused(resumeFrom_->dir.string() + ": the checkpoint lacks solver '" + solver->name + "''s state (" +
                            file.filename().string() + "); resume from an earlier one by removing this directory",
                        solver->name);
    // A reference solution continues from what it had gathered up to the
    // checkpoint; without that state (no analysis state in the checkpoint) it
    // would see only the exchanges after the resume, so the resume is refused.
    if (scene_.reference && !fs::exists(CheckpointStore::analysisState(resumeFrom_->dir)))
      throw Refused("cannot resume: " + resumeFrom_->dir.string() + " holds no state of the analysis '" +
                    scene_.reference->kind() + "' (" + CheckpointStore::analysisState(resumeFrom_->dir).filename().string() +
                    "), which would then cover only the exchanges after the checkpoint; start the run again");
    h5_.emplace(io::H5File::openForAppend(runDir_ / "coupler.h5"));
    series_.emplace(*h5_, "/series");
    // Each series as it stood at the checkpoint; older checkpoints: the setup
    // row and the rows of the exchanges before it.
    if (resumeFrom_->seriesRows) series_->resumeAt(*resumeFrom_->seriesRows);
    else series_->resumeAt(resumeFrom_->exchange / static_cast<std::uint64_t>(scene_.output.seriesEvery) + 1);
    report_.resumedFrom = std::make_pair(resumeFrom_->exchange, resumeFrom_->time);
    log::info("resuming from exchange " + std::to_string(resumeFrom_->exchange) + " (t = " +
              std::to_string(resumeFrom_->time) + " s)");
  }

  void checkpoint() {
    const auto dir = checkpoints_.begin(exchange_);
    std::size_t lostBefore = lost_.size();
    std::set<std::string> owed;
    auto pending = requestCheckpoints(dir);
    awaitRepliesHandingOver(pending, {}, owed);
    adoptedAnswers_.clear();  // the lost workers answered this exchange before they were lost
    // Moved from the previous checkpoint: the next requests go to the
    // adopters (restaged as a resumed run restages them), whose files must
    // now hold the adopted cells too; again while the round loses a worker.
    while (lost_.size() != lostBefore) {
      lostBefore = lost_.size();
      runCouplings(lastAdvanced_, true);
      auto again = requestCheckpoints(dir);
      awaitRepliesHandingOver(again, {}, owed);
      adoptedAnswers_.clear();
    }
    CheckpointStore::saveLostSolvers(dir, lost_);
    for (const auto& [name, msg] : latest_) msg.save(CheckpointStore::solverLastReply(dir, name).string());
    if (scene_.reference) saveAnalysis(CheckpointStore::analysisState(dir));
    if (keepsCouplingState()) saveCouplings(CheckpointStore::couplingState(dir));
    series_->flush();
    checkpoints_.commit(exchange_, time_, scene_.text, series_->rowCounts());
    for (const auto& c : scene_.couplings) c->checkpointTaken(exchange_);
  }

  /// Asks every solver the run has for its checkpoint in dir. A worker that
  /// cannot be reached is handed over here (its cells move from the previous
  /// checkpoint, checkpoint() asks the adopters again).
  std::vector<std::pair<std::string, std::uint64_t>> requestCheckpoints(const fs::path& dir) {
    std::vector<std::pair<std::string, std::uint64_t>> pending;
    std::set<std::string> owed;
    for (const auto* solver : activeSolvers()) {
      wire::OutMessage m = session_->message(solver->name, 256);
      m.envelope().getBody().initCheckpoint().setPath(
          fs::absolute(CheckpointStore::solverCheckpoint(dir, solver->name)).string());
      try {
        pending.emplace_back(solver->name, session_->request(solver->name, m));
      } catch (const wire::PeerFault& e) {
        handOverOrRethrow(e, false, owed);
      }
    }
    return pending;
  }

  /// After setup: every solver restores its checkpoint; the couplings restage
  /// the inputs from the replies the checkpoint kept.
  void restoreFromCheckpoint() {
    const auto& point = *resumeFrom_;
    std::vector<std::pair<std::string, std::uint64_t>> pending;
    for (const auto* solver : activeSolvers()) {
      wire::OutMessage m = session_->message(solver->name, 256);
      m.envelope().getBody().initRestore().setPath(
          fs::absolute(CheckpointStore::solverCheckpoint(point.dir, solver->name)).string());
      pending.emplace_back(solver->name, session_->request(solver->name, m));
    }
    auto replies = session_->awaitReplies(pending);
    for (std::size_t i = 0; i < replies.size(); ++i) {
      const double t = replies[i].message.envelope().getBody().getRestored().getTime();
      if (t != point.time)
        log::warn("solver '" + pending[i].first + "' restored to t = " + std::to_string(t) + " s, the checkpoint is at t = " +
                  std::to_string(point.time) + " s");
    }
    for (const auto& s : scene_.solvers) {
      // A lost worker's stand-in reply, kept where the checkpoint followed the exchange it was lost in.
      if (lost_.count(s.name) && !fs::exists(CheckpointStore::solverLastReply(point.dir, s.name))) continue;
      try {
        latest_.insert_or_assign(s.name, wire::InMessage::load(CheckpointStore::solverLastReply(point.dir, s.name).string()));
      } catch (const wire::MalformedMessage& e) {
        throw Refused(std::string("cannot resume: solver '") + s.name + "''s last reply in the checkpoint: " + e.what(), s.name);
      }
      keepViews(s.name);
    }
    exchange_ = completed_ = point.exchange;
    time_ = point.time;
    if (scene_.reference) restoreAnalysis(CheckpointStore::analysisState(point.dir));
    restoreCouplings(CheckpointStore::couplingState(point.dir));
    for (const auto& c : scene_.couplings) c->checkpointTaken(point.exchange);
    runCouplings({names_.begin(), names_.end()}, true);
  }

  static constexpr std::uint64_t kCouplingMagic = 0x31474e4c50554f43;  // "COUPLNG1"

  bool keepsCouplingState() const {
    return std::any_of(scene_.couplings.begin(), scene_.couplings.end(), [](const auto& c) { return c->keepsState(); });
  }

  /// Each coupling that keeps state: its name, then its record.
  void saveCouplings(const fs::path& file) const {
    std::ofstream out(file, std::ios::binary);
    util::BinaryWriter w(out);
    w.pod(kCouplingMagic);
    for (const auto& c : scene_.couplings) {
      if (!c->keepsState()) continue;
      w.vec(std::vector<char>(c->name().begin(), c->name().end()));
      c->save(w);
    }
    if (!out) throw std::runtime_error(file.string() + ": cannot write the couplings' state");
  }

  /// The couplings continue their counts from the checkpoint. A checkpoint
  /// without the couplings' state still resumes (the counts are report
  /// figures, not physics), and the report says they start at the resume.
  void restoreCouplings(const fs::path& file) {
    if (!keepsCouplingState()) return;
    if (!fs::exists(file)) {
      const std::string m = "the checkpoint holds no state of the couplings (" + file.filename().string() +
                            "): their counts in the report cover the exchanges after the resume only";
      log::warn(m);
      report_.warnings.push_back(m);
      return;
    }
    std::ifstream in(file, std::ios::binary);
    util::BinaryReader r(in, file.string());
    if (r.pod<std::uint64_t>("couplings' state") != kCouplingMagic) r.fail("couplings' state", "not a couplings record");
    for (const auto& c : scene_.couplings) {
      if (!c->keepsState()) continue;
      const auto name = r.vec<char>("coupling name");
      if (std::string(name.begin(), name.end()) != c->name())
        r.fail("coupling name", "expected '" + c->name() + "', found '" + std::string(name.begin(), name.end()) + "'");
      c->restore(r);
    }
    if (in.peek() != std::char_traits<char>::eof()) r.fail("couplings' state", "bytes left after the records");
  }

  static constexpr std::uint64_t kAnalysisMagic = 0x31534c414e41534f;  // "OSANALS1"

  void saveAnalysis(const fs::path& file) const {
    std::ofstream out(file, std::ios::binary);
    util::BinaryWriter w(out);
    w.pod(kAnalysisMagic);
    scene_.reference->save(w);
    if (!out) throw std::runtime_error(file.string() + ": cannot write the analysis state");
  }

  /// The reference solution continues from what it had gathered up to the
  /// checkpoint (prepareResume made sure the file is there).
  void restoreAnalysis(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    util::BinaryReader r(in, file.string());
    if (r.pod<std::uint64_t>("analysis state") != kAnalysisMagic) r.fail("analysis state", "not an analysis record");
    scene_.reference->restore(r);
    if (in.peek() != std::char_traits<char>::eof()) r.fail("analysis state", "bytes left after the record");
  }

  /// Where a started peer may run, as the report shows it; what went wrong otherwise.
  static std::string cpusOf(std::uint32_t pid) {
    try {
      return util::describeCpus(util::allowedCpusOf(static_cast<int>(pid)));
    } catch (const std::exception& e) {
      return std::string("unknown (") + e.what() + ")";
    }
  }

  /// Before any socket or OpenMP team exists, so that the coupler's threads
  /// and every solver it forks inherit the CPU set.
  void applyPlacement() {
    const auto& p = scene_.placement;
    if (p.kind != PlacementSpec::Kind::packed) return;
    const auto cpus = p.cpus.empty() ? std::vector<int>{util::currentCpu()} : p.cpus;
    try {
      util::restrictProcessTo(cpus);
    } catch (const std::exception& e) {
      throw config::ConfigError({scene_.file + ": placement.cpus: " + e.what()});
    }
    report_.placement = "packed on CPUs " + util::describeCpus(cpus);
    log::info("placement: the coupler and the solvers it starts run on CPUs " + util::describeCpus(cpus));
  }

  /// launch: srun needs an allocation to start steps in, and srun itself.
  void findSlurm() {
    if (!scene_.usesSlurm()) return;
    slurm_ = currentSlurmAllocation();
    if (!slurm_)
      throw Refused(scene_.file + ": solvers with launch: srun start as job steps of a Slurm allocation, and this coupler "
                    "runs in none (SLURM_JOB_ID is not set): submit the run with the script `coupler sbatch " +
                    scene_.file + "` writes, or run it inside salloc");
    slurmPlan_ = planResources(scene_);
    const auto planned = slurmPlan_.components.size();
    if (slurm_->components > 0 && static_cast<std::size_t>(slurm_->components) != planned)
      throw Refused(scene_.file + ": Slurm job " + slurm_->jobId + " is a heterogeneous job of " +
                    std::to_string(slurm_->components) + " components, and the scene's solvers need " +
                    std::to_string(planned) + " (the coupler's and one per kind of job step): submit the script `coupler "
                    "sbatch " + scene_.file + "` writes");
    for (const auto& s : scene_.solvers) {
      if (s.launch != SolverSpec::Launch::srun || s.poolIndex != 0 || nodesOfPool(s) == 0) continue;
      const int group = slurm_->components > 0 ? slurmPlan_.componentOf(s.name) : -1;
      const int nodes = slurmNodesOf(*slurm_, group);
      if (nodes < nodesOfPool(s))
        throw Refused(scene_.file + ": pool '" + s.poolEntry + "' places " + std::to_string(s.workersPerNode) +
                      " workers per node on " + std::to_string(nodesOfPool(s)) + " nodes, and Slurm job " +
                      slurm_->jobId + (group >= 0 ? " (component " + std::to_string(group) + ")" : std::string()) +
                      " has " + std::to_string(nodes) +
                      ": submit the script `coupler sbatch` writes, or raise pool.workers_per_node");
    }
    srun_ = findExecutable("srun", scene_.sceneDir);
    if (srun_.empty()) throw Refused("launch: srun: no srun executable on $PATH");
    if (scene_.transport.kind == wire::TransportOptions::Kind::ipc && slurm_->nodes > 1)
      throw Refused(scene_.file + ": transport kind ipc reaches this host only, and Slurm job " + slurm_->jobId +
                    " spans " + std::to_string(slurm_->nodes) + " nodes (" + slurm_->nodeList +
                    "): leave transport.kind out (tcp with CurveZMQ is the default with launch: srun) or set tcp");
  }

  void startPeers() {
    findSlurm();
    endpoint_ = wire::bindEndpoint(scene_.transport, runDir_);
    std::optional<wire::CurveKeyPair> curve;
    std::vector<std::string> environment;
    // Solvers share the cores with each other and with the coupler, and wait
    // for each other every exchange: OpenMP threads that spin while idle
    // steal the core a peer needs, and the peer's step then takes several
    // times longer.
    if (!std::getenv("OMP_WAIT_POLICY")) environment.emplace_back("OMP_WAIT_POLICY=PASSIVE");
    if (scene_.transport.curve) {
      curve = wire::CurveKeyPair::generate();
      writeServerKey(curve->publicKey);
      environment.push_back("COSIM_SERVER_KEY=" + curve->publicKey);
    }
    socket_.emplace(endpoint_, curve);
    endpoint_ = socket_->endpoint();
    const auto connectTo =
        scene_.usesSlurm() ? wire::connectableFromAnyHost(endpoint_) : wire::connectableEndpoint(endpoint_);
    session_.emplace(*socket_, linkOptions());
    session_->setWatchdog([this] { watchdog(); });
    for (const auto* solver : activeSolvers()) {
      const auto& s = *solver;
      if (s.launch == SolverSpec::Launch::spawn) {
        processes_.spawn(s.name, s.binary, launchArgs(s, connectTo), environment);
      } else if (s.launch == SolverSpec::Launch::srun) {
        // A job step: srun forwards the signals the coupler sends it to the
        // task, and exits when the step ends (cancelled, failed, its node lost).
        const auto args = srunArguments(s, launchArgs(s, connectTo),
                                        slurm_->components > 0 ? slurmPlan_.componentOf(s.name) : -1);
        log::info("starting solver '" + s.name + "' as a job step of Slurm job " + slurm_->jobId + ": srun " + joined(args, " "));
        processes_.spawn(s.name, srun_, args, environment);
      } else {
        log::info("waiting for solver '" + s.name + "' to connect to " + connectTo + " (start it with: " +
                  (s.binary.empty() ? s.kind + "_solver" : s.binary) + " --endpoint " + connectTo + " --name " + s.name +
                  (curve ? " --server-key-file " + fs::absolute(serverKeyPath()).string() : std::string()) + ")");
      }
    }
    std::vector<std::string> expected;
    for (const auto* solver : activeSolvers()) expected.push_back(solver->name);
    session_->awaitHellos(expected, scene_.connectTimeoutS);
    checkHellos();
    for (const auto& n : expected) session_->welcome(n);
  }

  fs::path serverKeyPath() const { return runDir_ / "coupler.pub"; }
  fs::path shmDirectory() const { return runDir_ / "shm"; }

  /// The scene's link, with the directory where shared-memory segments go:
  /// emptied first, so that a run killed before it could remove its segments
  /// leaves nothing in the way of the next.
  wire::LinkOptions linkOptions() const {
    auto link = scene_.link;
    const auto dir = shmDirectory();
    fs::remove_all(dir);
    if (link.shm.mode == wire::ShmOptions::Mode::zmq) return link;
    fs::create_directories(dir);
    fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace);
    link.shm.directory = dir.string();
    return link;
  }

  /// The CurveZMQ public key, readable by this user only: whoever holds it can talk to the run.
  void writeServerKey(const std::string& key) const {
    const auto path = serverKeyPath();
    {
      std::ofstream out(path);
      out << key << "\n";
      if (!out) throw std::runtime_error(path.string() + ": cannot write the server key");
    }
    fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  }

  void watchdog() {
    if (auto exit = processes_.reapOne())
      throw wire::PeerFault(exit->name,
                            "peer '" + exit->name + "' (pid " + std::to_string(exit->pid) + ") " + exit->how + ", " +
                                context() + "; last heard: " + session_->lastHeard(exit->name),
                            true);
    checkInterrupt();
  }

  std::string context() const {
    return exchange_ == 0 ? std::string("before time zero")
                          : "at exchange " + std::to_string(exchange_) + " (t = " + std::to_string(time_) + " s)";
  }

  void checkHellos() {
    std::vector<std::string> problems;
    for (const auto* solver : activeSolvers()) {
      const auto& s = *solver;
      const auto& info = session_->info(s.name);
      const std::string who = "solver '" + s.name + "' (" + (s.binary.empty() ? "attached" : s.binary) + ", " +
                              info.kind + " " + info.version + ")";
      std::string problem;
      if (info.protocolMajor != proto::PROTOCOL_MAJOR)
        problem = who + " speaks protocol " + std::to_string(info.protocolMajor) + "." +
                  std::to_string(info.protocolMinor) + ", the coupler speaks " + std::to_string(proto::PROTOCOL_MAJOR) +
                  "." + std::to_string(proto::PROTOCOL_MINOR) + " (major versions must match)";
      else if (info.kind != s.kind)
        problem = who + " reports kind '" + info.kind + "' but the scene declares kind '" + s.kind + "' (" +
                  scene_.file + ":" + std::to_string(s.line) + ")";
      else
        for (const auto& cap : scene_.requiredCapabilities(s.name))
          if (std::find(info.capabilities.begin(), info.capabilities.end(), cap) == info.capabilities.end()) {
            problem = who + " lacks capability '" + cap + "' that this scene needs (it offers: " +
                      joined(info.capabilities) + ")";
            break;
          }
      if (!problem.empty()) problems.push_back(problem);
    }
    if (problems.empty()) return;
    // Every peer hears why the run will not start, so all of them leave now.
    for (const auto* solver : activeSolvers()) session_->refuse(solver->name, "run refused: " + joined(problems));
    throw Refused(joined(problems));
  }

  void setUpPeers() {
    std::vector<std::pair<std::string, std::uint64_t>> pending;
    for (const auto& c : scene_.couplings) c->stageSetup(inputs_);
    for (const auto* solver : activeSolvers()) {
      const auto& s = *solver;
      auto& inputs = inputs_[s.name];
      wire::OutMessage m = session_->message(s.name, scene_.text.size() / 8 + 256 + inputs.words());
      fillSetup(m.envelope().getBody().initSetup(), scene_, s, inputs, runDir_, resumeFrom_.has_value());
      pending.emplace_back(s.name, session_->request(s.name, m));
    }
    std::vector<wire::Reply> replies;
    try {
      replies = session_->awaitReplies(pending);
    } catch (const wire::PeerFault& e) {
      throw Refused(std::string("setup failed: ") + e.what(), e.peer());
    }
    std::map<std::string, double> critical;
    for (std::size_t i = 0; i < replies.size(); ++i) {
      const auto& name = pending[i].first;
      auto done = replies[i].message.envelope().getBody().getSetupDone();
      critical[name] = done.getCriticalDt();
      if (const auto bad = badCriticalStep(name, critical[name], "at setup")) throw Refused(*bad, name);
      if (const auto bad = nonFiniteEnergy(name, done.getEnergies()))
        throw Refused(*bad + " at setup, before any step: check its material parameters and initial state", name);
      latest_.insert_or_assign(name, std::move(replies[i].message));
      keepViews(name);
    }
    auto limits = critical;
    refusingSceneErrors([&] {
      for (const auto& c : scene_.couplings) c->setupReference(outputs_);
      // dt: auto also respects the stiffness couplings add; a given dt is
      // checked against the solvers' own steps (the coupling bounds are
      // conservative estimates).
      for (const auto& c : scene_.couplings) c->limitCriticalSteps(limits);
    });
    try {
      scene_.schedule->resolveTimeStep(scene_.schedule->autoTimeStep() ? limits : critical, options_.force);
    } catch (const std::runtime_error& e) {
      throw Refused(e.what());
    }
    report_.schedule = scene_.schedule->describe();
    report_.plannedExchanges = scene_.schedule->exchanges();
    report_.endTime = scene_.schedule->endTime();
    for (const auto* solver : activeSolvers()) {
      const auto& s = *solver;
      PeerTiming p;
      p.name = s.name;
      p.kind = session_->info(s.name).kind;
      p.version = session_->info(s.name).version;
      p.criticalDt = p.lastCriticalDt = p.minCriticalDt = critical[s.name];
      if (s.launch == SolverSpec::Launch::spawn) p.cpus = cpusOf(session_->info(s.name).pid);
      timings_[s.name] = p;
    }
    if (resumeFrom_) return restoreFromCheckpoint();
    refusingSceneErrors([&] { runCouplings({names_.begin(), names_.end()}); });
    record();
  }

  /// What the couplings find wrong in the setup replies (a surface or zone the
  /// scene names that a solver did not export) is the scene's fault, found
  /// before time zero: a refusal (exit 3), not a coupler failure.
  template <typename Work>
  static void refusingSceneErrors(Work work) {
    try {
      work();
    } catch (const wire::PeerFault&) {
      throw;
    } catch (const std::runtime_error& e) {
      throw Refused(std::string(e.what()) + " (before time zero: check the scene's coupling and solver keys)");
    }
  }

  /// Takes a solver's reply in; returns its part in the round's timing.
  RoundTrip takeAdvanced(const std::string& name, wire::Reply&& reply, double sentAt, double dt) {
    auto adv = reply.message.envelope().getBody().getAdvanced();
    const RoundTrip trip{sentAt,
                         reply.receivedAt,
                         adv.getComputeSeconds(),
                         adv.getComputeStartedAt(),
                         adv.getAheadSeconds(),
                         adv.getAheadStartedAt()};
    auto& t = timings_[name];
    t.computeS += trip.computeS + trip.aheadS;
    t.aheadS += trip.aheadS;
    t.communicationS +=
        std::max(0.0, trip.receivedAt - trip.sentAt - trip.computeS - aheadInsideRoundTrip(trip));
    if (recordsThisExchange()) noteCriticalStep(name, adv.getCriticalDt(), dt);
    if (const auto bad = nonFiniteEnergy(name, adv.getEnergies()))
      throw wire::PeerFault(name, *bad + " at exchange " + std::to_string(exchange_) + " (t = " + std::to_string(time_) +
                                      " s): the run is unstable");
    // A reply without energies (not asked for) leaves the last ones in force:
    // the message they point into is kept until energies come again.
    const bool fresh = adv.getEnergies().size() > 0;
    auto last = latest_.find(name);
    if (fresh) energySource_.erase(name);
    else if (last != latest_.end() && !energySource_.count(name)) energySource_.emplace(name, std::move(last->second));
    latest_.insert_or_assign(name, std::move(reply.message));
    if (fresh) keepViews(name);
    else outputs_[name] = outputsOf(latest_.at(name));
    return trip;
  }

  /// "solver 'x' reported strain = nan" for the first non-finite energy of a reply.
  static std::optional<std::string> nonFiniteEnergy(const std::string& name, capnp::List<proto::NamedValue>::Reader energies) {
    for (auto e : energies)
      if (!std::isfinite(e.getValue()))
        return "solver '" + name + "' reported " + e.getName().cStr() + " = " + std::to_string(e.getValue());
    return std::nullopt;
  }

  /// A critical step is positive, or 0 for "no limit": NaN, infinite or
  /// negative means the solver's material or state is broken (E = 1e308 gives
  /// an infinite wave speed), and a dt checked against it would pass unseen.
  static std::optional<std::string> badCriticalStep(const std::string& name, double critical, const std::string& when) {
    if (std::isfinite(critical) && critical >= 0.0) return std::nullopt;
    std::ostringstream m;
    m << "solver '" << name << "' reports a critical time step of " << critical << " s " << when
      << " (it must be positive and finite, or 0 for no limit): check its material parameters";
    return m.str();
  }

  /// A solver's stable step can shrink during a run (a Hertz contact's with
  /// the impact speed): each series row records it, and a step above it is
  /// reported once per solver, on stderr and in the run report.
  void noteCriticalStep(const std::string& name, double critical, double dt) {
    if (const auto bad = badCriticalStep(name, critical, "at exchange " + std::to_string(exchange_)))
      throw wire::PeerFault(name, *bad);
    auto& t = timings_[name];
    t.lastCriticalDt = critical;
    if (!(critical > 0.0)) return;
    t.minCriticalDt = t.minCriticalDt > 0.0 ? std::min(t.minCriticalDt, critical) : critical;
    if (dt <= critical || options_.force || !warnedCritical_.insert(name).second) return;
    std::ostringstream m;
    m.precision(6);
    m << "solver '" << name << "' reports a critical step of " << critical << " s at exchange " << exchange_
      << " (t = " << time_ << " s), below the step dt = " << dt
      << " s it takes: the run may go unstable (lower dt, or use dt: auto)";
    log::warn(m.str());
    report_.warnings.push_back(m.str());
  }

  /// Energies can cost a sweep over a solver's model: ask for them only when
  /// a series row will record this reply, or an analysis or coupling reads them.
  bool wantsEnergies(bool row) const {
    if (row) return true;
    if (scene_.reference && scene_.reference->usesEnergies()) return true;
    return std::any_of(scene_.couplings.begin(), scene_.couplings.end(),
                       [](const auto& c) { return c->usesEnergies(); });
  }

  /// `replay`: the exchange of a checkpoint run again on its saved replies,
  /// to stage the next requests; its series rows are in the file already.
  void runCouplings(const std::set<std::string>& advanced, bool replay = false) {
    ScopedTimer t(report_.mappingS);
    for (auto& [name, inputs] : inputs_) inputs.clear();  // staged views may point into replaced replies
    ExchangeContext ctx{exchange_, time_, outputs_, inputs_,
                        recordsThisExchange() && !replay ? &*series_ : nullptr, &energies_, advanced, replay};
    for (const auto& c : scene_.couplings) c->exchange(ctx);
  }

  /// Rows of /series every output.series_every exchanges, and the last one.
  bool recordsThisExchange() const { return recordsExchange(exchange_); }
  bool recordsExchange(std::uint64_t e) const {
    return e % static_cast<std::uint64_t>(scene_.output.seriesEvery) == 0 || e == scene_.schedule->exchanges() ||
           stopRequested();
  }

  void record() {
    ScopedTimer t(report_.outputS);
    // Decided before the analysis looks: it may end the run at this exchange.
    const bool row = recordsThisExchange();
    if (scene_.reference) observe(row);
    if (exchange_ % static_cast<std::uint64_t>(scene_.output.flushInterval) == 0) series_->flush();
    if (!row) return;
    series_->append("time", time_);
    series_->append("exchange", static_cast<double>(exchange_));
    for (const auto& [name, energies] : energies_) {
      for (auto e : energies) series_->append(name + "/energy/" + e.getName().cStr(), e.getValue());
      series_->append(name + "/compute_s", timings_[name].computeS);
      series_->append(name + "/communication_s", timings_[name].communicationS);
      series_->append(name + "/critical_dt_s", timings_[name].lastCriticalDt);
    }
    for (const auto& r : scene_.output.record) {
      proto::NamedArray::Reader array;
      if (!wire::findArray(outputs_.at(r.solver).getArrays(), r.array, array))
        throw std::runtime_error("output.record: solver '" + r.solver + "' sent no array '" + r.array + "'");
      series_->append(r.solver + "/" + r.array, wire::view(array.getValues()));
    }
  }

  /// The outputs and energies of a solver's latest reply, as views into latest_.
  void keepViews(const std::string& name) {
    outputs_[name] = outputsOf(latest_.at(name));
    energies_.insert_or_assign(name, energiesOf(latest_.at(name)));
  }

  void observe(bool row) {
    scene_.reference->observe(Observation{exchange_, time_, outputs_, energies_, row ? &*series_ : nullptr});
  }

  void finish(const std::string& status, const std::string& message, int code) {
    report_.status = status;
    report_.message = message;
    report_.exitCode = code;
    report_.exchanges = completed_;
    report_.simulatedTime = time_;
    report_.communicationS = communication_.close();
  }

  // Steal time above a few percent means the wall times (and every ratio
  // built on them) measure the neighbours as much as this run.
  void noteHostLoad(const std::optional<util::HostCpuTimes>& atStart) {
    const auto now = util::readHostCpuTimes();
    if (!atStart || !now) return;
    report_.host = *now - *atStart;
    if (const double share = report_.stealShare(); share > kStealWarning && report_.host->stealS >= kStealWarningMinS) {
      std::ostringstream w;
      w.precision(3);
      w << "the hypervisor took " << 100.0 * share << " % of the CPUs' time during the run (steal "
        << report_.host->stealS << " s over " << report_.host->cpus << " CPUs): the wall times are disturbed";
      report_.warnings.push_back(w.str());
    }
  }

  int conclude() {
    progress_.finish();
    if (session_) {
      session_->setWatchdog(nullptr);
      session_->shutdownAll(report_.status, 3.0, faulty_);
      for (auto& [name, t] : timings_) {
        const auto& traffic = session_->traffic(name);
        t.messagesSent = traffic.messagesSent;
        t.messagesReceived = traffic.messagesReceived;
        t.bytesSent = traffic.bytesSent;
        t.bytesReceived = traffic.bytesReceived;
        t.dataPath = session_->sharedMemory(name) ? "shm" : "zmq";
        report_.peers.push_back(t);
      }
    }
    for (const auto& name : faulty_) processes_.kill(name);  // dead or hung: no grace
    processes_.terminateAll(1.0, 2.0);
    for (const auto& [name, energies] : energies_) {
      for (auto e : energies) report_.finalEnergies[name + "." + e.getName().cStr()] = e.getValue();
    }
    if (completed_ > 0)
      for (const auto& c : scene_.couplings) c->conclude(report_);
    if (scene_.reference && completed_ > 0) {
      try {
        scene_.reference->conclude(report_);
      } catch (const std::exception& e) {
        // The run itself went through, but its error figure is missing: not a success.
        if (report_.exitCode == kExitOk) finish("failed", std::string("analysis: ") + e.what(), kExitFailure);
        else log::error(std::string("analysis: ") + e.what());
      }
    }
    try {
      if (series_) {
        series_->flush();
        h5_->setAttribute("/", "status", report_.status);
      }
      if (fs::exists(runDir_)) report_.writeJson(runDir_ / "run_report.json");
    } catch (const std::exception& e) {
      log::error(std::string("could not finish the output: ") + e.what());
    }
    if (report_.exitCode != kExitOk) log::error(report_.message);
    std::cout << report_.text() << std::flush;
    if (socket_) wire::removeIpcEndpoint(endpoint_);
    std::error_code ignored;
    fs::remove_all(shmDirectory(), ignored);  // what no solver mapped yet, and the doorbell
    return report_.exitCode;
  }

  const Scene& scene_;
  RunOptions options_;
  fs::path runDir_;
  ProgressLine progress_;
  std::vector<std::string> names_;
  RunReport report_;
  std::optional<io::H5File> h5_;
  std::optional<io::SeriesWriter> series_;
  std::string endpoint_;
  std::optional<wire::RouterSocket> socket_;
  std::optional<wire::PeerSession> session_;
  ProcessGroup processes_;
  std::set<std::string> faulty_;
  struct InFlightAdoption {
    std::string adopter;
    std::uint64_t seq = 0;
    bool answersNow = false;
  };
  std::vector<InFlightAdoption> adoptions_;  // AdoptCells requests not yet answered
  std::vector<std::pair<std::string, wire::Reply>> adoptedAnswers_;  // adopter, its answers to this exchange's jobs
  std::optional<SlurmAllocation> slurm_;  // the allocation launch: srun steps start in
  ResourcePlan slurmPlan_;                // its components, as coupler sbatch asks for them
  std::string srun_;                      // srun's path
  std::set<std::string> lastAdvanced_;  // the solvers that advanced in the last exchange
  std::set<std::string> lost_;  // workers lost mid-run whose cells moved to the others (gmh on_worker_loss: move)
  std::set<std::string> warnedCritical_;  // solvers whose step was reported above their critical step
  CheckpointStore checkpoints_;
  std::optional<CheckpointStore::Point> resumeFrom_;
  std::map<std::string, wire::InMessage> latest_;
  std::map<std::string, proto::CouplingData::Reader> outputs_;  // views into latest_ (keepViews)
  SolverEnergies energies_;  // views into latest_, or energySource_ after replies without energies
  std::map<std::string, wire::InMessage> energySource_;  // the reply the energies came with, when older
  std::map<std::string, InputAssembler> inputs_;
  std::map<std::string, PeerTiming> timings_;
  CommunicationLedger communication_;  // the rounds' communication, settled a round late (work ahead)
  std::uint64_t exchange_ = 0;   // the exchange in progress (or last done)
  std::uint64_t completed_ = 0;  // exchanges fully done and recorded
  double time_ = 0.0;
};

}  // namespace

fs::path solverCheckDirectory() {
  return fs::temp_directory_path() / ("cosim-solver-check-" + std::to_string(::getpid()));
}

int runScene(const Scene& scene, const RunOptions& options) {
  installStopSignalHandlers();
  // Before anything starts for real: what only the solvers can judge.
  const auto checked = checkSolverParams(scene, solverCheckDirectory());
  if (!checked.problems.empty() || !checked.failures.empty()) {
    for (const auto& p : checked.problems) std::cerr << scene.file << ": " << p << "\n";
    for (const auto& f : checked.failures) std::cerr << "coupler: " << f << "\n";
    std::cerr << "coupler: run refused before any solver started\n";
    return checked.problems.empty() ? kExitRefused : kExitBadConfig;
  }
  CouplerRun run(scene, options);
  return run.run();
}

void describeScene(const Scene& scene, std::ostream& out) {
  out << "scene '" << scene.name << "' (" << scene.file << ")\n";
  if (!scene.description.empty()) out << "  " << scene.description << "\n";
  out << "schedule: " << scene.schedule->describe() << "\n";
  if (scene.placement.kind == PlacementSpec::Kind::packed)
    out << "placement: packed, the coupler and the solvers it starts on CPUs "
        << (scene.placement.cpus.empty() ? std::string("[the one the coupler starts on]") : util::describeCpus(scene.placement.cpus))
        << "\n";
  out << "solvers:\n";
  for (const auto& s : scene.solvers) {
    out << "  " << s.name << " (" << s.kind << "): ";
    if (s.launch == SolverSpec::Launch::spawn) {
      out << "start " << s.binary << " --endpoint <endpoint> --name " << s.name;
      for (const auto& a : s.args) out << " " << a;
    } else if (s.launch == SolverSpec::Launch::srun) {
      out << "job step: srun " << joined(srunArguments(s, launchArgs(s, "<endpoint>")), " ");
    } else {
      out << "attach: waits for it to connect";
    }
    out << "\n    needs capabilities: " << joined(scene.requiredCapabilities(s.name)) << "\n";
  }
  out << "couplings:" << (scene.couplings.empty() ? " none" : "") << "\n";
  for (const auto& c : scene.couplings) {
    out << "  " << c->name() << " [" << c->kind() << "] ";
    c->describe(out);
    out << "\n";
  }
  if (scene.reference) {
    out << "analysis: [" << scene.reference->kind() << "] ";
    scene.reference->describe(out);
    out << "\n";
  }
  out << "transport: "
      << (scene.transport.kind == wire::TransportOptions::Kind::tcp
              ? "tcp on " + scene.transport.interface + (scene.transport.curve ? " (CurveZMQ)" : "")
              : "ipc")
      << ", heartbeat " << scene.link.heartbeatIntervalS << " s, timeout " << scene.link.heartbeatTimeoutS << " s\n";
  describeResources(scene, out);
  out << "output: " << scene.output.dir << "/coupler.h5\n";
}

}  // namespace cosim::coupler
