// pd-dem-contact: PD-DEM contact coupling through hybrid surface particles
// (Hartmann, Thoeni, Rojek 2022, Sec. 3). PD exports its surface particles
// (position, velocity, quasi-radius R = (3V / 4 pi)^(1/3), Eq. 39, body,
// reference position, horizon); DEM treats them as driven spheres, finds
// DEM-hybrid and hybrid-hybrid contacts (pairs of one PD family excluded) and
// returns the mean contact force on every hybrid particle over its interval;
// PD adds it as f^Coupling in f = f^PD + f^DEM + f^Coupling + m b (Eq. 40),
// f^Coupling of a hybrid particle being the sum of its contact (and wall)
// forces. Its body force m b stays in PD (counted once, Sec. 3.2).
//
// Each exchange stages PD's latest hybrid states to DEM and DEM's latest
// hybrid forces to PD. Which states and forces are "latest" is the schedule's
// business: lockstep + order parallel exchanges both at once (each solver
// sees the other's state at the interval's start); multirate with
// order: fine-first / coarse-first gives the staggered updates of Eq. 46-47
// (docs/pd_dem_coupling.md).
//
// Hybrid kinematics over a DEM interval (key `kinematics`):
//   extrapolated: DEM moves the hybrid spheres with PD's velocities (default);
//   held:         DEM keeps them at PD's positions (zero velocity sent). When
//                 DEM takes one step over several PD steps, extrapolating PD's
//                 surface velocity (which carries its fastest modes) over the
//                 whole interval can feed energy back into them.
//
// Contact forces over PD's sub-steps (key `forces`):
//   held:       PD applies DEM's force unchanged over all its sub-steps (Hartmann
//               Alg. 2). A held contact spring is integrated with the coarse
//               step while the particle moves with the fine one, which adds
//               energy each coarse step (H2 at m = 6 diverged).
//   linearised: DEM also sends, per hybrid particle, where the force was
//               evaluated and K = -df/dx summed over its contacts; PD applies
//               f = F - K (x - x_F) at every sub-step (clamped so it never
//               reverses), so the contact stiffness is integrated with PD's step.
//
// The hybrid set (ids, bodies, reference positions, radii, horizons) is fixed:
// PD sends it with its setup outputs, states alone after that (pddem.capnp),
// and this coupling keeps it and sends it to DEM until a reply of DEM's
// carries hybrid forces (then DEM holds it): the states are half the bytes.
// With the hybrid watch (pddem.capnp) PD sends only the states DEM watches;
// this coupling passes the watch set and the partial states through.
#include <ostream>
#include <stdexcept>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

class PdDemContact final : public Coupling {
 public:
  PdDemContact(const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers)
      : Coupling(name) {
    pd_ = requireSolverName(m, "pd", solvers);
    dem_ = requireSolverName(m, "dem", solvers);
    if (!pd_.empty() && pd_ == dem_) m.error("dem", "pd and dem must name two different solvers");
    const std::string kinematics = m.string("kinematics", "extrapolated");
    if (kinematics != "extrapolated" && kinematics != "held")
      m.error("kinematics", "must be extrapolated or held, got '" + kinematics + "'");
    held_ = kinematics == "held";
    const std::string forces = m.string("forces", "held");
    if (forces != "held" && forces != "linearised")
      m.error("forces", "must be held or linearised, got '" + forces + "'");
    linearised_ = forces == "linearised";
  }

  std::string kind() const override { return "pd-dem-contact"; }
  std::vector<std::string> participants() const override { return {pd_, dem_}; }
  std::vector<std::string> requiredCapabilities(const std::string& /*solver*/) const override {
    return {"hybrid-particles"};
  }
  void describe(std::ostream& out) const override {
    out << pd_ << " hybrid surface particles (Eq. 39) -> " << dem_ << " driven spheres; " << dem_
        << " contact forces -> " << pd_ << " (Hartmann 2022 Sec. 3), hybrid kinematics "
        << (held_ ? "held" : "extrapolated") << ", contact forces " << (linearised_ ? "linearised" : "held");
  }

  void setupReference(const std::map<std::string, proto::CouplingData::Reader>& outputs) override {
    demHoldsSet_ = false;  // a DEM process just set up (a start or a resume) holds no set
    const auto pd = outputs.find(pd_);
    if (pd == outputs.end() || !pd->second.hasHybridParticles()) return;
    for (auto h : pd->second.getHybridParticles())
      if (h.getIds().size() > 0) set_.remember(h);
  }

  void exchange(ExchangeContext& ctx) override {
    const auto pd = ctx.outputs.find(pd_);
    const auto dem = ctx.outputs.find(dem_);
    if (pd == ctx.outputs.end() || dem == ctx.outputs.end()) return;
    // DEM returns hybrid forces once it holds the set; a reply that a resume
    // replays comes from the process before it.
    if (!ctx.replay && dem->second.hasHybridForces()) demHoldsSet_ = true;
    stageParticles(pd->second, ctx);
    stageForces(dem->second, ctx);
  }

 private:
  void stageParticles(proto::CouplingData::Reader pd, ExchangeContext& ctx) {
    if (!pd.hasHybridParticles() || pd.getHybridParticles().size() == 0)
      throw std::runtime_error("coupling '" + name() + "': solver '" + pd_ + "' sent no hybrid particles at exchange " +
                               std::to_string(ctx.exchange) + " (is params.hybrid false?)");
    for (auto h : pd.getHybridParticles()) {
      const bool carriesSet = h.getIds().size() > 0;
      if (carriesSet && set_.ids.empty()) set_.remember(h);
      if (set_.ids.empty())
        throw std::runtime_error("coupling '" + name() + "': solver '" + pd_ + "' sent hybrid particle states at exchange " +
                                 std::to_string(ctx.exchange) +
                                 " without their set (ids, body ids, reference positions, radii, horizons), and "
                                 "its setup outputs carried none");
      InputAssembler::StagedHybridParticles staged;
      staged.positions = wire::view(h.getPositions());
      staged.velocities = wire::view(h.getVelocities());
      staged.wantStiffness = linearised_;
      staged.serial = h.getSerial();
      staged.partial = h.getPartial();
      staged.watchBasis = h.getWatchBasis();
      if (staged.partial) staged.indices = wire::view(h.getIndices());
      const std::size_t n = staged.partial ? staged.indices.size() : carriesSet ? h.getIds().size() : set_.ids.size();
      if (staged.positions.size() != 3 * n || staged.velocities.size() != 3 * n)
        throw std::runtime_error("coupling '" + name() + "': solver '" + pd_ + "' sent " +
                                 std::to_string(staged.positions.size()) + " position and " +
                                 std::to_string(staged.velocities.size()) + " velocity values for " +
                                 std::to_string(n) + " hybrid particles (need 3 per particle)");
      if (held_) {
        zeros_.assign(staged.velocities.size(), 0.0);
        staged.velocities = zeros_;
      }
      // Ids a message carries name its order; without them it is the set's.
      if (carriesSet) staged.ids = wire::view(h.getIds());
      if (!demHoldsSet_ && carriesSet) {
        staged.bodyIds = wire::view(h.getBodyIds());
        staged.referencePositions = wire::view(h.getReferencePositions());
        staged.radii = wire::view(h.getRadii());
        staged.horizons = wire::view(h.getHorizons());
      } else if (!demHoldsSet_) {
        staged.ids = set_.ids;
        staged.bodyIds = set_.bodyIds;
        staged.referencePositions = set_.referencePositions;
        staged.radii = set_.radii;
        staged.horizons = set_.horizons;
      }
      ctx.inputs[dem_].stageHybridParticles(staged);
    }
  }

  void stageForces(proto::CouplingData::Reader dem, ExchangeContext& ctx) const {
    if (!dem.hasHybridForces()) return;  // DEM has not seen the hybrid particles yet (setup outputs)
    for (auto f : dem.getHybridForces()) {
      const auto ids = wire::view(f.getIds());
      const auto forces = wire::view(f.getForces());
      InputAssembler::StagedHybridForces staged{ids, forces};
      // A replayed reply's watch set rests on a message of the processes before the resume.
      if (!ctx.replay) staged.watch = watchOf(f);
      if (linearised_) {
        staged.positions = wire::view(f.getPositions());
        staged.stiffness = wire::view(f.getStiffness());
        if (staged.positions.size() != 3 * ids.size() || staged.stiffness.size() != 6 * ids.size())
          throw std::runtime_error("coupling '" + name() + "' (forces: linearised): solver '" + dem_ + "' sent " +
                                   std::to_string(staged.positions.size()) + " positions and " +
                                   std::to_string(staged.stiffness.size()) + " stiffness values for " +
                                   std::to_string(ids.size()) + " hybrid particles (need 3 and 6 per particle)");
      }
      ctx.inputs[pd_].stageHybridForces(staged);
      record(ids, forces, ctx);
    }
  }

  static InputAssembler::StagedHybridWatch watchOf(proto::HybridForces::Reader f) {
    InputAssembler::StagedHybridWatch w;
    w.sendAll = f.getSendAll();
    w.watchSet = f.getWatchSet();
    if (!w.watchSet) return w;
    w.watched = wire::view(f.getWatched());
    w.margin = f.getWatchMargin();
    w.interval = f.getWatchInterval();
    w.basis = f.getWatchBasis();
    return w;
  }

  /// Total force on PD's surface (= minus the force on DEM spheres and walls) and
  /// the number of loaded hybrid particles, under /series/<name>/.
  void record(std::span<const std::uint32_t> ids, std::span<const double> forces, ExchangeContext& ctx) const {
    if (!ctx.series) return;
    double total[3] = {0, 0, 0};
    double loaded = 0.0;
    for (std::size_t k = 0; k < ids.size(); ++k) {
      const double* f = &forces[3 * k];
      for (int d = 0; d < 3; ++d) total[d] += f[d];
      loaded += (f[0] != 0.0 || f[1] != 0.0 || f[2] != 0.0) ? 1.0 : 0.0;
    }
    ctx.series->append(name() + "/hybrid_force", std::span<const double>(total, 3));
    ctx.series->append(name() + "/loaded_particles", loaded);
  }

  /// PD's hybrid set, kept from the first message that carried it.
  struct HybridSet {
    std::vector<std::uint32_t> ids, bodyIds;
    std::vector<double> referencePositions, radii, horizons;
    void remember(proto::HybridParticles::Reader h) {
      auto copy = [](auto& to, auto list) {
        const auto v = wire::view(list);
        to.assign(v.begin(), v.end());
      };
      copy(ids, h.getIds());
      copy(bodyIds, h.getBodyIds());
      copy(referencePositions, h.getReferencePositions());
      copy(radii, h.getRadii());
      copy(horizons, h.getHorizons());
    }
  };

  std::string pd_, dem_;
  HybridSet set_;
  bool demHoldsSet_ = false;
  bool held_ = false;
  bool linearised_ = false;
  std::vector<double> zeros_;  // velocities staged with held kinematics
};

const bool registered = CouplingRegistry::add(
    "pd-dem-contact", [](const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<PdDemContact>(name, m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
