// The run report's host line (busy, idle and steal time; steal as a share of
// the machine's time) and the communication of exchange rounds.
#include <gtest/gtest.h>

#include "cosim/coupler/analysis/run_report.hpp"

namespace cosim::coupler {
namespace {

TEST(RunReport, StealIsAShareOfEveryCpusWallTime) {
  RunReport r;
  r.wallS = 10.0;
  EXPECT_EQ(r.stealShare(), 0.0);  // unknown host
  EXPECT_EQ(r.text().find("host "), std::string::npos);
  r.host = util::HostCpuTimes{15.0, 4.0, 1.0, 2};
  EXPECT_DOUBLE_EQ(r.stealShare(), 0.05);
  const auto text = r.text();
  EXPECT_NE(text.find("host          2 CPUs busy 15.000 s, idle 4.000 s, steal 1.000 s (5.000 % of their time)"), std::string::npos)
      << text;
}

// One solver per round: the round trip less its compute, wherever its clock is.
TEST(RunReport, ARoundOfOneSolverCommunicatesItsRoundTripLessItsCompute) {
  EXPECT_NEAR(roundCommunicationSeconds({{10.0, 10.5, 0.4, 10.05}}), 0.1, 1e-12);
  EXPECT_NEAR(roundCommunicationSeconds({{10.0, 10.5, 0.4, 0.0}}), 0.1, 1e-12);   // start not reported
  EXPECT_NEAR(roundCommunicationSeconds({{10.0, 10.5, 0.4, 777.0}}), 0.1, 1e-12); // another host's clock
  EXPECT_EQ(roundCommunicationSeconds({}), 0.0);
}

// Two solvers computing at once on two CPUs: each waits for the other, but the
// round's communication is what lies outside both computes (the old per-peer
// sum counted 0.3 + 0.1 s for a round of 0.55 s with 0.05 s outside compute).
TEST(RunReport, SolversComputingAtOnceCountTheirOverlapOnce) {
  const std::vector<RoundTrip> parallel{{0.0, 0.55, 0.2, 0.02}, {0.001, 0.53, 0.5, 0.025}};
  EXPECT_NEAR(roundCommunicationSeconds(parallel), 0.55 - 0.505, 1e-12);
}

// Packed on one CPU the second solver starts when the first is done: the
// computes follow each other, and only the gaps are communication. Without
// reported starts each compute is taken to end at its reply.
TEST(RunReport, SolversTakingTurnsOnOneCpuLeaveOnlyTheGaps) {
  std::vector<RoundTrip> packed{{0.0, 0.52, 0.2, 0.01}, {0.0, 0.5, 0.28, 0.215}};
  EXPECT_NEAR(roundCommunicationSeconds(packed), 0.52 - 0.48, 1e-12);
  for (auto& r : packed) r.computeStartedAt = 0.0;
  // [0.32, 0.52] and [0.22, 0.5]: 0.3 s covered of 0.52.
  EXPECT_NEAR(roundCommunicationSeconds(packed), 0.22, 1e-12);
}

// PD works ahead after its reply (Solver::workAhead), over DEM's round and
// into its own next one, and reports it with that next reply: the ledger
// settles each round once the next is in, so the work ahead covers DEM's
// round trip and the wait of PD's next request, and only the gaps remain.
TEST(RunReport, WorkAheadCountsAsComputeInTheRoundsItOverlaps) {
  const RoundTrip pd1{0.0, 0.3, 0.2, 0.05};
  const RoundTrip dem{0.31, 0.6, 0.2, 0.35};
  const RoundTrip pd2{0.61, 1.0, 0.05, 0.93, 0.6, 0.3};  // worked ahead over [0.3, 0.9]
  CommunicationLedger ledger;
  ledger.add({pd1});
  ledger.add({dem});
  ledger.add({pd2});
  EXPECT_NEAR(ledger.close(), 0.1 + 0.0 + (0.39 - 0.29 - 0.05), 1e-12);
  EXPECT_NEAR(ledger.close(), 0.15, 1e-12);  // nothing open: closing again adds nothing
  EXPECT_NEAR(aheadInsideRoundTrip(pd2), 0.29, 1e-12);
  EXPECT_EQ(aheadInsideRoundTrip(dem), 0.0);
  // Work ahead on another host's clock cannot be placed: the rounds as before.
  CommunicationLedger elsewhere;
  elsewhere.add({pd1});
  elsewhere.add({dem});
  elsewhere.add({{0.61, 1.0, 0.05, 0.93, 0.6, 777.0}});
  EXPECT_NEAR(elsewhere.close(), 0.1 + 0.09 + 0.34, 1e-12);
}

TEST(RunReport, EnergiesKeepTheirSignificantDigitsAtAnyScale) {
  RunReport r;
  r.finalEnergies = {{"pile.kinetic", 4.104145e-6}, {"pack.strain", 12345.678901}, {"bad.potential", 2e305}};
  const auto text = r.text();
  EXPECT_NE(text.find("pile.kinetic = 4.104145e-06 J"), std::string::npos) << text;
  EXPECT_NE(text.find("pack.strain = 12345.68 J"), std::string::npos) << text;
  EXPECT_NE(text.find("bad.potential = 2e+305 J"), std::string::npos) << text;
}

TEST(RunReport, OverheadIsTheRoundsCommunicationPlusMapping) {
  RunReport r;
  r.loopS = 10.0;
  r.mappingS = 1.0;
  r.communicationS = 2.0;
  for (const char* name : {"a", "b"}) {  // each waited for the other: their own figures overlap
    PeerTiming p;
    p.name = name;
    p.communicationS = 5.0;
    r.peers.push_back(p);
  }
  EXPECT_DOUBLE_EQ(r.couplingOverheadShare(), 0.3);
  EXPECT_NE(r.text().find("overhead      communication 2.000 s + mapping = 30.000 % of the exchange loop"),
            std::string::npos)
      << r.text();
}

}  // namespace
}  // namespace cosim::coupler
