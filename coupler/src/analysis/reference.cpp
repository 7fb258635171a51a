#include "cosim/coupler/analysis/reference.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cosim/io/h5_file.hpp"
#include "cosim/util/binary_record.hpp"

namespace cosim::coupler {

proto::ParticleStates::Reader zoneStates(const Observation& o, const std::string& solver, const std::string& zone) {
  auto out = o.outputs.find(solver);
  if (out != o.outputs.end())
    for (auto s : out->second.getParticles())
      if (s.getZone() == zone) return s;
  throw std::runtime_error("analysis: solver '" + solver + "' sent no particle states for zone '" + zone +
                           "' (list it in that solver's params.zones)");
}

void TimeRecord::save(util::BinaryWriter& out) const {
  out.vec(times), out.vec(values);
  out.pod(static_cast<std::uint64_t>(perTime));
}

void TimeRecord::restore(util::BinaryReader& in) {
  times = in.vec<double>("analysis record times");
  values = in.vec<double>("analysis record values");
  perTime = static_cast<std::size_t>(in.pod<std::uint64_t>("analysis record width"));
  if (values.size() != times.size() * perTime) in.fail("analysis record", "values do not fill its times");
}

double TimeRecord::at(std::size_t c, double t) const {
  if (times.size() < 2) return values[c];
  const auto it = std::lower_bound(times.begin(), times.end(), t);
  const auto k = static_cast<std::size_t>(
      std::clamp<std::ptrdiff_t>(it - times.begin(), 1, static_cast<std::ptrdiff_t>(times.size()) - 1));
  const double t0 = times[k - 1], t1 = times[k];
  const double a = t1 > t0 ? std::clamp((t - t0) / (t1 - t0), 0.0, 1.0) : 1.0;
  return (1.0 - a) * values[(k - 1) * perTime + c] + a * values[k * perTime + c];
}

double rmsAgainstStoredRun(const TimeRecord& record, const std::string& file, const std::string& dataset) {
  const auto h5 = io::H5File::openReadOnly(file);
  const auto refTimes = h5.readArray("/series/time");
  const auto ref = h5.readArray("/series/" + dataset);
  const std::size_t n = record.perTime;
  if (refTimes.empty() || ref.size() != refTimes.size() * n)
    throw std::runtime_error("analysis.reference_run: " + file + " holds " + std::to_string(ref.size()) + " values of " +
                             dataset + " for " + std::to_string(refTimes.size()) + " times; this run records " +
                             std::to_string(n) + " per time (run the reference with the same analysis)");
  if (record.times.empty()) throw std::runtime_error("analysis: nothing recorded to compare with " + file);
  double sum = 0.0, peak = 0.0;
  std::size_t count = 0;
  for (std::size_t t = 0; t < refTimes.size(); ++t) {
    if (refTimes[t] < record.times.front() || refTimes[t] > record.times.back()) continue;
    for (std::size_t c = 0; c < n; ++c) {
      const double diff = record.at(c, refTimes[t]) - ref[t * n + c];
      sum += diff * diff;
      peak = std::max(peak, std::abs(ref[t * n + c]));
      ++count;
    }
  }
  if (count == 0 || !(peak > 0.0))
    throw std::runtime_error("analysis.reference_run: " + file + " does not overlap this run in time (or is all zero)");
  return std::sqrt(sum / static_cast<double>(count)) / peak;
}

}  // namespace cosim::coupler
