#pragma once
// What the schedules share about time steps: the tightest critical step among
// some solvers, and readable numbers for the messages that refuse a step.
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <sstream>
#include <string>

namespace cosim::coupler {

struct CriticalStep {
  double dt = std::numeric_limits<double>::infinity();  // infinite when no solver has a limit
  std::string solver;
  bool limited() const { return dt < std::numeric_limits<double>::infinity(); }
};

/// The smallest positive critical step among the solvers `include` accepts (0 = no limit).
template <typename Include>
CriticalStep tightestStep(const std::map<std::string, double>& criticalDt, Include include) {
  CriticalStep limit;
  for (const auto& [solver, dt] : criticalDt)
    if (include(solver) && dt > 0.0 && dt < limit.dt) limit = {dt, solver};
  return limit;
}

/// Intervals of length `interval` until `endTime`; the last may overshoot it
/// by less than one interval (0 when the interval is not yet known).
inline std::uint64_t intervalsUntil(double endTime, double interval) {
  if (!(interval > 0.0)) return 0;
  return static_cast<std::uint64_t>(std::ceil(endTime / interval - 1e-9));
}

inline std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// "until t = 0.3 s"; where the last interval overshoots end_time, says so and
/// where the run ends ("until t = 0.005 s: end_time 0.001 s rounded up to whole
/// exchanges of 0.005 s"), so the description matches the report's end time.
inline std::string untilText(double endTime, double interval) {
  const double reached = static_cast<double>(intervalsUntil(endTime, interval)) * interval;
  if (!(interval > 0.0) || std::fabs(reached - endTime) <= 1e-9 * endTime)
    return "until t = " + formatNumber(endTime) + " s";
  return "until t = " + formatNumber(reached) + " s: end_time " + formatNumber(endTime) +
         " s rounded up to whole exchanges of " + formatNumber(interval) + " s";
}

}  // namespace cosim::coupler
