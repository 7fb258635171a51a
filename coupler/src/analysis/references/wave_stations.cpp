// wave-stations: a wave's record at fixed stations, against a stored run
// (scene C2, Cheng 2022 Sec. 6.2: "waveform at fixed stations against the
// full-DEM reference"). At setup the particle nearest each station point (by
// initial position) is chosen in a DEM zone; every exchange its velocity
// component goes to /series/analysis/station_velocity. With `reference_run`
// (the coupler.h5 of a run of the same stations, e.g. the full-DEM scene with
// this same analysis) the error is
//   e = sqrt( mean over stations and reference times of (v - v_ref)^2 ) / max |v_ref|,
// with this run's record interpolated linearly to the reference's times
// inside the span both cover. Figures: the dissipation ratio
//   dE/E = (E_in - E_end) / E_in,  E = the solvers' kinetic + elastic + strain energies,
//   E_in = E_0 + W, W = the work of the DEM's drives (a driven layer, Table 4 (b))
// (Cheng Sec. 6.2.2; a coupling's penalty energy is not in it, nor the
// penalty's work, which both solvers count as external), and each station's
// peak velocity.
#include <algorithm>
#include <cmath>
#include <ostream>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/analysis/reference.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

class WaveStations final : public Reference {
 public:
  WaveStations(config::MapReader& m, const std::vector<SolverSpec>& solvers) {
    dem_ = requireSolverName(m, "dem", solvers);
    zone_ = m.string("zone", "all");
    readStations(m);
    const std::string axis = m.string("component", "y");
    if (axis != "x" && axis != "y" && axis != "z") m.error("component", "must be x, y or z, got '" + axis + "'");
    component_ = static_cast<std::size_t>(axis[0] - 'x');
    referenceRun_ = m.string("reference_run", "");  // relative to the working directory, like output.dir
  }

  std::string kind() const override { return "wave-stations"; }
  void describe(std::ostream& out) const override {
    out << stations_.size() / 3 << " station(s) in zone '" << zone_ << "' of '" << dem_ << "', velocity "
        << "xyz"[component_] << (referenceRun_.empty() ? std::string(", no stored reference") : ", against " + referenceRun_);
  }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == dem_) return {"particle-states"};
    return {};
  }

  void observe(const Observation& o) override {
    const auto states = zoneStates(o, dem_, zone_);
    if (members_.empty()) pickStations(states);
    const auto v = wire::view(states.getVelocities());
    for (std::size_t s = 0; s < members_.size(); ++s) sample_[s] = v[3 * members_[s] + component_];
    record_.append(o.time, sample_);
    const double e = energy(o);
    if (o.exchange == 0) initialEnergy_ = e;
    finalEnergy_ = e;
    demWork_ = sumEnergies(o.energies, dem_, {"drive_work"});
    if (o.series) o.series->append("analysis/station_velocity", sample_);
  }

  void save(util::BinaryWriter& out) const override {
    std::vector<std::uint64_t> members(members_.begin(), members_.end());
    out.vec(members);
    record_.save(out);
    out.pod(initialEnergy_), out.pod(finalEnergy_), out.pod(demWork_);
  }
  void restore(util::BinaryReader& in) override {
    const auto members = in.vec<std::uint64_t>("wave station particles");
    if (members.size() * 3 != stations_.size()) in.fail("wave station particles", "not one per station of the scene");
    members_.assign(members.begin(), members.end());
    sample_.assign(members_.size(), 0.0);
    record_.restore(in);
    if (record_.perTime != members_.size()) in.fail("wave station record", "not one column per station");
    initialEnergy_ = in.pod<double>("wave station energies");
    finalEnergy_ = in.pod<double>("wave station energies");
    demWork_ = in.pod<double>("wave station energies");
  }

  void conclude(RunReport& report) const override {
    if (!referenceRun_.empty()) {
      const double e = rmsAgainstStoredRun(record_, referenceRun_, "analysis/station_velocity");
      report.errors.push_back({"station_velocity_rms_error", "stored run " + referenceRun_, "of the peak", e});
    }
    const double input = initialEnergy_ + demWork_;
    report.figures["dissipation_ratio"] = input > 0.0 ? (input - finalEnergy_) / input : 0.0;
    report.figures["input_energy_J"] = input;
    for (std::size_t s = 0; s < members_.size(); ++s) {
      double peak = 0.0;
      for (std::size_t t = 0; t < record_.times.size(); ++t)
        peak = std::max(peak, std::abs(record_.values[t * members_.size() + s]));
      report.figures["station_" + std::to_string(s) + "_peak_velocity"] = peak;
    }
  }

 private:
  void readStations(config::MapReader& m) {
    const YAML::Node list = m.node("stations");
    if (!list || !list.IsSequence() || list.size() == 0) {
      m.error("stations", "expected a list of points [x, y, z]");
      return;
    }
    for (const auto& p : list) {
      if (!p.IsSequence() || p.size() != 3) {
        m.errorAt(p.Mark(), "analysis.stations: each station is a point [x, y, z]");
        return;
      }
      for (const auto& c : p) stations_.push_back(m.numberIn(c, "stations").value_or(0.0));
    }
  }

  void pickStations(proto::ParticleStates::Reader states) {
    const auto x = wire::view(states.getPositions());
    if (x.empty()) throw std::runtime_error("analysis: zone '" + zone_ + "' of '" + dem_ + "' holds no particle");
    for (std::size_t s = 0; 3 * s < stations_.size(); ++s) {
      std::size_t best = 0;
      double bestDistance = std::numeric_limits<double>::infinity();
      for (std::size_t p = 0; 3 * p < x.size(); ++p) {
        const double d = std::hypot(x[3 * p] - stations_[3 * s], x[3 * p + 1] - stations_[3 * s + 1],
                                    x[3 * p + 2] - stations_[3 * s + 2]);
        if (d < bestDistance) bestDistance = d, best = p;
      }
      members_.push_back(best);
    }
    sample_.assign(members_.size(), 0.0);
    record_.perTime = members_.size();
  }

  double energy(const Observation& o) const {
    double e = 0.0;
    for (const auto& [solver, values] : o.energies) e += sumEnergies(o.energies, solver, {"kinetic", "elastic", "strain"});
    return e;
  }

  std::string dem_, zone_, referenceRun_;
  std::vector<double> stations_;       // 3 per station
  std::size_t component_ = 1;
  std::vector<std::size_t> members_;   // index in the zone of each station's particle
  std::vector<double> sample_;
  TimeRecord record_;  // the stations' velocities per time
  double initialEnergy_ = 0.0, finalEnergy_ = 0.0, demWork_ = 0.0;
};

const bool registered = ReferenceRegistry::add(
    "wave-stations", [](config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<WaveStations>(m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
