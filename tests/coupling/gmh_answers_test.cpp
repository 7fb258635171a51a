// The gmh coupling's bookkeeping of the pool, in process: every job goes to
// the worker that holds its cell and must come back from it exactly once. A
// worker that answers a cell twice, leaves a job unanswered or answers a cell
// it was not sent stops the run naming itself and the cell.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <capnp/message.h>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/analysis/run_report.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"

namespace cosim::coupler {
namespace {

/// One solver's reply, built in its own message.
struct Output {
  capnp::MallocMessageBuilder message;
  proto::CouplingData::Builder data = message.initRoot<proto::CouplingData>();
};

/// A worker's answer for the given cells (any stress: the bookkeeping is tested).
void answer(Output& out, const std::vector<std::uint32_t>& ids) {
  auto r = out.data.initUnitCellResults(1)[0];
  const auto n = static_cast<unsigned>(ids.size());
  auto cells = r.initCellIds(n);
  for (unsigned k = 0; k < n; ++k) cells.set(k, ids[k]);
  auto s = r.initStresses(9 * n);
  for (unsigned k = 0; k < 9 * n; ++k) s.set(k, -1.0e5);
  for (auto list : {r.initPorosities(n), r.initCoordinationNumbers(n), r.initUnbalancedForceIndices(n)})
    for (unsigned k = 0; k < n; ++k) list.set(k, 0.4);
  r.initRelaxationSteps(n);
}

/// FEM's jobs for the given cells (zero increments).
void jobs(Output& out, const std::vector<std::uint32_t>& ids) {
  auto j = out.data.initUnitCellJobs(1)[0];
  const auto n = static_cast<unsigned>(ids.size());
  auto cells = j.initCellIds(n);
  for (unsigned k = 0; k < n; ++k) cells.set(k, ids[k]);
  j.initStrainIncrements(9 * n);
  j.setDt(1.0e-5);
}

class GmhPoolAnswers : public ::testing::Test {
 protected:
  GmhPoolAnswers() {
    const YAML::Node node = YAML::Load("{name: cells, kind: gmh, fem: block, workers: [a, b]}");
    config::Diagnostics diagnostics("scene.yaml");
    config::MapReader m(node, "couplings.cells", diagnostics);
    std::vector<SolverSpec> solvers(3);
    for (std::size_t k = 0; k < solvers.size(); ++k) {
      solvers[k].name = std::vector<std::string>{"block", "a", "b"}[k];
      solvers[k].kind = k == 0 ? "fem" : "dem";
    }
    coupling_ = CouplingRegistry::create("gmh", "coupling kind", "cells", m, solvers);
    diagnostics.throwIfAny();
    // Setup: a holds cells 0 and 1, b holds 2; then FEM sends a job for each.
    Output a, b, fem;
    answer(a, {0, 1});
    answer(b, {2});
    exchange(0, {{"block", &fem}, {"a", &a}, {"b", &b}});
    Output femJobs;
    jobs(femJobs, {0, 1, 2});
    exchange(1, {{"block", &femJobs}});
  }

  /// Runs the coupling on the outputs of the solvers that advanced.
  void exchange(std::uint64_t n, const std::map<std::string, Output*>& advanced) {
    std::map<std::string, proto::CouplingData::Reader> outputs;
    std::set<std::string> names;
    for (const auto& [name, out] : advanced) outputs.emplace(name, out->data.asReader()), names.insert(name);
    ExchangeContext ctx{n, 1.0e-5 * static_cast<double>(n), outputs, inputs_};
    ctx.advanced = names;
    coupling_->exchange(ctx);
  }

  /// The error of the step in which a and b answer as given.
  std::string answered(const std::vector<std::uint32_t>& byA, const std::vector<std::uint32_t>& byB) {
    Output a, b;
    answer(a, byA);
    answer(b, byB);
    try {
      exchange(2, {{"a", &a}, {"b", &b}});
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  }

  std::unique_ptr<Coupling> coupling_;
  std::map<std::string, InputAssembler> inputs_;
};

TEST_F(GmhPoolAnswers, EachJobAnsweredOnceByItsWorkerIsTaken) {
  EXPECT_EQ(answered({1, 0}, {2}), "");
  RunReport report;
  coupling_->conclude(report);
  EXPECT_EQ(report.figures["answered_cell_jobs"], 3.0);
}

TEST_F(GmhPoolAnswers, ACellAnsweredTwiceStopsTheRun) {
  EXPECT_EQ(answered({0, 1, 0}, {2}), "coupling 'cells' at exchange 2: worker 'a' answered unit cell 0 twice");
}

TEST_F(GmhPoolAnswers, AnUnansweredJobStopsTheRun) {
  EXPECT_EQ(answered({0}, {2}),
            "coupling 'cells' at exchange 2: worker 'a' left 1 of its 2 jobs unanswered (unit cell 1 first)");
}

TEST_F(GmhPoolAnswers, AnAnswerForAnotherWorkersCellStopsTheRun) {
  EXPECT_EQ(answered({0, 1}, {2, 1}),
            "coupling 'cells' at exchange 2: worker 'b' answered unit cell 1, whose job it was not sent");
}

}  // namespace
}  // namespace cosim::coupler
