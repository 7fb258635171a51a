// arlequin: FEM-DEM volume coupling by penalty in an overlap zone (Cheng 2022
// Sec. 5.2, App. B; DESIGN.md 6.3). At setup both solvers receive the weight
// profile w(x) (DEM weighted by w, FEM by 1 - w, Eqs. 25-26). At the first
// exchange the coupling builds the homogenisation operator Pi (Eq. 27) from
// the reference configuration; at every exchange it homogenises the particle
// displacements onto the zone nodes, u^DE = Pi u_p, and stages the penalty
// forces f_i = eps sum_j M_ij (u^DE_j - u^FE_j) on the FE nodes (Eqs. 31, 38)
// and f_a = -sum_i Pi_ia f_i on the particles (Eqs. 32, 39), which sum to zero
// (Eq. 41). It records the weighted mass, momentum and energy of the coupled
// system and stops the run when the coupling diverges.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <ostream>
#include <sstream>
#include <vector>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/analysis/run_report.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/analysis/solver_energies.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/coupler/mapping/cg_kernel.hpp"
#include "cosim/coupler/mapping/homogenisation.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/util/weight_profile.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

std::string number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

class ArlequinCoupling final : public Coupling {
 public:
  ArlequinCoupling(const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers)
      : Coupling(name) {
    dem_ = requireSolverName(m, "dem", solvers);
    fem_ = requireSolverName(m, "fem", solvers);
    zone_ = m.requireString("zone");
    readProfile(m);
    epsilon_ = m.requireNumber("penalty", config::Range::positive());
    width_ = m.number("width", 0.0, config::Range::nonNegative());
    const std::string kernel = m.string("kernel", width_ > 0.0 ? "lucy" : "dirac");
    try {
      kernel_ = CgKernelRegistry::create(kernel, "CG kernel");
    } catch (const std::invalid_argument& e) {
      m.error("kernel", e.what());
    }
    if (kernel_ && kernel_->isDirac() && width_ > 0.0)
      m.error("width", "the dirac kernel has no width: use width 0 or kernel lucy|gaussian");
    // width 0 is the c -> 0 limit of every kernel: the Dirac form (Eq. 19),
    // so a sweep over c can keep its kernel.
    increments_ = m.choice("constraint", {"displacement", "increment"}, "displacement") == "increment";
    lumped_ = m.choice("penalty_matrix", {"consistent", "lumped"}, "consistent") == "lumped";
    perElement_ = m.choice("projection", {"zone", "element"}, "zone") == "element";
    cgPoints_ = m.choice("cg_quadrature", {"resolved", "element"}, "resolved") == "element" ? 2 : 0;
    predict_ = m.choice("gap_prediction", {"time-centred", "none"}, "time-centred") == "time-centred";
    maxGrowth_ = m.number("max_energy_growth", 100.0, config::Range{1.0, 1e300, true});
    if (m.has("system")) {
      config::MapReader s(m.node("system"), m.keyPath("system"), m.diagnostics());
      systemDem_ = s.requireString("dem");
      systemFem_ = s.requireString("fem");
      s.finish();
    }
    if (!dem_.empty() && dem_ == fem_) m.error("fem", "the DEM and FEM sides must be different solvers");
  }

  std::string kind() const override { return "arlequin"; }
  bool usesEnergies() const override { return true; }
  std::vector<std::string> participants() const override { return {dem_, fem_}; }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == dem_) return {"particle-states", "external-forces"};
    return {};
  }

  void describe(std::ostream& out) const override {
    out << dem_ << " <-> " << fem_ << ": arlequin zone " << zone_ << ", w " << profile_.kind << " along "
        << "xyz"[profile_.axis] << " from " << profile_.start << " to " << profile_.end << ", penalty " << epsilon_
        << " Pa/m^2, " << (width_ > 0.0 ? kernel_->name() + " c = " + number(width_) + " m" : std::string("c = 0"))
        << ", constraint on " << (increments_ ? "increments" : "displacements") << (lumped_ ? ", lumped M" : "") << (perElement_ ? ", per-element Pi" : "")
        << (predict_ ? "" : ", no gap prediction");
    if (profile_.low > 0.0 || profile_.high < 1.0) out << ", w in [" << profile_.low << ", " << profile_.high << "]";
    if (profile_.nodalFem) out << ", nodal FE weights";
  }

  void stageSetup(std::map<std::string, InputAssembler>& inputs) const override {
    inputs[dem_].stageWeightProfile(profile_);
    inputs[fem_].stageWeightProfile(profile_);
  }

  /// Pi and M from the setup outputs, so the penalty's stiffness is known
  /// before the time step is chosen.
  void setupReference(const std::map<std::string, proto::CouplingData::Reader>& outputs) override {
    const auto d = outputs.find(dem_), f = outputs.find(fem_);
    if (d == outputs.end() || f == outputs.end()) return;
    build(particleZone(d->second, zone_, 0), f->second, 0);
  }

  /// The penalty springs stiffen both sides (Cheng Eqs. 31-32): each solver's
  /// step becomes 2 / sqrt((2 / dt)^2 + omega_penalty^2) for the DOFs it
  /// integrates (the frequencies add in the Gershgorin bound of one row).
  void limitCriticalSteps(std::map<std::string, double>& criticalDt) const override {
    if (!penalty_) return;
    const auto tighten = [](double& dt, double omega) {
      if (omega <= 0.0) return;
      dt = dt > 0.0 ? 2.0 / std::sqrt(4.0 / (dt * dt) + omega * omega) : 2.0 / omega;
    };
    tighten(criticalDt[fem_], frequencies_.nodes);
    tighten(criticalDt[dem_], frequencies_.particles);
  }

  /// The penalty forces of an exchange depend on the exchanges before it
  /// (the increments of Cheng Sec. 5.2.3, the time-centred prediction, the
  /// energy guard's first value): a checkpoint keeps that history as it was
  /// before its own exchange, which the resume replays.
  bool keepsState() const override { return true; }
  void save(util::BinaryWriter& out) const override {
    out.pod(beforeLast_.lastTime);
    out.pod(beforeLast_.referenceEnergy);
    for (const auto* m : {&beforeLast_.particles, &beforeLast_.nodes, &beforeLast_.vParticles, &beforeLast_.vNodes}) {
      out.pod(static_cast<std::uint64_t>(m->rows()));
      out.vec(std::vector<double>(m->data(), m->data() + m->size()));
    }
  }
  void restore(util::BinaryReader& in) override {
    History h;
    h.lastTime = in.pod<double>("arlequin: time of the last exchange");
    h.referenceEnergy = in.pod<double>("arlequin: first energy");
    for (auto* m : {&h.particles, &h.nodes, &h.vParticles, &h.vNodes}) {
      const auto rows = in.pod<std::uint64_t>("arlequin: history rows");
      const auto values = in.vec<double>("arlequin: history");
      if (values.size() != 3 * rows) in.fail("arlequin: history", "not 3 values per row");
      *m = Eigen::Map<const Eigen::MatrixX3d>(values.data(), static_cast<Eigen::Index>(rows), 3);
    }
    now_ = beforeLast_ = h;
  }

  void conclude(RunReport& report) const override {
    report.figures["penalty_omega_nodes_rad_s"] = frequencies_.nodes;
    report.figures["penalty_omega_particles_rad_s"] = frequencies_.particles;
  }

  void exchange(ExchangeContext& ctx) override {
    const auto d = ctx.outputs.find(dem_), f = ctx.outputs.find(fem_);
    if (d == ctx.outputs.end() || f == ctx.outputs.end()) return;
    // A resumed run replays the checkpoint's exchange from the history it had
    // before that exchange (restore()), so it stages the same forces again.
    if (!ctx.replay) beforeLast_ = now_;
    const proto::ParticleStates::Reader particles = particleZone(d->second, zone_, ctx.exchange);
    if (!penalty_) build(particles, f->second, ctx.exchange);
    const double dt = ctx.exchange > 0 ? ctx.time - now_.lastTime : 0.0;
    now_.lastTime = ctx.time;
    gatherDisplacements(particles, f->second, ctx.exchange, dt);
    penalty_->compute(uParticles_, uNodes_, forces_);
    checkForces(ctx);
    stage(ctx);
    record(ctx, d->second, f->second);
  }

 private:
  void readProfile(config::MapReader& m) {
    if (!m.has("profile")) {
      m.error("profile", "missing: the weight profile {kind, axis, start, end}");
      return;
    }
    config::MapReader p(m.node("profile"), m.keyPath("profile"), m.diagnostics());
    profile_.kind = p.choice("kind", {"half-cosine", "linear"}, "half-cosine");
    const std::string axis = p.choice("axis", {"x", "y", "z"}, "x");
    profile_.axis = axis == "x" ? 0 : axis == "y" ? 1 : 2;
    profile_.start = p.requireNumber("start");
    profile_.end = p.requireNumber("end");
    // The published runs' 0.1-0.9 range and nodal FE weights
    // (shared/reference/cheng2022); the paper's text: 0-1 at the FE points.
    profile_.low = p.number("w_min", 0.0, config::Range::closed(0.0, 1.0));
    profile_.high = p.number("w_max", 1.0, config::Range::closed(0.0, 1.0));
    profile_.nodalFem = p.choice("fem_weights", {"points", "nodes"}, "points") == "nodes";
    p.finish();
    if (p.valid() && m.diagnostics().ok())
      if (const std::string why = profile_.problem(); !why.empty()) m.error("profile", why);
  }

  std::string where(std::uint64_t exchange) const {
    return "coupling '" + name() + "' (exchange " + std::to_string(exchange) + ")";
  }

  proto::ParticleStates::Reader particleZone(proto::CouplingData::Reader out, const std::string& zone,
                                             std::uint64_t exchange) const {
    for (auto s : out.getParticles())
      if (zone == s.getZone().cStr()) return s;
    throw std::runtime_error(where(exchange) + ": solver '" + dem_ + "' sent no particle zone '" + zone +
                             "' (declare it under its params.zones)");
  }

  std::span<const double> femArray(proto::CouplingData::Reader out, const std::string& zone, const std::string& what,
                                   std::uint64_t exchange) const {
    proto::NamedArray::Reader a;
    if (!wire::findArray(out.getArrays(), zone + "/" + what, a))
      throw std::runtime_error(where(exchange) + ": solver '" + fem_ + "' sent no array '" + zone + "/" + what +
                               "' (declare the zone under its params.coupling.zones)");
    return wire::view(a.getValues());
  }

  /// Pi (Eq. 27) and M (Eq. 32) from the reference configuration.
  void build(const proto::ParticleStates::Reader& particles, proto::CouplingData::Reader fem, std::uint64_t exchange) {
    const std::string what = where(exchange) + ": FEM zone '" + zone_ + "'";
    mesh_ = ZoneMesh::fromArrays(femArray(fem, zone_, "nodes", exchange), femArray(fem, zone_, "node_positions", exchange),
                                 femArray(fem, zone_, "elements", exchange), what);
    const Eigen::Vector3d extent = mesh_.upper() - mesh_.lower();
    if (width_ > extent[profile_.axis])
      throw std::runtime_error(where(exchange) + ": CG width c = " + number(width_) + " m exceeds the coupling zone's length " +
                               number(extent[profile_.axis]) + " m along the profile axis: the homogenisation would reach far outside it");
    ParticleCloud cloud = referenceCloud(particles, exchange);
    const Smoothing smoothing{width_ > 0.0 ? kernel_.get() : nullptr, width_, cgPoints_};
    if (perElement_) {
      ElementPenalty e = elementPenalty(mesh_, cloud, smoothing, lumped_);
      penalty_ = std::make_unique<PenaltyCoupling>(std::move(e.pi), std::move(e.matrix), epsilon_, std::move(e.gather));
    } else {
      SparseMatrix matrix = zoneMatrix(mesh_, femArray(fem, zone_, "matrix", exchange), what);
      if (lumped_) matrix = rowSumLumped(matrix);
      penalty_ = std::make_unique<PenaltyCoupling>(homogenisation(mesh_, cloud, smoothing), std::move(matrix), epsilon_);
    }
    // Inertia as the solvers integrate it: FEM's (1 - w)-weighted lumped
    // masses, w m for the particles (Cheng Eqs. 25-26).
    const auto nodeMasses = femArray(fem, zone_, "masses", exchange);
    std::vector<double> inertia(cloud.masses.size());
    for (std::size_t k = 0; k < inertia.size(); ++k)
      inertia[k] = profile_.along(cloud.positions[k][profile_.axis]) * cloud.masses[k];
    frequencies_ = penalty_->maxFrequencies({nodeMasses.begin(), nodeMasses.end()}, inertia);
    nodeIds_ = mesh_.nodes;
    particleForces_.assign(3 * particleIds_.size(), 0.0);
    nodeForces_.assign(3 * nodeIds_.size(), 0.0);
  }

  ParticleCloud referenceCloud(const proto::ParticleStates::Reader& s, std::uint64_t exchange) {
    const auto ids = wire::view(s.getIds());
    const auto x = wire::view(s.getPositions()), u = wire::view(s.getDisplacements());
    const auto m = wire::view(s.getMasses());
    if (ids.empty()) throw std::runtime_error(where(exchange) + ": DEM zone '" + zone_ + "' holds no particle");
    if (x.size() != 3 * ids.size() || u.size() != 3 * ids.size() || m.size() != ids.size())
      throw std::runtime_error(where(exchange) + ": DEM zone '" + zone_ + "' arrays do not match its " +
                               std::to_string(ids.size()) + " ids");
    ParticleCloud c;
    particleIds_.assign(ids.begin(), ids.end());
    for (std::size_t k = 0; k < ids.size(); ++k) {
      c.positions.emplace_back(x[3 * k] - u[3 * k], x[3 * k + 1] - u[3 * k + 1], x[3 * k + 2] - u[3 * k + 2]);
      c.masses.push_back(m[k]);
    }
    return c;
  }

  void gatherDisplacements(const proto::ParticleStates::Reader& s, proto::CouplingData::Reader fem, std::uint64_t exchange,
                           double dt) {
    const auto ids = wire::view(s.getIds());
    const auto u = wire::view(s.getDisplacements());
    if (ids.size() != particleIds_.size() || !std::equal(ids.begin(), ids.end(), particleIds_.begin()) ||
        u.size() != 3 * ids.size())
      throw std::runtime_error(where(exchange) + ": DEM zone '" + zone_ + "' changed its particles since setup");
    const auto un = femArray(fem, zone_, "displacement", exchange);
    if (un.size() != 3 * nodeIds_.size())
      throw std::runtime_error(where(exchange) + ": FEM zone '" + zone_ + "' sent " + std::to_string(un.size()) +
                               " displacement values for " + std::to_string(nodeIds_.size()) + " nodes");
    Eigen::MatrixX3d up(static_cast<Eigen::Index>(ids.size()), 3), uf(static_cast<Eigen::Index>(nodeIds_.size()), 3);
    for (Eigen::Index k = 0; k < up.rows(); ++k)
      for (Eigen::Index i = 0; i < 3; ++i) up(k, i) = u[static_cast<std::size_t>(3 * k + i)];
    for (Eigen::Index k = 0; k < uf.rows(); ++k)
      for (Eigen::Index i = 0; i < 3; ++i) uf(k, i) = un[static_cast<std::size_t>(3 * k + i)];
    // Both solvers apply the staged forces at the end of their next step
    // (velocity Verlet / central differences evaluate forces at t + dt). A
    // penalty computed from the displacements at t would lag one step, which
    // pumps energy into the stiff penalty springs; predict the displacements
    // at t + dt instead, u + dt v + dt^2/2 a, with a from the last two
    // velocities (exact for one step per exchange).
    // `gap_prediction: none` is the published runs' staggered exchange: the
    // forces of the step to t + dt from the displacements at t.
    if (predict_) {
      predict(up, velocitiesOf(wire::view(s.getVelocities()), ids.size()), now_.vParticles, dt);
      predict(uf, velocitiesOf(femArray(fem, zone_, "velocity", exchange), nodeIds_.size()), now_.vNodes, dt);
    }
    if (!up.allFinite() || !uf.allFinite())
      throw std::runtime_error(where(exchange) + ": non-finite displacements in the coupling zone: the run diverged");
    if (increments_) {
      // Cheng Sec. 5.2.3: penalise the displacements of the last exchange
      // interval, u^FE = X_t - X_{t-dt}, u^DE = v^DE dt.
      if (now_.particles.size() == 0) now_.particles = up, now_.nodes = uf;
      uParticles_ = up - now_.particles;
      uNodes_ = uf - now_.nodes;
      now_.particles = up;
      now_.nodes = uf;
    } else {
      uParticles_ = up;
      uNodes_ = uf;
    }
  }

  Eigen::MatrixX3d velocitiesOf(std::span<const double> v, std::size_t rows) const {
    if (v.size() != 3 * rows)
      throw std::runtime_error("coupling '" + name() + "': " + std::to_string(v.size()) + " velocity values for " +
                               std::to_string(rows) + " zone points");
    Eigen::MatrixX3d out(static_cast<Eigen::Index>(rows), 3);
    for (std::size_t k = 0; k < v.size(); ++k) out(static_cast<Eigen::Index>(k / 3), static_cast<Eigen::Index>(k % 3)) = v[k];
    return out;
  }

  static void predict(Eigen::MatrixX3d& u, const Eigen::MatrixX3d& v, Eigen::MatrixX3d& previousV, double dt) {
    if (dt > 0.0 && previousV.rows() == v.rows()) u += dt * v + 0.5 * dt * (v - previousV);
    else if (dt > 0.0) u += dt * v;
    previousV = v;
  }

  void checkForces(const ExchangeContext& ctx) const {
    const double fn = forces_.onNodes.cwiseAbs().maxCoeff(), fp = forces_.onParticles.cwiseAbs().maxCoeff();
    if (!std::isfinite(fn) || !std::isfinite(fp) || !std::isfinite(forces_.energy))
      throw std::runtime_error(where(ctx.exchange) + " at t = " + number(ctx.time) + " s: the penalty forces diverged (max |f| on nodes " +
                               number(fn) + " N, on particles " + number(fp) + " N, penalty energy " + number(forces_.energy) +
                               " J); lower the penalty, the time step or the CG width");
  }

  void stage(ExchangeContext& ctx) {
    for (std::size_t k = 0; k < nodeIds_.size(); ++k)
      for (Eigen::Index i = 0; i < 3; ++i) nodeForces_[3 * k + static_cast<std::size_t>(i)] = forces_.onNodes(static_cast<Eigen::Index>(k), i);
    for (std::size_t k = 0; k < particleIds_.size(); ++k)
      for (Eigen::Index i = 0; i < 3; ++i)
        particleForces_[3 * k + static_cast<std::size_t>(i)] = forces_.onParticles(static_cast<Eigen::Index>(k), i);
    ctx.inputs[fem_].stageForces({zone_, proto::CouplingForces::Target::NODES, nodeIds_, nodeForces_});
    ctx.inputs[dem_].stageForces({zone_, proto::CouplingForces::Target::PARTICLES, particleIds_, particleForces_});
  }

  static double energy(const ExchangeContext& ctx, const std::string& solver, std::initializer_list<const char*> names) {
    return ctx.energies ? sumEnergies(*ctx.energies, solver, names) : 0.0;
  }

  /// Weighted mass and momentum (Cheng Eqs. 25-26): DEM particles by w at
  /// their reference positions, FE nodes by their lumped (1 - w) masses.
  void systemTotals(proto::CouplingData::Reader dem, proto::CouplingData::Reader fem, std::uint64_t exchange,
                    double& mass, Eigen::Vector3d& momentum) const {
    mass = 0.0;
    momentum.setZero();
    const auto s = particleZone(dem, systemDem_, exchange);
    const auto x = wire::view(s.getPositions()), u = wire::view(s.getDisplacements()), v = wire::view(s.getVelocities());
    const auto m = wire::view(s.getMasses());
    for (std::size_t k = 0; k < m.size(); ++k) {
      const double w = profile_(Eigen::Vector3d(x[3 * k] - u[3 * k], x[3 * k + 1] - u[3 * k + 1], x[3 * k + 2] - u[3 * k + 2]));
      mass += w * m[k];
      momentum += w * m[k] * Eigen::Vector3d(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
    }
    const auto mn = femArray(fem, systemFem_, "masses", exchange), vn = femArray(fem, systemFem_, "velocity", exchange);
    for (std::size_t k = 0; k < mn.size(); ++k) {
      mass += mn[k];
      momentum += mn[k] * Eigen::Vector3d(vn[3 * k], vn[3 * k + 1], vn[3 * k + 2]);
    }
  }

  void record(const ExchangeContext& ctx, proto::CouplingData::Reader dem, proto::CouplingData::Reader fem) {
    // Solver energies arrive already weighted (DEM by w, FEM by 1 - w).
    const double eDem = energy(ctx, dem_, {"kinetic", "elastic", "potential"});
    const double eFem = energy(ctx, fem_, {"kinetic", "strain", "hourglass"});
    // The penalty of the displacement form is a stored (spring) energy; the
    // increment form's penalty acts like a damper and stores none.
    const double total = eDem + eFem + (increments_ ? 0.0 : forces_.energy);
    if (!std::isfinite(total))
      throw std::runtime_error(where(ctx.exchange) + " at t = " + number(ctx.time) + " s: the weighted energy is not finite (DEM " +
                               number(eDem) + " J, FEM " + number(eFem) + " J, penalty " + number(forces_.energy) + " J)");
    if (now_.referenceEnergy <= 0.0 && total > 0.0) now_.referenceEnergy = total;
    // Energy put in since by DEM's drives (a driven layer, Cheng Table 4 (b))
    // raises the bound; the penalty's own work is not input.
    const double supplied = now_.referenceEnergy + std::max(0.0, energy(ctx, dem_, {"drive_work"}));
    if (now_.referenceEnergy > 0.0 && total > maxGrowth_ * supplied)
      throw std::runtime_error(where(ctx.exchange) + " at t = " + number(ctx.time) + " s: the coupled energy diverged: " +
                               number(total) + " J (DEM " + number(eDem) + ", FEM " + number(eFem) + ", penalty " +
                               number(forces_.energy) + ") is more than " + number(maxGrowth_) + " times its first value " +
                               number(now_.referenceEnergy) + " J plus the work done on DEM since (" + number(supplied) +
                               " J together; max_energy_growth); lower the penalty or the CG width");
    if (!ctx.series) return;
    const Eigen::Vector3d sumNodes = forces_.onNodes.colwise().sum(), sumParticles = forces_.onParticles.colwise().sum();
    const Eigen::Vector3d balance = sumNodes + sumParticles;
    const double gap = (forces_.uDe - forces_.uFe).cwiseAbs().maxCoeff();
    const std::string p = name() + "/";
    ctx.series->append(p + "dem_energy", eDem);
    ctx.series->append(p + "fem_energy", eFem);
    ctx.series->append(p + "penalty_energy", forces_.energy);
    ctx.series->append(p + "energy", total);
    ctx.series->append(p + "force_balance", std::span<const double>(balance.data(), 3));
    ctx.series->append(p + "max_gap", gap);
    if (systemDem_.empty()) return;
    double mass = 0.0;
    Eigen::Vector3d momentum;
    systemTotals(dem, fem, ctx.exchange, mass, momentum);
    ctx.series->append(p + "mass", mass);
    ctx.series->append(p + "momentum", std::span<const double>(momentum.data(), 3));
  }

  /// What the next exchange reads of the earlier ones.
  struct History {
    double lastTime = 0.0, referenceEnergy = 0.0;
    Eigen::MatrixX3d particles, nodes, vParticles, vNodes;
  };

  std::string dem_, fem_, zone_, systemDem_, systemFem_;
  History now_, beforeLast_;  // the history as it is, and as it was before the last exchange
  util::WeightProfile profile_;
  double epsilon_ = 0.0, width_ = 0.0, maxGrowth_ = 100.0;
  int cgPoints_ = 0;  // Gauss points per direction of the CG integral (0: resolved)
  bool increments_ = false, lumped_ = false, predict_ = true, perElement_ = false;
  std::unique_ptr<CgKernel> kernel_;
  ZoneMesh mesh_;
  std::unique_ptr<PenaltyCoupling> penalty_;
  PenaltyCoupling::Frequencies frequencies_;
  PenaltyCoupling::Forces forces_;
  Eigen::MatrixX3d uParticles_, uNodes_;
  // Staged views point into these until the next exchange.
  std::vector<std::uint32_t> nodeIds_, particleIds_;
  std::vector<double> nodeForces_, particleForces_;
};

const bool registered = CouplingRegistry::add(
    "arlequin", [](const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<ArlequinCoupling>(name, m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
