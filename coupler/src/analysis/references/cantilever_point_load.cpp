// cantilever-point-load: scene C1's reference (Cheng 2022 Sec. 6.1). Particles
// roll along a cantilever clamped at y = 0; quasi-statically their weight P
// acts as a point load at their current y, and Euler-Bernoulli beam theory
// gives the deflection under the load
//   z_ref(y) = z_0 - P y^3 / (3 E I)                     (scenes/README C1)
// with x_ref = x_0 (no lateral motion). The error at time t is
//   err(t) = || x_sim(t) - x_ref(t) ||_2 over all particles (y_ref = y_sim),
// averaged over time while every particle is on the beam. The run ends when
// all particles have left it (past the tip or over a side edge).
// Figures: lateral drift max |x - x_0| per particle, the coupled total energy
// FEM (kinetic + strain + hourglass) + DEM (kinetic + elastic + potential
// relative to t = 0) and its maximum while coupled, the fall-off time.
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

class CantileverPointLoad final : public Reference {
 public:
  CantileverPointLoad(config::MapReader& m, const std::vector<SolverSpec>& solvers) {
    dem_ = requireSolverName(m, "dem", solvers);
    zone_ = m.string("zone", "all");
    young_ = m.requireNumber("young", config::Range::positive());
    inertia_ = m.requireNumber("second_moment", config::Range::positive());
    gravity_ = m.requireNumber("gravity", config::Range::positive());
    length_ = m.requireNumber("length", config::Range::positive());
    halfWidth_ = m.requireNumber("half_width", config::Range::positive());
    axisX_ = m.number("axis_x", 0.0);
    // A CG width or schedule outside the stable range shows as energy growth;
    // the run is stopped as unstable long before it could reach NaN.
    maxGrowth_ = m.number("max_energy_growth", 1000.0, {1.0, 1e12, true});
  }

  std::string kind() const override { return "cantilever-point-load"; }
  void describe(std::ostream& out) const override {
    out << "particles of '" << dem_ << "' zone '" << zone_ << "' against z_0 - P y^3 / (3 E I), E = " << young_
        << " Pa, I = " << inertia_ << " m^4, beam length " << length_ << " m";
  }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == dem_) return {"particle-states"};
    return {};
  }

  void observe(const Observation& o) override {
    const auto states = zoneStates(o, dem_, zone_);
    const auto x = wire::view(states.getPositions());
    if (o.exchange == 0 || x0_.empty()) start(states, o);
    const double energy = totalEnergy(o);
    if (o.exchange == 0) initialEnergy_ = std::max(std::abs(energy), 1e-12);
    if (!(energy <= maxGrowth_ * initialEnergy_))
      throw std::runtime_error("analysis: unstable run: the coupled total energy is " + std::to_string(energy) +
                               " J at t = " + std::to_string(o.time) + " s, more than " + std::to_string(maxGrowth_) +
                               " times its initial " + std::to_string(initialEnergy_) +
                               " J (analysis.max_energy_growth); the CG width or the schedule is outside the stable range");
    const auto zRef = referenceZ(x);
    if (o.series) {
      o.series->append("analysis/total_energy", energy);
      o.series->append("analysis/positions", x);
      o.series->append("analysis/reference_z", zRef);
    }
    if (coupled_ && !allOnBeam(x)) {
      coupled_ = false;
      fallOffTime_ = o.time;
    }
    if (allLeft(x)) finished_ = true;
    if (!coupled_ || o.exchange == 0) return;
    const double err = error(x, zRef);
    if (o.series) o.series->append("analysis/trajectory_error", err);
    errorIntegral_ += 0.5 * (err + lastError_) * (o.time - lastTime_);
    lastError_ = err;
    lastTime_ = o.time;
    maxEnergy_ = std::max(maxEnergy_, energy);
    for (std::size_t p = 0; p < drift_.size(); ++p) drift_[p] = std::max(drift_[p], std::abs(x[3 * p] - x0_[3 * p]));
  }

  bool finished() const override { return finished_; }

  void save(util::BinaryWriter& out) const override {
    out.vec(x0_), out.vec(drift_);
    for (double v : {load_, initialPotential_, initialEnergy_, startTime_, lastTime_, lastError_, errorIntegral_,
                     maxEnergy_, fallOffTime_})
      out.pod(v);
    out.pod(static_cast<std::uint8_t>(coupled_)), out.pod(static_cast<std::uint8_t>(finished_));
  }
  void restore(util::BinaryReader& in) override {
    x0_ = in.vec<double>("cantilever start positions");
    drift_ = in.vec<double>("cantilever drifts");
    if (drift_.size() * 3 != x0_.size()) in.fail("cantilever drifts", "not one per particle");
    for (double* v : {&load_, &initialPotential_, &initialEnergy_, &startTime_, &lastTime_, &lastError_,
                      &errorIntegral_, &maxEnergy_, &fallOffTime_})
      *v = in.pod<double>("cantilever sums");
    coupled_ = in.pod<std::uint8_t>("cantilever flags") != 0;
    finished_ = in.pod<std::uint8_t>("cantilever flags") != 0;
  }

  void conclude(RunReport& report) const override {
    const double span = lastTime_ - startTime_;
    report.errors.push_back({"time_averaged_trajectory_error",
                             "quasi-static point load z_0 - P y^3 / (3 E I), x = x_0 (Cheng 2022 Sec. 6.1)", "m",
                             span > 0.0 ? errorIntegral_ / span : 0.0});
    for (std::size_t p = 0; p < drift_.size(); ++p)
      report.figures["lateral_drift_" + std::to_string(p) + "_m"] = drift_[p];
    report.figures["max_total_energy_J"] = maxEnergy_;
    report.figures["coupled_until_s"] = coupled_ ? lastTime_ : fallOffTime_;
    report.figures["all_left_beam"] = finished_ ? 1.0 : 0.0;
  }

 private:
  void start(proto::ParticleStates::Reader states, const Observation& o) {
    const auto x = wire::view(states.getPositions());
    x0_.assign(x.begin(), x.end());
    double mass = 0.0;
    for (double m : wire::view(states.getMasses())) mass += m;
    load_ = mass * gravity_;
    drift_.assign(x.size() / 3, 0.0);
    startTime_ = lastTime_ = o.time;
    lastError_ = 0.0;
    initialPotential_ = sumEnergies(o.energies, dem_, {"potential"});
  }

  /// z_ref = z_0 - P y^3 / (3 E I) at each particle's current y.
  std::span<const double> referenceZ(std::span<const double> x) {
    zRef_.resize(x.size() / 3);
    for (std::size_t p = 0; p < zRef_.size(); ++p) {
      const double y = x[3 * p + 1];
      zRef_[p] = x0_[3 * p + 2] - load_ * y * y * y / (3.0 * young_ * inertia_);
    }
    return zRef_;
  }

  double error(std::span<const double> x, std::span<const double> zRef) const {
    double sum = 0.0;
    for (std::size_t p = 0; p < zRef.size(); ++p) {
      const double dx = x[3 * p] - x0_[3 * p], dz = x[3 * p + 2] - zRef[p];
      sum += dx * dx + dz * dz;
    }
    return std::sqrt(sum);
  }

  bool onBeam(std::span<const double> x, std::size_t p) const {
    return x[3 * p + 1] <= length_ && std::abs(x[3 * p] - axisX_) <= halfWidth_;
  }
  bool allOnBeam(std::span<const double> x) const {
    for (std::size_t p = 0; 3 * p < x.size(); ++p)
      if (!onBeam(x, p)) return false;
    return true;
  }
  bool allLeft(std::span<const double> x) const {
    for (std::size_t p = 0; 3 * p < x.size(); ++p)
      if (onBeam(x, p)) return false;
    return true;
  }

  double totalEnergy(const Observation& o) const {
    double total = -initialPotential_;
    for (const auto& [solver, values] : o.energies)
      total += sumEnergies(o.energies, solver, {"kinetic", "strain", "hourglass", "elastic", "potential"});
    return total;
  }

  std::string dem_, zone_;
  double young_ = 0.0, inertia_ = 0.0, gravity_ = 0.0, length_ = 0.0, halfWidth_ = 0.0, axisX_ = 0.0;
  std::vector<double> x0_, drift_, zRef_;
  double load_ = 0.0, initialPotential_ = 0.0, initialEnergy_ = 0.0, maxGrowth_ = 1000.0;
  bool coupled_ = true, finished_ = false;
  double startTime_ = 0.0, lastTime_ = 0.0, lastError_ = 0.0, errorIntegral_ = 0.0, maxEnergy_ = 0.0;
  double fallOffTime_ = 0.0;
};

const bool registered = ReferenceRegistry::add(
    "cantilever-point-load", [](config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<CantileverPointLoad>(m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
