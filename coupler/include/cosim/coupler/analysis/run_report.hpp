#pragma once
// The report every run ends with, printed and written as JSON next to
// coupler.h5: how it ended, and where the wall time went (each peer's
// compute and communication, the coupler's own mapping and output work).
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cosim/util/host_cpu_time.hpp"

namespace cosim::coupler {

struct PeerTiming {
  std::string name;
  std::string kind;
  std::string version;
  double computeS = 0.0;        // inside the solver's advance, as it reports (work ahead included)
  double aheadS = 0.0;          // of which worked ahead, between a reply and the next request
  double communicationS = 0.0;  // request round trips minus compute (in a round where solvers
                                // compute at once, waiting for the others counts here too)
  std::uint64_t messagesSent = 0;
  std::uint64_t messagesReceived = 0;
  std::uint64_t bytesSent = 0;
  std::uint64_t bytesReceived = 0;
  std::string dataPath = "zmq";  // where requests and replies travel: "shm" (shared memory) or "zmq"
  double criticalDt = 0.0;      // at setup
  double lastCriticalDt = 0.0;  // as last reported (series rows ask for it)
  double minCriticalDt = 0.0;   // the smallest nonzero one reported during the run
  std::string cpus;  // the CPUs a started peer may use, "[0]"; empty for an attached one
};

/// A scene's error against its reference (analytic formula or stored run):
/// what `coupler sweep` plots against wall time.
struct ErrorFigure {
  std::string name;       // e.g. "time_averaged_trajectory_error"
  std::string reference;  // what it is measured against, in words
  std::string unit;
  double value = 0.0;
};

/// One solver's request in an exchange round, on the coupler's monotonic clock.
struct RoundTrip {
  double sentAt = 0.0;            // just before the request went out
  double receivedAt = 0.0;        // when the reply was taken off the socket
  double computeS = 0.0;          // the solver's advance, as it reports
  double computeStartedAt = 0.0;  // the solver's clock when it began (0: not reported)
  double aheadS = 0.0;            // work the solver did ahead of this request, after its last reply
  double aheadStartedAt = 0.0;    // the solver's clock when that work began (0: none)
};

/// The wall time of one exchange round spent outside every solver's compute:
/// from the first send to the last reply, less the union of the compute
/// intervals. Where solvers compute at once (a parallel schedule, a pool of
/// workers), each one's round trip covers the others' compute, so summing the
/// peers' round trips less their own compute counts the overlap several times
/// (shares above 100 %). A solver's reported start is used where it lies on the
/// coupler's clock (same host: between the send and the reply); otherwise its
/// compute is taken to end when its reply arrived.
/// `alsoComputing` adds work known to have run during the round (a solver's
/// work ahead, on the coupler's clock), clipped to the round.
double roundCommunicationSeconds(const std::vector<RoundTrip>& round,
                                 const std::vector<std::pair<double, double>>& alsoComputing = {});

/// The part of a request's round trip its solver spent finishing the work it
/// did ahead (Solver::workAhead): the request waited for it in the queue.
double aheadInsideRoundTrip(const RoundTrip& trip);

/// Sums the exchange rounds' communication. A solver's work ahead arrives
/// with its next reply but ran during the rounds before (PD's next bond
/// forces while DEM stepped), so a round is settled only once the next one
/// is in; work ahead spanning more rounds counts as communication there.
class CommunicationLedger {
 public:
  void add(std::vector<RoundTrip> round);
  /// Settles the round still open; returns the total.
  double close();

 private:
  std::vector<RoundTrip> open_;
  std::vector<std::pair<double, double>> openAhead_;  // work ahead reported with the open round
  double seconds_ = 0.0;
};

struct RunReport {
  std::string scene;
  std::string sceneFile;
  std::string runDir;
  std::string status = "not started";  // completed, refused, failed, interrupted
  std::string message;
  int exitCode = 0;
  std::string schedule;
  std::string placement = "spread";  // "spread", or "packed on CPUs [0]"
  std::uint64_t exchanges = 0;
  std::uint64_t plannedExchanges = 0;
  double simulatedTime = 0.0;
  double endTime = 0.0;
  /// A resumed run (--resume): the checkpoint it continued from. Its wall
  /// times and shares cover this process's exchanges only; the analysis
  /// (errors, figures) covers the whole run from t = 0.
  std::optional<std::pair<std::uint64_t, double>> resumedFrom;  // exchange, time
  double wallS = 0.0;
  double startupS = 0.0;   // launch, handshake and setup
  double loopS = 0.0;      // the exchange loop
  double mappingS = 0.0;   // couplings and request assembly in the coupler
  double communicationS = 0.0;  // exchange rounds outside every solver's compute (roundCommunicationSeconds)
  double outputS = 0.0;    // HDF5 series and flushes
  /// What the whole machine did over the run (Linux): busy and steal time
  /// of every CPU, other processes' and the hypervisor's work included.
  std::optional<util::HostCpuTimes> host;
  std::vector<PeerTiming> peers;
  std::map<std::string, double> finalEnergies;  // "solver.name" -> J
  std::vector<ErrorFigure> errors;              // the first one is the scene's error metric
  std::map<std::string, double> figures;        // a scene's own numbers (drift, peak energy ...)
  std::vector<std::string> warnings;            // e.g. a step above a solver's critical step

  /// Communication (the rounds' time outside every solver's compute) plus the
  /// coupler's mapping, as a share of the exchange loop.
  double couplingOverheadShare() const;
  /// The hypervisor's steal time as a share of the machine's CPU time over
  /// the run (CPUs x wall); 0 where the host's times are unknown.
  double stealShare() const;

  void writeJson(const std::filesystem::path& path) const;
  std::string text() const;
};

}  // namespace cosim::coupler
