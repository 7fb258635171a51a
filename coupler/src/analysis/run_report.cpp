#include "cosim/coupler/analysis/run_report.hpp"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

namespace cosim::coupler {

double roundCommunicationSeconds(const std::vector<RoundTrip>& round,
                                 const std::vector<std::pair<double, double>>& alsoComputing) {
  if (round.empty()) return 0.0;
  double first = round.front().sentAt, last = round.front().receivedAt;
  std::vector<std::pair<double, double>> compute;
  for (const auto& r : round) {
    first = std::min(first, r.sentAt);
    last = std::max(last, r.receivedAt);
    const bool sameClock = r.computeStartedAt > 0.0 && r.computeStartedAt >= r.sentAt &&
                           r.computeStartedAt + r.computeS <= r.receivedAt;
    const double end = sameClock ? r.computeStartedAt + r.computeS : r.receivedAt;
    compute.emplace_back(std::max(r.sentAt, end - r.computeS), end);
  }
  for (const auto& [a, b] : alsoComputing)
    if (std::min(b, last) > std::max(a, first)) compute.emplace_back(std::max(a, first), std::min(b, last));
  std::sort(compute.begin(), compute.end());
  double covered = 0.0, reach = first;
  for (const auto& [a, b] : compute) {
    if (b > reach) covered += b - std::max(a, reach);
    reach = std::max(reach, b);
  }
  return std::max(0.0, last - first - covered);
}

namespace {
/// A trip's work ahead as an interval on the coupler's clock; none where it
/// is not on it (another host) or there was none.
std::optional<std::pair<double, double>> aheadInterval(const RoundTrip& r) {
  if (!(r.aheadS > 0.0) || !(r.aheadStartedAt > 0.0) || r.aheadStartedAt + r.aheadS > r.receivedAt) return std::nullopt;
  return std::make_pair(r.aheadStartedAt, r.aheadStartedAt + r.aheadS);
}
}  // namespace

double aheadInsideRoundTrip(const RoundTrip& trip) {
  const auto ahead = aheadInterval(trip);
  return ahead ? std::max(0.0, std::min(ahead->second, trip.receivedAt) - std::max(ahead->first, trip.sentAt)) : 0.0;
}

void CommunicationLedger::add(std::vector<RoundTrip> round) {
  std::vector<std::pair<double, double>> ahead;
  for (const auto& r : round)
    if (const auto a = aheadInterval(r)) ahead.push_back(*a);
  if (!open_.empty()) {
    auto during = openAhead_;
    during.insert(during.end(), ahead.begin(), ahead.end());
    seconds_ += roundCommunicationSeconds(open_, during);
  }
  open_ = std::move(round);
  openAhead_ = std::move(ahead);
}

double CommunicationLedger::close() {
  seconds_ += roundCommunicationSeconds(open_, openAhead_);
  open_.clear();
  openAhead_.clear();
  return seconds_;
}

void RunReport::writeJson(const std::filesystem::path& path) const {
  nlohmann::json j;
  j["scene"] = scene;
  j["scene_file"] = sceneFile;
  j["run_dir"] = runDir;
  j["status"] = status;
  j["message"] = message;
  j["exit_code"] = exitCode;
  j["schedule"] = schedule;
  j["placement"] = placement;
  j["exchanges"] = exchanges;
  j["planned_exchanges"] = plannedExchanges;
  j["simulated_time_s"] = simulatedTime;
  j["end_time_s"] = endTime;
  if (resumedFrom) j["resumed_from"] = {{"exchange", resumedFrom->first}, {"time_s", resumedFrom->second}};
  j["wall_s"] = {{"total", wallS}, {"startup", startupS}, {"exchange_loop", loopS},
                 {"coupler_mapping", mappingS}, {"coupler_output", outputS}, {"communication", communicationS}};
  j["peers"] = nlohmann::json::array();
  for (const auto& p : peers)
    j["peers"].push_back({{"name", p.name}, {"kind", p.kind}, {"version", p.version},
                          {"compute_s", p.computeS}, {"ahead_s", p.aheadS}, {"communication_s", p.communicationS},
                          {"messages_sent", p.messagesSent}, {"messages_received", p.messagesReceived},
                          {"bytes_sent", p.bytesSent}, {"bytes_received", p.bytesReceived}, {"data_path", p.dataPath},
                          {"critical_dt_s", p.criticalDt}, {"critical_dt_min_s", p.minCriticalDt},
                          {"cpus", p.cpus}});
  if (host)
    j["host"] = {{"cpus", host->cpus}, {"busy_cpu_s", host->busyS}, {"idle_cpu_s", host->idleS},
                 {"steal_cpu_s", host->stealS},
                 {"steal_share", stealShare()}};
  j["final_energies_J"] = finalEnergies;
  j["coupling_overhead_share"] = couplingOverheadShare();
  j["errors"] = nlohmann::json::array();
  for (const auto& e : errors)
    j["errors"].push_back({{"name", e.name}, {"reference", e.reference}, {"unit", e.unit}, {"value", e.value}});
  j["figures"] = figures;
  j["warnings"] = warnings;
  std::ofstream out(path);
  out << std::setw(2) << j << "\n";
}

double RunReport::couplingOverheadShare() const {
  if (!(loopS > 0.0)) return 0.0;
  return (mappingS + communicationS) / loopS;
}

double RunReport::stealShare() const {
  if (!host || host->cpus <= 0 || !(wallS > 0.0)) return 0.0;
  return host->stealS / (host->cpus * wallS);
}

std::string RunReport::text() const {
  std::ostringstream s;
  s << std::fixed << std::setprecision(3);
  s << "run report: scene '" << scene << "' " << status;
  if (!message.empty()) s << ": " << message;
  s << "\n  schedule      " << schedule << "\n";
  s << "  placement     " << placement << "\n";
  s << "  exchanges     " << exchanges << " of " << plannedExchanges << ", simulated t = " << std::setprecision(6)
    << simulatedTime << " s of " << endTime << " s\n" << std::setprecision(3);
  if (resumedFrom)
    s << "  resumed       from exchange " << resumedFrom->first << " (t = " << std::setprecision(6) << resumedFrom->second
      << " s): the times below cover the exchanges since\n" << std::setprecision(3);
  s << "  wall time     " << wallS << " s (startup " << startupS << " s, exchange loop " << loopS << " s)\n";
  if (host)
    s << "  host          " << host->cpus << " CPUs busy " << host->busyS << " s, idle " << host->idleS << " s, steal " << host->stealS << " s ("
      << 100.0 * stealShare() << " % of their time)\n";
  const double loop = loopS > 0 ? loopS : 1.0;
  s << "  coupler       mapping " << mappingS << " s (" << 100.0 * mappingS / loop << " %), output " << outputS
    << " s (" << 100.0 * outputS / loop << " %)\n";
  for (const auto& p : peers) {
    s << "  " << std::left << std::setw(13) << p.name << std::right << " compute " << p.computeS << " s ("
      << 100.0 * p.computeS / loop << " %";
    if (p.aheadS > 0.0) s << ", " << p.aheadS << " s of it worked ahead";
    s << "), communication " << p.communicationS << " s ("
      << 100.0 * p.communicationS / loop << " %), " << p.messagesSent << " requests, "
      << (p.bytesSent + p.bytesReceived) / 1048576.0 << " MiB moved over " << p.dataPath << (p.cpus.empty() ? "" : ", CPUs " + p.cpus)
      << "\n";
  }
  s << "  overhead      communication " << communicationS << " s + mapping = " << 100.0 * couplingOverheadShare()
    << " % of the exchange loop\n";
  for (const auto& e : errors)
    s << "  error         " << e.name << " = " << std::setprecision(6) << e.value << " " << e.unit << " (against "
      << e.reference << ")\n" << std::setprecision(3);
  // Figures span many scales (time steps of 1e-7 s, forces of 1e4 N): six significant digits.
  for (const auto& [name, v] : figures)
    s << "  figure        " << name << " = " << std::defaultfloat << std::setprecision(6) << v << std::fixed << "\n";
  for (const auto& w : warnings) s << "  warning       " << w << "\n";
  // Energies too span many scales (4e-6 J of a settled pile, 1e4 J of a squeezed pack): significant digits.
  for (const auto& [name, e] : finalEnergies)
    s << "  energy        " << name << " = " << std::defaultfloat << std::setprecision(7) << e << std::fixed << " J\n";
  s << "  output        " << runDir << "\n";
  return s.str();
}

}  // namespace cosim::coupler
