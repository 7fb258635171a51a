// force-displacement: the load-displacement curve of driven DEM spheres
// pressed into a body (scene H2, Hartmann 2022 Sec. 4.2: "wall force vs
// displacement for monolithic, staggered and multi-rate"). Each exchange, for
// the spheres of a DEM zone moving along the loading direction n:
//   d = mean_p (x_p - x_p(0)) . n       (how far they have moved),
//   F = -sum_p f_p . n                  (the force the body resists with),
// with f_p the interval mean force DEM reports for a driven sphere. Both go to
// /series/analysis/displacement and /series/analysis/force. With
// `reference_run` (the coupler.h5 of a run of the same scene with this
// analysis, e.g. the monolithic schedule) the error is the RMS difference of
// F over the stored run's times, relative to its peak force
// (rmsAgainstStoredRun): the curves compare at equal d because the spheres
// are driven at the same speed in both.
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

class ForceDisplacement final : public Reference {
 public:
  ForceDisplacement(config::MapReader& m, const std::vector<SolverSpec>& solvers) {
    dem_ = requireSolverName(m, "dem", solvers);
    zone_ = m.string("zone", "all");
    readDirection(m);
    referenceRun_ = m.string("reference_run", "");  // relative to the working directory, like output.dir
  }

  std::string kind() const override { return "force-displacement"; }
  bool usesEnergies() const override { return false; }
  void describe(std::ostream& out) const override {
    out << "spheres of '" << dem_ << "' zone '" << zone_ << "' loading along (" << n_[0] << ", " << n_[1] << ", "
        << n_[2] << ")" << (referenceRun_.empty() ? std::string(", no stored reference") : ", against " + referenceRun_);
  }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == dem_) return {"particle-states"};
    return {};
  }

  void observe(const Observation& o) override {
    const auto states = zoneStates(o, dem_, zone_);
    const auto x = wire::view(states.getPositions());
    const auto f = wire::view(states.getForces());
    if (x.empty() || f.size() != x.size())
      throw std::runtime_error("analysis: zone '" + zone_ + "' of '" + dem_ +
                               "' must hold spheres with their forces (driven spheres)");
    if (start_.empty()) start_.assign(x.begin(), x.end());
    if (start_.size() != x.size())
      throw std::runtime_error("analysis: zone '" + zone_ + "' of '" + dem_ + "' changed its sphere count");
    double d = 0.0, force = 0.0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      d += (x[k] - start_[k]) * n_[k % 3];
      force -= f[k] * n_[k % 3];
    }
    d /= static_cast<double>(x.size() / 3);
    const double row[1] = {force};
    forces_.append(o.time, row);
    lastDisplacement_ = d;
    maxForce_ = std::max(maxForce_, force);
    if (o.series) {
      o.series->append("analysis/displacement", d);
      o.series->append("analysis/force", force);
    }
  }

  void save(util::BinaryWriter& out) const override {
    out.vec(start_);
    forces_.save(out);
    out.pod(lastDisplacement_), out.pod(maxForce_);
  }
  void restore(util::BinaryReader& in) override {
    start_ = in.vec<double>("force-displacement start positions");
    forces_.restore(in);
    lastDisplacement_ = in.pod<double>("force-displacement figures");
    maxForce_ = in.pod<double>("force-displacement figures");
  }

  void conclude(RunReport& report) const override {
    if (!referenceRun_.empty())
      report.errors.push_back({"force_rms_error", "stored run " + referenceRun_, "of the peak",
                               rmsAgainstStoredRun(forces_, referenceRun_, "analysis/force")});
    report.figures["final_displacement_m"] = lastDisplacement_;
    report.figures["final_force_N"] = forces_.values.empty() ? 0.0 : forces_.values.back();
    report.figures["max_force_N"] = maxForce_;
  }

 private:
  void readDirection(config::MapReader& m) {
    if (!m.has("direction")) return;  // default: downwards, -z
    const YAML::Node node = m.node("direction");
    double v[3] = {0, 0, 0};
    bool ok = node.IsSequence() && node.size() == 3;
    for (std::size_t i = 0; ok && i < 3; ++i) {
      const auto x = node[i].IsScalar() ? config::parseNumber(node[i].Scalar()) : std::nullopt;
      ok = x && std::isfinite(*x);
      if (ok) v[i] = *x;
    }
    const double norm = std::hypot(v[0], v[1], v[2]);
    if (!ok || !(norm > 0.0)) {
      m.error("direction", "expected the loading direction as a non-zero vector [x, y, z]");
      return;
    }
    for (int i = 0; i < 3; ++i) n_[i] = v[i] / norm;
  }

  std::string dem_, zone_, referenceRun_;
  double n_[3] = {0, 0, -1};
  std::vector<double> start_;  // positions at setup
  TimeRecord forces_;
  double lastDisplacement_ = 0.0, maxForce_ = 0.0;
};

const bool registered = ReferenceRegistry::add(
    "force-displacement", [](config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<ForceDisplacement>(m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
