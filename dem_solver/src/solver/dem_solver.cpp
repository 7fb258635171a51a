#include "cosim/dem/solver/dem_solver.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/util/finite.hpp"
#include "cosim/wire/weight_profile.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/coupling_forces.hpp"

namespace cosim::dem {
namespace {

using wire::SolverError;
using Code = proto::Error::Code;

const std::vector<std::string> kFieldNames{"positions", "velocities", "angular_velocities", "orientations",
                                           "forces", "radii", "masses", "ids", "energies", "coordination",
                                           "plane_wall_forces", "stress", "unbalanced_force_index",
                                           "porosity"};

std::vector<double> flat(const std::vector<Vec3>& v) {
  std::vector<double> out(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int d = 0; d < 3; ++d) out[3 * i + static_cast<std::size_t>(d)] = v[i][d];
  return out;
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace

wire::SolverInfo DemSolver::info() const {
  wire::SolverInfo i;
  i.kind = "dem";
  i.version = "0.1.0";
  i.capabilities = wire::baseCapabilities();
  for (const char* c : {"particles", "plane-walls", "triangle-walls", "contact-list", "external-forces",
                        "driven-particles", "particle-states", "critical-dt", "energies", "hdf5-snapshots",
                        "unit-cells", "unit-cell-adoption", "pool-member", "hybrid-particles"})
    i.capabilities.emplace_back(c);
  return i;
}

void DemSolver::setup(const wire::SetupContext& context, proto::CouplingData::Builder outputs) {
  sceneFile_ = context.sceneFile.empty() ? std::string("<scene>") : context.sceneFile;
  instance_ = context.instance;
  runDir_ = context.runDir;
  system_ = DemSystem{};
  settings_ = RunSettings{};
  reported_.clear();
  cells_.reset();
  zoneForceSums_.clear();
  try {
    const YAML::Node params = findSolverParams(context.sceneYaml, sceneFile_, context.paramsEntry());
    if (context.poolSize > 0 && !params["unit_cells"])
      throw SolverError(Code::BAD_INPUT, sceneFile_ + ": solver '" + context.paramsEntry() +
                                             "': pool: a pool's workers are GMH unit-cell workers (params.unit_cells)");
    if (params["unit_cells"]) {  // GMH worker: answers unitCellJobs only
      const PoolShare share{context.poolIndex, std::max<std::uint32_t>(1, context.poolSize)};
      cells_ = UnitCellWorker::fromParams(params, sceneFile_, context.baseDir(), share);
      cells_->report(outputs);
      ready_ = true;
      return;
    }
    configure(params, sceneFile_, system_, settings_, context.baseDir());
    system_.initialize();
    checkParticles(system_, settings_.overlapTolerance, sceneFile_ + ": solver '" + instance_ + "'");
  } catch (const SolverError&) {
    throw;
  } catch (const std::exception& e) {
    throw SolverError(Code::BAD_INPUT, e.what());
  }
  hybrids_ = HybridSpheres{};
  hybrids_.watch().requestedMargin = settings_.hybridWatchMargin;
  applyInputs(context.inputs);
  applyWeightProfile(context.inputs);
  selectZoneMembers();
  selectDriveMembers();
  if (settings_.dt > 0.0) checkDt(settings_.dt, sceneFile_ + ": solver '" + instance_ + "': params.dt");
  if (settings_.snapshotEvery > 0) {
    std::filesystem::path file = settings_.snapshotFile.empty() ? instance_ + ".h5" : settings_.snapshotFile;
    if (file.is_relative() && !runDir_.empty()) file = std::filesystem::path(runDir_) / file;
    try {
      snapshots_ = std::make_unique<SnapshotWriter>(file.string(), context.resuming);
      if (!context.resuming) snapshots_->write(system_);
    } catch (const std::exception& e) {
      throw SolverError(Code::BAD_INPUT, sceneFile_ + ": solver '" + instance_ + "': params.snapshots.file: " + e.what());
    }
  }
  ready_ = true;
  fillOutputs(outputs);
}

// Unit cells relax in their own pseudo time: the coarse step does not bound them.
double DemSolver::criticalDt() const {
  if (cells_) return 0.0;
  const double own = criticalTimeStep(system_), hybrid = hybridCriticalDt();
  return own > 0.0 && hybrid > 0.0 ? std::min(own, hybrid) : std::max(own, hybrid);
}

// PD integrates its hybrid particles under the contact forces returned to it
// (Hartmann 2022 Sec. 3.2), so their contacts bound the coupled step as well.
double DemSolver::hybridCriticalDt() const { return criticalTimeStep(system_, hybrids_.particleIndices()); }

void DemSolver::checkDt(double dt, const std::string& where) {
  const double crit = criticalDt();
  if (crit > 0.0 && dt > crit && !settings_.force) {
    const double hybrid = hybridCriticalDt();
    std::string whose;
    if (hybrid > 0.0 && hybrid <= crit)
      whose = ", set by the hybrid PD particles' contacts: material '" +
              system_.materials[settings_.hybridMaterial].name + "', their mass rho V";
    else if (const double bonds = bondCriticalStep(system_); bonds > 0.0 && bonds <= crit)
      whose = ", set by the bonds: params.bonds.stiffness " + num(system_.bonds.stiffness) + " N/m";
    throw SolverError(Code::BAD_INPUT, where + ": dt = " + num(dt) + " s is above the critical step " + num(crit) +
                                           " s (contact law " + system_.contactLaw().name() + whose +
                                           "); lower dt or set params.force: true");
  }
  checkedDt_ = dt;
}

void DemSolver::applyInputs(proto::CouplingData::Reader inputs) {
  Particles& p = system_.particles;
  // Forces on particles from couplings (CouplingForces, target particles).
  // The coupler restages its inputs every exchange: forces not sent again
  // stop acting, and several entries (couplings, zones) add up.
  p.fExt.clear();
  wire::forEachCouplingForce(inputs.getForces(), proto::CouplingForces::Target::PARTICLES, p.size(), "particle",
                             [&](std::uint32_t id, const double* f) {
                               p.fExt.add(id, Vec3{f[0], f[1], f[2]});
                               tookCouplingForces_ = true;
                             });
  // Driven particles: kinematics from outside.
  for (auto s : inputs.getParticles()) {
    const auto ids = wire::view(s.getIds());
    const auto x = wire::view(s.getPositions());
    const auto v = wire::view(s.getVelocities());
    if (x.size() != 3 * ids.size() || (!v.empty() && v.size() != 3 * ids.size()))
      throw SolverError(Code::BAD_INPUT, "particle states for zone '" + std::string(s.getZone().cStr()) +
                                             "': arrays must hold 3 values per id");
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (ids[k] >= p.size())
        throw SolverError(Code::BAD_INPUT, "particle states: particle id " + std::to_string(ids[k]) + " does not exist");
      p.driven[ids[k]] = 1;
      system_.setDrivenState(ids[k], {x[3 * k], x[3 * k + 1], x[3 * k + 2]},
                             v.empty() ? p.v[ids[k]] : Vec3{v[3 * k], v[3 * k + 1], v[3 * k + 2]});
    }
  }
  applyHybridParticles(inputs);
  // Moving triangle meshes (a coupled FE surface).
  for (auto m : inputs.getMeshes()) {
    const std::string name = m.getSurface().cStr();
    TriangleWallGroup* group = nullptr;
    for (auto& g : system_.meshes)
      if (g.name == name) group = &g;
    if (!group) {
      if (system_.cell.enabled)
        throw SolverError(Code::BAD_INPUT, "mesh '" + name + "': a periodic DEM cell takes no triangle-mesh walls "
                                           "(their contacts are not searched across the cell's images)");
      system_.meshes.emplace_back();
      group = &system_.meshes.back();
      group->name = name;
      group->history.resize(p.size());
    }
    const auto x = wire::view(m.getPositions());
    const auto v = wire::view(m.getVelocities());
    const auto t = wire::view(m.getTriangles());
    if (x.size() % 3 != 0 || (!v.empty() && v.size() != x.size()) || t.size() % 3 != 0)
      throw SolverError(Code::BAD_INPUT, "mesh '" + name + "': positions/velocities/triangles not in triples");
    group->vertices.resize(x.size() / 3);
    group->velocities.assign(x.size() / 3, {});
    for (std::size_t k = 0; k < x.size() / 3; ++k) {
      group->vertices[k] = {x[3 * k], x[3 * k + 1], x[3 * k + 2]};
      if (!v.empty()) group->velocities[k] = {v[3 * k], v[3 * k + 1], v[3 * k + 2]};
    }
    if (!t.empty()) {
      group->triangles.resize(t.size() / 3);
      for (std::size_t k = 0; k < t.size() / 3; ++k) group->triangles[k] = {t[3 * k], t[3 * k + 1], t[3 * k + 2]};
    }
    try {
      group->validate();
    } catch (const std::exception& e) {
      throw SolverError(Code::BAD_INPUT, e.what());
    }
  }
}

void DemSolver::applyHybridParticles(proto::CouplingData::Reader inputs) {
  // Hybrid PD surface particles (Hartmann 2022 Sec. 3): driven spheres, added at their first exchange.
  if (!inputs.hasHybridParticles()) return;
  if (inputs.getHybridParticles().size() > 1)
    throw SolverError(Code::BAD_INPUT, std::to_string(inputs.getHybridParticles().size()) +
                                           " hybrid particle sets sent; a DEM solver takes one (one PD solver)");
  for (auto h : inputs.getHybridParticles()) {
    try {
      if (!hybrids_.apply(h, system_, settings_.hybridMaterial)) continue;
      defaultSkinFromHybrids();
      system_.initialize();
      if (system_.step == 0) hybrids_.checkStartOverlaps(system_, settings_.overlapTolerance);
    } catch (const std::invalid_argument& e) {
      throw SolverError(Code::BAD_INPUT, e.what());
    }
  }
}

void DemSolver::defaultSkinFromHybrids() {
  // Without params.skin the default (kDefaultSkinPerRadius x the smallest
  // radius) takes the hybrid particles' radii in once they arrive: a skin
  // sized by DEM spheres 16 times larger (H5) listed some 30 same-body
  // hybrid pairs per particle that never touch, and every step tested them.
  if (settings_.skinGiven) return;
  double rmin = std::numeric_limits<double>::max();
  for (double r : system_.particles.radius) rmin = std::min(rmin, r);
  if (rmin < std::numeric_limits<double>::max()) system_.neighbors.skin = kDefaultSkinPerRadius * rmin;
}

void DemSolver::applyWeightProfile(proto::CouplingData::Reader inputs) {
  // Arlequin weight w of every particle from its initial position (Cheng
  // 2022 Eqs. 22-24, 26), with the formula fem_solver and the coupler use.
  if (!inputs.hasWeightProfiles() || inputs.getWeightProfiles().size() == 0) return;
  if (inputs.getWeightProfiles().size() > 1)
    throw SolverError(Code::BAD_INPUT, "setup: " + std::to_string(inputs.getWeightProfiles().size()) +
                                           " weight profiles sent; a DEM solver takes one");
  const util::WeightProfile profile = wire::read(inputs.getWeightProfiles()[0]);
  if (const std::string why = profile.problem(); !why.empty())
    throw SolverError(Code::BAD_INPUT, "setup: weight profile: " + why);
  Particles& p = system_.particles;
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.weight[i] = profile(p.x[i]);
    if (!(p.weight[i] > 0.0) && !p.driven[i])
      throw SolverError(Code::BAD_INPUT, "setup: weight profile gives particle " + std::to_string(p.id[i]) +
                                             " weight 0 (it lies beyond the profile's end " + num(profile.end) +
                                             "): it would have no inertia; remove it from the DEM domain");
  }
}

void DemSolver::advance(const wire::AdvanceRequest& request, proto::CouplingData::Builder outputs) {
  if (!ready_) throw SolverError(Code::UNEXPECTED, "advance before setup");
  if (cells_) {
    cells_->answer(request.inputs, outputs);
    cells_->time += request.dt * request.steps;
    cells_->steps += request.steps;
    return;
  }
  if (request.dt != checkedDt_) checkDt(request.dt, "advance (exchange " + std::to_string(request.exchange) + ")");
  const std::size_t hybridsBefore = hybrids_.size();
  applyInputs(request.inputs);
  // Hybrid particles arrive with the first exchange, after setup reported the step.
  if (hybrids_.size() != hybridsBefore) {
    checkDt(request.dt, "exchange " + std::to_string(request.exchange));
    energyBalanceStarted_ = false;  // new particles bring their own energy
  }
  contactSums_.assign(system_.meshes.size(), {});
  hybrids_.beginInterval(system_, request.dt * request.steps);
  zoneForceSums_.assign(zoneMembers_.empty() ? 0 : system_.particles.size(), {});
  for (std::uint32_t s = 0; s < request.steps; ++s) {
    // A drive sets its particles' velocities; holding them on that path is
    // work of the prescribed motion, counted in the step (DemSystem::advance).
    drive(request.dt);
    try {
      system_.advance(request.dt);
    } catch (const std::runtime_error& e) {  // a diverged state: a particle the neighbour grid cannot place
      throw SolverError(Code::SOLVER_FAILURE, "step " + std::to_string(system_.step + 1) + ": " + e.what());
    } catch (const std::invalid_argument& e) {  // a periodic cell deformed below twice the cut-off
      throw SolverError(Code::SOLVER_FAILURE, "step " + std::to_string(system_.step + 1) + ": " + e.what());
    }
    checkServoWalls(request.dt);
    accumulateWallContacts();
    hybrids_.accumulate(system_, request.dt);
    for (std::size_t i = 0; i < zoneForceSums_.size(); ++i) zoneForceSums_[i] += system_.particles.f[i];
    if (snapshots_ && system_.step % static_cast<std::uint64_t>(settings_.snapshotEvery) == 0) snapshots_->write(system_);
  }
  averageWallContacts(request.steps);
  try {
    hybrids_.endInterval(request.steps, system_);
  } catch (const std::runtime_error& e) {
    throw SolverError(Code::SOLVER_FAILURE, e.what());
  }
  for (Vec3& f : zoneForceSums_) f = (1.0 / request.steps) * f;
  checkFinite();
  fillOutputs(outputs);
}

void DemSolver::accumulateWallContacts() {
  for (std::size_t g = 0; g < system_.meshes.size(); ++g)
    for (const TriangleContact& k : system_.meshes[g].contacts) {
      TriangleContact& sum = contactSums_[g][{k.particle, k.triangle}];
      sum.particle = k.particle;
      sum.triangle = k.triangle;
      sum.force += k.force;
      // The contact point is averaged with the force magnitude as weight, so
      // the reported force and point carry the interval's mean moment.
      const double w = norm(k.force);
      for (std::size_t v = 0; v < 3; ++v) sum.bary[v] += w * k.bary[v];
    }
}

void DemSolver::averageWallContacts(std::uint32_t steps) {
  reported_.assign(system_.meshes.size(), {});
  for (std::size_t g = 0; g < contactSums_.size(); ++g)
    for (auto& [key, sum] : contactSums_[g]) {
      const double total = sum.bary[0] + sum.bary[1] + sum.bary[2];
      if (!(total > 0.0)) continue;
      for (double& b : sum.bary) b /= total;
      sum.force = (1.0 / steps) * sum.force;
      reported_[g].push_back(sum);
    }
}

void DemSolver::checkFinite() const {
  const Particles& p = system_.particles;
  // Called after every advance: the message is built only for a failure.
  auto causes = [this] {
    const Vec3& g = system_.gravity;
    std::ostringstream s;
    s << "dt too large, contact law unstable";
    if (norm2(g) > 0.0) s << ", or params.gravity [" << g.x << ", " << g.y << ", " << g.z << "] m/s^2 too large";
    return s.str();
  };
  // A branch-free scan first (util/finite.hpp); the search below names the particle.
  using util::nonFinite;
  bool any = false;
  for (std::size_t i = 0; i < p.size(); ++i)
    any |= nonFinite(p.x[i].x) | nonFinite(p.x[i].y) | nonFinite(p.x[i].z) | nonFinite(p.v[i].x) |
           nonFinite(p.v[i].y) | nonFinite(p.v[i].z);
  if (!any) return;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(p.x[i][d]) || !std::isfinite(p.v[i][d]))
        throw SolverError(Code::SOLVER_FAILURE, "step " + std::to_string(system_.step) + ": particle " +
                                                    std::to_string(p.id[i]) + " has a non-finite " +
                                                    (std::isfinite(p.x[i][d]) ? "velocity" : "position") + " (" +
                                                    causes() + ")");
}

/// A servo whose loop gain G dt k passes 1 overshoots its target every step
/// and rings at the step frequency (above 2 it diverges): stopped here with the
/// gain it would need, not left to chatter or to blow up later as a NaN.
void DemSolver::checkServoWalls(double dt) const {
  for (const PlaneWall& w : system_.planes) {
    const double loop = w.servoLoopGain(dt);
    if (!(loop > 1.0)) continue;
    std::ostringstream m;
    m << "step " << system_.step << ": servo wall '" << w.name << "' is unstable: params.walls gain " << w.servoGain
      << " m/(N s) x dt " << dt << " s x the stiffness of its contacts " << w.stiffness << " N/m = " << loop
      << " > 1, so it overshoots its target stress every step; use gain <= " << 0.5 / (dt * w.stiffness)
      << " (loop gain 0.5) or a smaller dt";
    throw SolverError(Code::BAD_INPUT, m.str());
  }
}

void DemSolver::selectZoneMembers() {
  const Particles& p = system_.particles;
  referencePositions_ = p.x;
  zoneMembers_.assign(settings_.zones.size(), {});
  for (std::size_t z = 0; z < settings_.zones.size(); ++z) {
    const ExportZone& zone = settings_.zones[z];
    for (std::size_t i = 0; i < p.size(); ++i) {
      bool inside = true;
      for (int d = 0; zone.boxed && d < 3; ++d) inside = inside && p.x[i][d] >= zone.lo[d] && p.x[i][d] <= zone.hi[d];
      if (inside) zoneMembers_[z].push_back(static_cast<std::uint32_t>(i));
    }
  }
}

void DemSolver::selectDriveMembers() {
  driveZones_.clear();
  Particles& p = system_.particles;
  for (const DriveSpec& d : settings_.drives) {
    std::size_t z = 0;
    while (settings_.zones[z].name != d.zone) ++z;  // the scene reader checked the name
    if (zoneMembers_[z].empty())
      throw SolverError(Code::BAD_INPUT, sceneFile_ + ": solver '" + instance_ + "': params.drives: zone '" + d.zone +
                                             "' holds no particle");
    for (std::uint32_t i : zoneMembers_[z]) {
      p.driven[i] = 1;
      p.omega[i] = {};  // the velocity comes with the first step (drive)
    }
    driveZones_.push_back(z);
  }
}

// A driven particle moves by v dt in a step (DemSystem::advance); the
// history's velocity at the step's midpoint makes that the midpoint rule,
// second order in dt like the integrator. Setting the velocity also counts
// the change of the particles' own kinetic energy (weighted, as the energies
// report it) as work, so external work and stored energy balance at every step.
void DemSolver::drive(double dt) {
  for (std::size_t k = 0; k < driveZones_.size(); ++k) {
    const Vec3 v = settings_.drives[k].history->velocity(system_.time + 0.5 * dt);
    for (std::uint32_t i : zoneMembers_[driveZones_[k]]) system_.setDrivenVelocity(i, v);
  }
}

void DemSolver::fillZones(proto::CouplingData::Builder outputs) const {
  const Particles& p = system_.particles;
  auto states = outputs.initParticles(static_cast<unsigned>(zoneMembers_.size()));
  for (std::size_t z = 0; z < zoneMembers_.size(); ++z) {
    const auto& members = zoneMembers_[z];
    auto s = states[static_cast<unsigned>(z)];
    s.setZone(settings_.zones[z].name);
    const auto n = static_cast<unsigned>(members.size());
    auto ids = wire::view(s.initIds(n));
    auto x = wire::view(s.initPositions(3 * n));
    auto v = wire::view(s.initVelocities(3 * n));
    auto u = wire::view(s.initDisplacements(3 * n));
    auto m = wire::view(s.initMasses(n));
    auto r = wire::view(s.initRadii(n));
    // The interval's mean force (impulse / interval), as for hybrid particles; after setup the current one.
    auto f = wire::view(s.initForces(3 * n));
    for (unsigned k = 0; k < n; ++k) {
      const std::uint32_t i = members[k];
      ids[k] = p.id[i];
      m[k] = p.mass[i];
      r[k] = p.radius[i];
      for (int d = 0; d < 3; ++d) {
        const auto c = 3 * k + static_cast<unsigned>(d);
        x[c] = p.x[i][d];
        v[c] = p.v[i][d];
        u[c] = p.x[i][d] - referencePositions_[i][d];
        f[c] = zoneForceSums_.size() == p.size() ? zoneForceSums_[i][d] : p.f[i][d];
      }
    }
  }
}

void DemSolver::fillOutputs(proto::CouplingData::Builder outputs) const {
  if (!zoneMembers_.empty()) fillZones(outputs);
  if (hybrids_.size() > 0) hybrids_.fill(outputs.initHybridForces(1)[0], system_);
  if (system_.meshes.empty()) return;
  auto lists = outputs.initContacts(static_cast<unsigned>(system_.meshes.size()));
  for (std::size_t g = 0; g < system_.meshes.size(); ++g) {
    const TriangleWallGroup& m = system_.meshes[g];
    // After an advance: the contacts averaged over its sub-steps; after setup: the current ones.
    const auto& contacts = g < reported_.size() ? reported_[g] : m.contacts;
    auto l = lists[static_cast<unsigned>(g)];
    l.setSurface(m.name);
    const auto n = static_cast<unsigned>(contacts.size());
    auto tri = wire::view(l.initTriangleIds(n));
    auto part = wire::view(l.initParticleIds(n));
    auto bary = wire::view(l.initBarycentric(3 * n));
    auto pts = wire::view(l.initPoints(3 * n));
    auto frc = wire::view(l.initForces(3 * n));
    for (unsigned c = 0; c < n; ++c) {
      const TriangleContact& k = contacts[c];
      tri[c] = k.triangle;
      part[c] = system_.particles.id[k.particle];
      Vec3 point;
      for (int v = 0; v < 3; ++v) {
        bary[3 * c + static_cast<unsigned>(v)] = k.bary[static_cast<std::size_t>(v)];
        point += k.bary[static_cast<std::size_t>(v)] * m.vertices[m.triangles[k.triangle][static_cast<std::size_t>(v)]];
      }
      for (int d = 0; d < 3; ++d) {
        pts[3 * c + static_cast<unsigned>(d)] = point[d];
        frc[3 * c + static_cast<unsigned>(d)] = k.force[d];
      }
    }
  }
}

void DemSolver::fields(const std::vector<std::string>& requested, proto::CouplingData::Builder out) {
  if (cells_) throw SolverError(Code::BAD_INPUT, "fields: this dem_solver holds unit cells; their results come as unitCellResults");
  std::vector<std::string> names = requested;
  if (names.empty())  // everything this state offers
    for (const auto& n : kFieldNames)
      if (system_.cell.enabled || (n != "stress" && n != "porosity")) names.push_back(n);
  for (const auto& n : names)
    if (std::find(kFieldNames.begin(), kFieldNames.end(), n) == kFieldNames.end()) {
      std::string known;
      for (const auto& k : kFieldNames) known += (known.empty() ? "" : ", ") + k;
      throw SolverError(Code::BAD_INPUT, "unknown field '" + n + "' (dem offers: " + known + ")");
    }
  const Particles& p = system_.particles;
  auto arrays = out.initArrays(static_cast<unsigned>(names.size()));
  for (unsigned k = 0; k < names.size(); ++k) {
    const std::string& n = names[k];
    std::vector<double> v;
    std::uint32_t comps = 1;
    if (n == "positions") v = flat(p.x), comps = 3;
    else if (n == "velocities") v = flat(p.v), comps = 3;
    else if (n == "angular_velocities") v = flat(p.omega), comps = 3;
    else if (n == "forces") v = flat(p.f), comps = 3;
    else if (n == "orientations") {
      comps = 4;
      for (const Quat& q : p.q) v.insert(v.end(), {q.w, q.x, q.y, q.z});
    } else if (n == "radii") v = p.radius;
    else if (n == "masses") v = p.mass;
    else if (n == "ids") v.assign(p.id.begin(), p.id.end());
    else if (n == "coordination") v = {coordinationNumber(system_)};
    else if (n == "plane_wall_forces") {
      comps = 3;
      for (const auto& w : system_.planes) v.insert(v.end(), {w.force.x, w.force.y, w.force.z});
    } else if (n == "stress" || n == "porosity") {
      // Love-Weber stress and porosity need a reference volume: the periodic cell.
      if (!system_.cell.enabled)
        throw SolverError(Code::BAD_INPUT, "field '" + n + "' needs a periodic cell (params.periodic)");
      const double volume = system_.cell.volume();
      if (n == "stress") {
        const auto sig = loveWeberStress(system_, volume);
        v.assign(sig.begin(), sig.end());
        comps = 9;
      } else {
        v = {1.0 - solidVolume(system_) / volume};
      }
    } else if (n == "unbalanced_force_index") {
      v = {unbalancedForceIndex(system_)};
    } else {  // energies
      for (const auto& [name, value] : energies()) v.push_back(value);
      comps = static_cast<std::uint32_t>(v.size());
    }
    wire::addArray(arrays, k, n, comps, v);
  }
}

wire::NamedValues DemSolver::energies() const {
  if (cells_) return {};  // unit cells run in pseudo time: their energies mean nothing physical
  const Energies e = dem::energies(system_);
  checkEnergyBalance(e);
  wire::NamedValues values{{"kinetic", e.kinetic()},           {"translational", e.translational},
                           {"rotational", e.rotational},       {"elastic", e.elastic},
                           {"potential", e.potential},         {"dissipated", e.dissipated},
                           {"external_work", e.externalWork}};
  // The share of the external work done by prescribed motion (drives, driven
  // spheres, hybrid PD particles); a coupling's forces do work on particles
  // too, Arlequin's penalty among them.
  if (!settings_.drives.empty() || system_.driveWork != 0.0) values.emplace_back("drive_work", system_.driveWork);
  return values;
}

// Velocity Verlet keeps E - E_0 = W (E: kinetic + elastic + potential +
// dissipated, W: work of walls, external forces and prescribed motion) to
// O(dt^2) while it is stable. A step above a contact's stable limit (a
// coupled run whose contacts stiffen, forces held over a long coarse step)
// makes the stored energy run away from the work before any value is
// non-finite: stop such a run with the numbers.
void DemSolver::checkEnergyBalance(const Energies& e) const {
  // Potential energy counts from its value at the start (its origin is
  // arbitrary: m g z far from z = 0 would swamp the scale), and the scale
  // holds every part's size: a settling packing turns potential energy into
  // kinetic and dissipated energy while their sum stays near zero.
  const double dynamic = e.kinetic() + e.elastic + e.dissipated;
  if (!energyBalanceStarted_) {
    // Two checks in a row: a contact's first step (trapezoidal work against
    // Hertz's rise from zero) can leave a quarter of its small energy as gap.
    energyBalance_ = util::EnergyBalance(settings_.energyTolerance,
                                         "kinetic + elastic + dissipated + potential since the start", 2);
    // The affine motion of a deforming periodic cell does work no force accounts for.
    if (system_.cell.enabled) energyBalance_.disable();
    potentialAtStart_ = e.potential;
    energyBalance_.start(dynamic, e.externalWork);
    energyBalanceStarted_ = true;
    return;
  }
  const double potential = e.potential - potentialAtStart_;
  const double magnitude = e.kinetic() + std::abs(e.elastic) + std::abs(e.dissipated) + std::abs(potential);
  const auto broken = energyBalance_.check(dynamic + potential, e.externalWork, magnitude);
  if (!broken) return;
  std::ostringstream m;
  m.precision(6);
  m << *broken << ", at t = " << system_.time << " s (step " << system_.step
    << "): the DEM integration is unstable at dt = " << checkedDt_ << " s (";
  // Every particle driven (H2's indenters and hybrids alone) leaves no step
  // bound here: say so instead of printing 0.
  if (const double crit = criticalDt(); crit > 0.0)
    m << "critical step now " << crit << " s)";
  else
    m << "no free or hybrid particle in contact bounds the step)";
  if (tookCouplingForces_)
    m << " or external forces from a coupling feed energy in (a penalty or contact stiffness too high for the "
         "exchange step)";
  if (!hybrids_.particleIndices().empty())
    m << " or the hybrid particles' motion, set by their peridynamic solver, feeds energy into their contacts "
         "(an exchange interval too long for the contact stiffness, or contact forces held over it)";
  m << "; lower dt, or set params.energy_tolerance: 0 to turn the check off";
  throw SolverError(Code::SOLVER_FAILURE, m.str());
}

std::uint64_t DemSolver::checkpoint(const std::string& path) {
  try {
    if (cells_) return cells_->checkpoint(path);
    std::ofstream out(path, std::ios::binary);
    if (!out) throw std::runtime_error(path + ": cannot open checkpoint for writing");
    writeCheckpoint(system_, out, path);
    hybrids_.save(out);  // which particles are PD's hybrids (they came with an exchange)
    out.flush();
    if (!out) throw std::runtime_error(path + ": write failed");
    return static_cast<std::uint64_t>(out.tellp());
  } catch (const std::exception& e) {
    throw SolverError(Code::SOLVER_FAILURE, e.what());
  }
}

void DemSolver::adoptCells(proto::AdoptCells::Reader request, proto::CouplingData::Builder outputs) {
  if (!cells_)
    throw SolverError(Code::UNEXPECTED, "solver '" + instance_ + "' holds no unit cells (params.unit_cells) to adopt others into");
  cells_->adopt(request, outputs);
}

void DemSolver::restore(const std::string& path) {
  try {
    cells_ = UnitCellWorker::restore(path);  // nullptr for a plain dem checkpoint
    if (cells_) {
      ready_ = true;
      return;
    }
    DemSystem restored;
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open checkpoint");
    readCheckpoint(restored, in, path);
    // The hybrid PD particles the checkpoint holds: the set PD sends again
    // drives them (adding it again would double them).
    HybridSpheres hybrids;
    hybrids.watch().requestedMargin = settings_.hybridWatchMargin;
    hybrids.load(in, path, restored.particles.size());
    if (hybrids_.size() > 0 && hybrids.size() != hybrids_.size())
      throw std::runtime_error("checkpoint holds " + std::to_string(hybrids.size()) +
                               " hybrid PD particles, this setup " + std::to_string(hybrids_.size()));
    hybrids_ = std::move(hybrids);
    system_ = std::move(restored);
    if (snapshots_) snapshots_->resumeAt(system_.step);
  } catch (const std::exception& e) {
    throw SolverError(Code::BAD_INPUT, e.what());
  }
  checkedDt_ = 0.0;
  energyBalanceStarted_ = false;
  zoneForceSums_.clear();
  ready_ = true;
}

}  // namespace cosim::dem
