// The PdSolver adapter: scene section -> PdSystem, advance requests ->
// sub-steps with held or interpolated coupling forces, hybrid particles out.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "cosim/pd/hybrid.hpp"
#include "cosim/pd/hybrid_watch.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/util/finite.hpp"
#include "cosim/pd/pd_solver.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::pd {

using cosim::proto::Error;
using cosim::wire::SolverError;

namespace {

constexpr char kMagic[8] = {'P', 'D', 'C', 'K', 'P', 'T', '1', '\0'};

template <class T>
void put(std::ofstream& out, const std::vector<T>& v) {
  const std::uint64_t n = v.size();
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}

template <class T>
void putScalar(std::ofstream& out, T v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); }

template <class T>
void get(std::ifstream& in, std::vector<T>& v, const std::string& path, const char* what) {
  std::uint64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!in || n != v.size())
    throw SolverError(Error::Code::BAD_INPUT, path + ": checkpoint " + what + " has " + std::to_string(n) +
                                                  " entries, this setup has " + std::to_string(v.size()));
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
  if (!in) throw SolverError(Error::Code::BAD_INPUT, path + ": checkpoint truncated in " + what);
}

template <class T>
T getScalar(std::ifstream& in, const std::string& path) {
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof v);
  if (!in) throw SolverError(Error::Code::BAD_INPUT, path + ": checkpoint truncated");
  return v;
}

}  // namespace

const std::vector<std::string>& PdSolver::fieldNames() {
  static const std::vector<std::string> names{"position", "displacement", "velocity", "force", "damage",
                                              "strain", "cauchy", "von_mises", "deformation_gradient"};
  return names;
}

cosim::wire::SolverInfo PdSolver::info() const {
  auto caps = cosim::wire::baseCapabilities();
  caps.push_back("hybrid-particles");
  caps.push_back("multirate-interpolation");
  caps.push_back("staggered-update");
  return {"pd", "0.1.0", caps};
}

void PdSolver::requireSetup(const char* what) const {
  if (!ready_) throw SolverError(Error::Code::UNEXPECTED, std::string(what) + " before setup");
}

void PdSolver::setup(const cosim::wire::SetupContext& ctx, cosim::proto::CouplingData::Builder outputs) {
  if (ready_) throw SolverError(Error::Code::UNEXPECTED, "setup called twice");
  const std::string file = ctx.sceneFile.empty() ? "<scene>" : ctx.sceneFile;
  try {
    const YAML::Node scene = YAML::Load(ctx.sceneYaml);
    const auto solvers = scene["solvers"];
    if (!solvers || !solvers.IsSequence())
      throw std::invalid_argument(file + ": no 'solvers' list in the scene");
    YAML::Node params;
    bool found = false;
    for (const auto& s : solvers)
      if (s["name"] && s["name"].as<std::string>() == ctx.instance) {
        found = true;
        params = s["params"];
        if (!params)
          throw std::invalid_argument(file + ":" + std::to_string(s.Mark().line + 1) + ": solver '" +
                                      ctx.instance + "' has no 'params' section");
      }
    if (!found) throw std::invalid_argument(file + ": no solver named '" + ctx.instance + "'");
    const std::string baseDir = ctx.baseDir();
    config_ = parsePdParams(params, file, baseDir);
    buildSystem(config_, system_, file);
  } catch (const YAML::Exception& e) {
    throw SolverError(Error::Code::BAD_INPUT, file + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  } catch (const std::invalid_argument& e) {
    throw SolverError(Error::Code::BAD_INPUT, e.what());
  }
  if (config_.hybrid)
    for (const auto& b : system_.bodies()) {
      const auto s = surfaceParticles(system_.particles(), b.begin, b.end, b.spacing);
      hybrid_.insert(hybrid_.end(), s.begin(), s.end());
    }
  for (const auto& b : system_.bodies()) hybridHorizon_.push_back(b.horizon);
  if (config_.outputEvery > 0) {
    std::filesystem::path p = config_.outputFile;
    if (p.is_relative() && !ctx.runDir.empty()) p = std::filesystem::path(ctx.runDir) / p;
    try {
      snapshots_ = std::make_unique<SnapshotWriter>(p, ctx.resuming);
      if (!ctx.resuming) snapshots_->write(system_);
    } catch (const std::runtime_error& e) {  // the HDF5 file cannot be created there
      throw SolverError(Error::Code::BAD_INPUT, file + ": solver '" + ctx.instance + "': params.output.file: " + e.what());
    }
  }
  ready_ = true;
  startEnergyBalance();
  writeHybrid(outputs, true, 1);  // exchange 0's message
}

void PdSolver::startEnergyBalance() {
  // Two checks in a row, as dem_solver: a contact starting inside a step
  // leaves a gap of the order of its own first energy, (dt F)^2 / 8m of
  // Verlet's half kick (H5's coarse pack: 6e-9 J gap on 7e-9 J at its
  // first wall contact, 0.4 % one check later).
  energyBalance_ = util::EnergyBalance(config_.energyTolerance, "kinetic + strain", 2);
  // Runs whose balance does not close by design: relaxation damps the motion,
  // breaking bonds releases energy, a prescribed velocity's reaction does work
  // that is not counted.
  if (config_.quasiStatic) energyBalance_.disable();
  for (const auto& b : system_.bodies())
    if (b.spec.options.criticalStretch > 0.0) energyBalance_.disable();
  for (const auto& bc : config_.boundaries)
    if (bc.type == Constraint::Velocity && (bc.velocity[0] != 0.0 || bc.velocity[1] != 0.0 || bc.velocity[2] != 0.0))
      energyBalance_.disable();
  const auto e = system_.energies();
  energyBalance_.start(e.kinetic + e.strain, e.externalWork);
}

void PdSolver::readHybridForces(cosim::proto::CouplingData::Reader data, std::vector<double>& into,
                                std::vector<PdSystem::LinearisedCoupling>* linearised) const {
  into.assign(3 * system_.particles().size(), 0.0);
  if (linearised) linearised->clear();
  if (!data.hasHybridForces()) return;
  for (const auto hf : data.getHybridForces()) {
    const auto ids = cosim::wire::view(hf.getIds());
    const auto f = cosim::wire::view(hf.getForces());
    if (f.size() != 3 * ids.size())
      throw SolverError(Error::Code::BAD_INPUT, "hybridForces: " + std::to_string(ids.size()) + " ids but " +
                                                    std::to_string(f.size()) + " force values (need 3 per id)");
    const auto x = cosim::wire::view(hf.getPositions());
    const auto k = cosim::wire::view(hf.getStiffness());
    const bool follow = !k.empty();
    if (follow && (x.size() != 3 * ids.size() || k.size() != 6 * ids.size()))
      throw SolverError(Error::Code::BAD_INPUT, "hybridForces: " + std::to_string(ids.size()) + " ids but " +
                                                    std::to_string(x.size()) + " positions and " +
                                                    std::to_string(k.size()) +
                                                    " stiffness values (need 3 and 6 per id)");
    for (std::size_t q = 0; q < ids.size(); ++q) {
      if (ids[q] >= system_.particles().size())
        throw SolverError(Error::Code::BAD_INPUT, "hybridForces: unknown particle id " + std::to_string(ids[q]));
      for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(f[3 * q + a]))
          throw SolverError(Error::Code::BAD_INPUT, "hybridForces: non-finite force on particle " +
                                                        std::to_string(ids[q]));
        into[3 * ids[q] + a] += f[3 * q + a];
      }
      if (!follow || !linearised) continue;
      PdSystem::LinearisedCoupling c;
      c.particle = ids[q];
      bool finite = true;
      for (int a = 0; a < 3; ++a) finite = finite && std::isfinite(c.position[a] = x[3 * q + a]);
      for (int a = 0; a < 6; ++a) finite = finite && std::isfinite(c.stiffness[a] = k[6 * q + a]);
      if (!finite)
        throw SolverError(Error::Code::BAD_INPUT, "hybridForces: non-finite position or stiffness of particle " +
                                                      std::to_string(ids[q]));
      // Only loaded particles: a zero force has no contact to follow.
      if (f[3 * q] != 0.0 || f[3 * q + 1] != 0.0 || f[3 * q + 2] != 0.0) linearised->push_back(c);
    }
  }
}

void PdSolver::advance(const cosim::wire::AdvanceRequest& req, cosim::proto::CouplingData::Builder outputs) {
  requireSetup("advance");
  const bool interpolate = config_.interpolate && req.inputsEnd.has_value();
  // The step worked ahead is this request's only where it is the same step
  // with the same coupling; otherwise the state goes back to where it was.
  const bool ahead = system_.lookAheadStep() > 0.0 && endOfStepCoupling(req.steps, interpolate) &&
                     req.dt == system_.lookAheadStep();
  if (!ahead) system_.cancelLookAhead();
  mayWorkAhead_ = false;
  lastDt_ = req.dt;
  const double crit = system_.criticalTimeStep();
  if (req.dt > crit * (1.0 + 1e-12) && !config_.force)
    throw SolverError(Error::Code::BAD_INPUT, "advance: dt = " + std::to_string(req.dt) +
                                                  " s exceeds the PD critical step " + std::to_string(crit) +
                                                  " s (" + criticalStepRule() +
                                                  ", docs/pd.md); set 'force: true' to override");
  // Without interpolation the forces go straight into the system's coupling
  // force (one pass, no copy: this is on the exchange's critical path).
  auto& coupling = system_.couplingForce();
  std::vector<double>& f0 = interpolate ? forcesStart_ : coupling;
  std::vector<double>& f1 = forcesEnd_;
  // Forces sent with their stiffness follow their particles over the sub-steps
  // (pd-dem-contact `forces: linearised`); interpolation takes precedence.
  readHybridForces(req.inputs, f0, &system_.linearisedCoupling());
  receiveWatch(req.inputs);
  if (req.inputsEnd.has_value()) receiveWatch(*req.inputsEnd);
  if (interpolate) {
    system_.linearisedCoupling().clear();
    readHybridForces(*req.inputsEnd, f1, nullptr);
    coupling = f0;
  }
  const std::uint32_t n = req.steps;
  // One Verlet step per request with the force held: DEM evaluated it where
  // this step's drift ends (the hybrids' drift velocity, writeHybrid), so it
  // is monolithic Verlet's end-of-step force and enters after the drift; the
  // first half kick keeps the force of the state. Otherwise the forces
  // received act from the first half kick on (held over sub-steps, Alg. 2).
  if (!endOfStepCoupling(n, interpolate)) system_.updateExternalForces();
  if (config_.quasiStatic) {
    // Quasi-static loading: the end-of-request loads, relaxed to equilibrium.
    if (interpolate) coupling = f1;
    const auto used = system_.relax(config_.relaxTolerance, config_.relaxMaxIterations);
    if (used >= config_.relaxMaxIterations)
      throw SolverError(Error::Code::SOLVER_FAILURE,
                        "quasi_static: dynamic relaxation did not reach tolerance " +
                            std::to_string(config_.relaxTolerance) + " in " + std::to_string(used) + " iterations");
    system_.setTime(system_.time() + n * req.dt, system_.stepCount() + n);
  }
  for (std::uint32_t k = 0; k < n && !config_.quasiStatic; ++k) {
    if (config_.staggered) {
      // The coupling kick of sub-step k uses the value at its start.
      if (interpolate)
        for (std::size_t q = 0; q < coupling.size(); ++q)
          coupling[q] = f0[q] + (f1[q] - f0[q]) * static_cast<double>(k) / n;
      system_.stepStaggered(req.dt);
    } else {
      // Velocity Verlet evaluates forces at the end of the sub-step.
      if (interpolate)
        for (std::size_t q = 0; q < coupling.size(); ++q)
          coupling[q] = f0[q] + (f1[q] - f0[q]) * static_cast<double>(k + 1) / n;
      if (ahead) system_.completeLookAhead();
      else system_.step(req.dt);
    }
  }
  checkFinite();
  mayWorkAhead_ = config_.workAhead && endOfStepCoupling(n, interpolate);
  ++advances_;
  if (snapshots_ && advances_ % config_.outputEvery == 0) snapshots_->write(system_);
  // The exchange names the message: the same after a restore.
  writeHybrid(outputs, false, req.exchange + 1);
}

bool PdSolver::workAhead() {
  return ready_ && mayWorkAhead_ && system_.lookAhead(lastDt_);
}

void PdSolver::checkFinite() const {
  const auto& p = system_.particles();
  // A branch-free scan first (util/finite.hpp); the search below names the particle.
  bool any = false;
  for (std::size_t q = 0; q < p.displacement.size(); ++q)
    any |= util::nonFinite(p.displacement[q]) | util::nonFinite(p.velocity[q]);
  if (!any) return;
  for (std::size_t q = 0; q < p.displacement.size(); ++q)
    if (!std::isfinite(p.displacement[q]) || !std::isfinite(p.velocity[q]))
      throw SolverError(Error::Code::SOLVER_FAILURE,
                        "non-finite displacement or velocity of particle " + std::to_string(q / 3) + " (body '" +
                            system_.bodies()[p.body[q / 3]].spec.name + "') at step " +
                            std::to_string(system_.stepCount()));
}

bool PdSolver::endOfStepCoupling(std::uint32_t steps, bool interpolate) const {
  return steps == 1 && !interpolate && !config_.staggered && !config_.quasiStatic;
}

void PdSolver::writeHybrid(cosim::proto::CouplingData::Builder out, bool withSet, std::uint64_t serial) {
  if (!config_.hybrid) return;
  const auto& p = system_.particles();
  const auto n = static_cast<unsigned>(hybrid_.size());
  // Verlet's next drift moves a particle by dt v_{n+1/2}, v_{n+1/2} = v_n +
  // dt/2 a_n with the forces of the state (Hartmann Eq. 44): sent as the
  // velocity, DEM's drift of the driven sphere ends where PD's will, and the
  // force it returns is the one at PD's next positions (pddem.capnp).
  const bool drift = !config_.staggered && !config_.quasiStatic && lastDt_ > 0.0;
  hybridX_.resize(3 * n);
  hybridV_.resize(3 * n);
  for (unsigned q = 0; q < n; ++q) {
    const std::size_t i = hybrid_[q];
    for (int a = 0; a < 3; ++a) {
      const std::size_t k = 3 * i + static_cast<std::size_t>(a);
      hybridX_[3 * q + a] = p.reference[k] + p.displacement[k];
      hybridV_[3 * q + a] = p.velocity[k];
    }
    if (drift) system_.driftVelocity(lastDt_, i, &hybridV_[3 * q]);
  }
  // The hybrid watch (hybrid_watch.hpp): the states DEM watches alone, where it may.
  const std::vector<std::uint32_t>* part = serial > 0 && !withSet ? watch_.select(hybridX_, hybridV_) : nullptr;
  auto h = out.initHybridParticles(1)[0];
  if (serial > 0) {
    h.setSerial(serial);
    watch_.sent(part == nullptr, hybridX_, serial);
  }
  if (part) {
    h.setPartial(true);
    h.setWatchBasis(watch_.basis());
    const auto m = static_cast<unsigned>(part->size());
    auto idx = cosim::wire::view(h.initIndices(m));
    auto pos = cosim::wire::view(h.initPositions(3 * m));
    auto vel = cosim::wire::view(h.initVelocities(3 * m));
    for (unsigned r = 0; r < m; ++r) {
      const std::uint32_t q = (*part)[r];
      idx[r] = q;
      std::copy_n(hybridX_.begin() + 3 * q, 3, pos.begin() + 3 * r);
      std::copy_n(hybridV_.begin() + 3 * q, 3, vel.begin() + 3 * r);
    }
    return;
  }
  auto pos = cosim::wire::view(h.initPositions(3 * n));
  auto vel = cosim::wire::view(h.initVelocities(3 * n));
  std::copy(hybridX_.begin(), hybridX_.end(), pos.begin());
  std::copy(hybridV_.begin(), hybridV_.end(), vel.begin());
  if (!withSet) return;
  auto ids = cosim::wire::view(h.initIds(n));
  auto bodies = cosim::wire::view(h.initBodyIds(n));
  auto ref = cosim::wire::view(h.initReferencePositions(3 * n));
  auto rad = cosim::wire::view(h.initRadii(n));
  for (unsigned q = 0; q < n; ++q) {
    const std::size_t i = hybrid_[q];
    ids[q] = static_cast<std::uint32_t>(i);
    bodies[q] = p.body[i];
    rad[q] = quasiRadius(p.volume[i]);  // Hartmann Eq. 39
    for (int a = 0; a < 3; ++a) ref[3 * q + a] = p.reference[3 * i + a];
  }
  auto hz = cosim::wire::view(h.initHorizons(static_cast<unsigned>(hybridHorizon_.size())));
  std::copy(hybridHorizon_.begin(), hybridHorizon_.end(), hz.begin());
}

void PdSolver::receiveWatch(cosim::proto::CouplingData::Reader data) {
  if (!data.hasHybridForces()) return;
  for (const auto hf : data.getHybridForces())
    if (const std::string bad = watch_.receive(hf, hybrid_.size()); !bad.empty())
      throw SolverError(Error::Code::BAD_INPUT, "hybridForces: " + bad);
}

void PdSolver::fields(const std::vector<std::string>& names, cosim::proto::CouplingData::Builder out) {
  requireSetup("fields");
  system_.cancelLookAhead();
  std::vector<std::string> want = names.empty() ? fieldNames() : names;
  for (const auto& n : want) {
    bool known = false;
    for (const auto& f : fieldNames()) known = known || f == n;
    if (!known && n != "hybrid")
      throw SolverError(Error::Code::BAD_INPUT, "fields: unknown field '" + n + "'");
  }
  const auto& p = system_.particles();
  CorrespondenceFields corr;
  bool needCorr = false;
  for (const auto& n : want)
    needCorr = needCorr || n == "strain" || n == "cauchy" || n == "von_mises" || n == "deformation_gradient";
  if (needCorr) corr = system_.correspondenceFields();
  unsigned count = 0;
  for (const auto& n : want) count += n == "hybrid" ? 0u : 1u;
  auto arrays = out.initArrays(count);
  unsigned k = 0;
  for (const auto& n : want) {
    if (n == "hybrid") { writeHybrid(out, true, 0); continue; }
    if (n == "position") {
      std::vector<double> x(p.reference.size());
      for (std::size_t q = 0; q < x.size(); ++q) x[q] = p.reference[q] + p.displacement[q];
      cosim::wire::addArray(arrays, k++, n, 3, x);
    } else if (n == "displacement") {
      cosim::wire::addArray(arrays, k++, n, 3, p.displacement);
    } else if (n == "velocity") {
      cosim::wire::addArray(arrays, k++, n, 3, p.velocity);
    } else if (n == "force") {
      std::vector<double> f(p.internalForce.size());
      for (std::size_t q = 0; q < f.size(); ++q) f[q] = p.internalForce[q] + p.externalForce[q];
      cosim::wire::addArray(arrays, k++, n, 3, f);
    } else if (n == "damage") {
      cosim::wire::addArray(arrays, k++, n, 1, system_.damageField());
    } else if (n == "strain") {
      cosim::wire::addArray(arrays, k++, n, 6, corr.greenLagrange);
    } else if (n == "cauchy") {
      cosim::wire::addArray(arrays, k++, n, 6, corr.cauchy);
    } else if (n == "von_mises") {
      cosim::wire::addArray(arrays, k++, n, 1, corr.vonMises);
    } else if (n == "deformation_gradient") {
      cosim::wire::addArray(arrays, k++, n, 9, corr.deformationGradient);
    }
  }
}

std::uint64_t PdSolver::checkpoint(const std::string& path) {
  requireSetup("checkpoint");
  system_.cancelLookAhead();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw SolverError(Error::Code::SOLVER_FAILURE, path + ": cannot write checkpoint");
  out.write(kMagic, sizeof kMagic);
  auto& p = system_.particles();
  putScalar(out, system_.time());
  putScalar(out, system_.stepCount());
  putScalar(out, system_.externalWork());
  putScalar(out, advances_);
  put(out, p.displacement);
  put(out, p.velocity);
  put(out, p.internalForce);
  put(out, p.externalForce);
  put(out, system_.previousExternalForce());
  put(out, system_.couplingForce());
  for (const auto& b : system_.bodies()) put(out, b.bonds.broken);
  cosim::util::BinaryWriter w(out);
  watch_.save(w);  // the hybrid watch: a restored run sends what the original did
  out.flush();
  if (!out) throw SolverError(Error::Code::SOLVER_FAILURE, path + ": checkpoint write failed");
  return static_cast<std::uint64_t>(out.tellp());
}

void PdSolver::restore(const std::string& path) {
  requireSetup("restore");
  system_.cancelLookAhead();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SolverError(Error::Code::BAD_INPUT, path + ": cannot open checkpoint");
  char magic[8] = {};
  in.read(magic, sizeof magic);
  if (!in || std::memcmp(magic, kMagic, sizeof kMagic) != 0)
    throw SolverError(Error::Code::BAD_INPUT, path + ": not a pd_solver checkpoint");
  // Read into copies first, so a bad file leaves the state untouched.
  const auto t = getScalar<double>(in, path);
  const auto s = getScalar<std::uint64_t>(in, path);
  const auto w = getScalar<double>(in, path);
  const auto adv = getScalar<std::uint64_t>(in, path);
  auto& p = system_.particles();
  auto u = p.displacement, v = p.velocity, fi = p.internalForce, fe = p.externalForce;
  auto prev = system_.previousExternalForce(), cf = system_.couplingForce();
  get(in, u, path, "displacement");
  get(in, v, path, "velocity");
  get(in, fi, path, "internal force");
  get(in, fe, path, "external force");
  get(in, prev, path, "previous external force");
  get(in, cf, path, "coupling force");
  std::vector<std::vector<std::uint8_t>> broken;
  for (const auto& b : system_.bodies()) {
    broken.push_back(b.bonds.broken);
    get(in, broken.back(), path, "bond flags");
  }
  HybridWatch watch;
  if (in.peek() != std::ifstream::traits_type::eof()) {
    cosim::util::BinaryReader r(in, path);
    try {
      watch.load(r, hybrid_.size());
    } catch (const std::runtime_error& e) {
      throw SolverError(Error::Code::BAD_INPUT, e.what());
    }
  }
  watch_ = std::move(watch);
  p.displacement = std::move(u);
  p.velocity = std::move(v);
  p.internalForce = std::move(fi);
  p.externalForce = std::move(fe);
  system_.previousExternalForce() = std::move(prev);
  system_.couplingForce() = std::move(cf);
  for (std::size_t b = 0; b < broken.size(); ++b) system_.bodies()[b].bonds.broken = std::move(broken[b]);
  system_.setTime(t, s);
  system_.externalWork() = w;
  advances_ = adv;
  if (snapshots_) snapshots_->resumeAt(s);
  startEnergyBalance();
}

std::string PdSolver::criticalStepRule() const {
  if (!system_.criticalStepsMeasured()) return "0.45 delta / c_p";
  std::ostringstream s;
  s << kMeasuredStepSafety << " x 2 / omega_max, measured at setup";
  return s.str();
}

double PdSolver::time() const { return system_.time(); }
std::uint64_t PdSolver::step() const { return system_.stepCount(); }
double PdSolver::criticalDt() const { return ready_ ? system_.criticalTimeStep() : 0.0; }

cosim::wire::NamedValues PdSolver::energies() const {
  if (!ready_) return {};
  if (system_.lookAheadStep() > 0.0)
    throw SolverError(Error::Code::INTERNAL,
                      "energies asked for while the next step is worked ahead (the host asks with the advance)");
  const auto e = system_.energies();
  if (const auto broken = energyBalance_.check(e.kinetic + e.strain, e.externalWork)) {
    std::ostringstream m;
    m.precision(6);
    m << *broken << ", at t = " << system_.time() << " s (step " << system_.stepCount()
      << "): the PD integration is unstable at dt = " << lastDt_ << " s (critical step " << criticalStepRule()
      << " = " << system_.criticalTimeStep()
      << " s); lower dt, or set params.energy_tolerance: 0 to turn the check off";
    throw SolverError(Error::Code::SOLVER_FAILURE, m.str());
  }
  return {{"kinetic", e.kinetic}, {"strain", e.strain}, {"external_work", e.externalWork}};
}

std::size_t PdSolver::outputWordsHint() const {
  // Hybrid particles (11 words each) or full fields (~40 words per particle).
  return 1024 + 48 * system_.particles().size();
}

}  // namespace cosim::pd
