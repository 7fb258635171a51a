#include "cosim/dem/cell/unit_cell.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <span>
#include <sstream>
#include <stdexcept>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/io/snapshot_writer.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/packing/packing.hpp"
#include "cosim/io/h5_file.hpp"

namespace cosim::dem {
namespace {

std::string num(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::runtime_error("unit-cell preparation: " + what);
}

void checkPreparation(const CellPreparation& p) {
  require(p.count >= 2, "count must be at least 2");
  require(p.dMin > 0.0 && p.dMax >= p.dMin, "diameters need 0 < d_min <= d_max");
  require(p.shearModulus > 0.0 && p.density > 0.0, "shear modulus and density must be positive");
  require(p.poisson >= 0.0 && p.poisson < 0.5, "Poisson's ratio must lie in [0, 0.5)");
  require(p.friction >= 0.0, "friction must not be negative");
  require(p.contactDamping >= 0.0 && p.contactDamping < 1.0, "contact damping ratio must lie in [0, 1)");
  require(p.pressure > 0.0, "target pressure must be positive");
  require(p.pressureTolerance > 0.0 && p.unbalancedTolerance > 0.0, "tolerances must be positive");
  require(p.initialSolidFraction > 0.0 && p.initialSolidFraction <= 0.4, "initial solid fraction must lie in (0, 0.4]");
  require(p.massDampingDt >= 0.0 && p.massDampingDt < 1.0, "mass damping * dt must lie in [0, 1)");
  require(p.dtFactor > 0.0 && p.dtFactor <= 1.0, "dt factor must lie in (0, 1]");
  require(p.maxStrainPerStep > 0.0 && p.maxSteps > 0, "strain rate limit and step budget must be positive");
  require(!p.progress || p.progressEvery > 0, "the progress interval must be positive");
}

/// Restitution of a linear dashpot with damping ratio zeta:
/// e = exp(-pi zeta / sqrt(1 - zeta^2)). Liu's Table I gives the contact
/// viscosity as 0.12 without a definition; we read it as this damping ratio.
double restitutionOfDampingRatio(double zeta) {
  return std::exp(-std::numbers::pi * zeta / std::sqrt(1.0 - zeta * zeta));
}

// Voigt order of the six stress components the servo controls.
constexpr std::array<std::array<int, 2>, 6> kVoigt{{{0, 0}, {1, 1}, {2, 2}, {1, 2}, {0, 2}, {0, 1}}};

/// Affine (upper-bound) stiffness of each stress component against its own
/// strain: C_abab = 1/V sum_c k_n l^2 n_a^2 n_b^2, with the Hertz tangent
/// stiffness k_n = 2 E* sqrt(R* delta). Used only to scale the servo's steps.
std::array<double, 6> affineStiffness(const DemSystem& s) {
  const Particles& p = s.particles;
  const auto& nl = s.neighbors;
  std::array<double, 6> c{};
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) {
      if (!nl.touching[k]) continue;
      const std::uint32_t j = nl.partner[k];
      const Vec3 d = s.pairVector(i, k);
      const double l = norm(d), rsum = p.radius[i] + p.radius[j];
      const double overlap = rsum - l;
      if (overlap <= 0.0) continue;
      const double kn = 2.0 * s.materials.pair(p.material[i], p.material[j]).eEff *
                        std::sqrt(p.radius[i] * p.radius[j] / rsum * overlap);
      for (std::size_t v = 0; v < 6; ++v) {
        const double na = d[kVoigt[v][0]] / l, nb = d[kVoigt[v][1]] / l;
        c[v] += kn * l * l * na * na * nb * nb;
      }
    }
  for (double& v : c) v /= s.cell.volume();
  return c;
}

/// Errors of the six stress components relative to the isotropic target
/// sigma = -p I: (p + sigma_aa) / p on the diagonal, sigma_ab / p off it.
std::array<double, 6> stressErrors(const DemSystem& s, double pressure) {
  const auto sig = loveWeberStress(s, s.cell.volume());
  std::array<double, 6> e{};
  for (std::size_t v = 0; v < 6; ++v) {
    const auto a = static_cast<std::size_t>(kVoigt[v][0]), b = static_cast<std::size_t>(kVoigt[v][1]);
    e[v] = (0.5 * (sig[3 * a + b] + sig[3 * b + a]) + (a == b ? pressure : 0.0)) / pressure;
  }
  return e;
}

bool within(const std::array<double, 6>& e, double tol) {
  return std::all_of(e.begin(), e.end(), [tol](double v) { return std::fabs(v) < tol; });
}

void setFriction(DemSystem& s, bool on) {
  if (on) {
    s.contactLaw().prepare(s.materials);  // pair table from the materials again
    return;
  }
  for (PairMaterial& pm : s.materials.pairs()) pm.friction = 0.0;
}

}  // namespace

CellMeasures measureCell(const DemSystem& cell) {
  CellMeasures m;
  const double volume = cell.cell.volume();
  m.stress = loveWeberStress(cell, volume);  // Liu Eq. 44b (with the kinetic part)
  m.pressure = -(m.stress[0] + m.stress[4] + m.stress[8]) / 3.0;
  m.porosity = 1.0 - solidVolume(cell) / volume;
  m.coordination = coordinationNumber(cell);
  m.unbalancedForceIndex = unbalancedForceIndex(cell);
  return m;
}

namespace {

/// Calls prep.progress about every prep.progressEvery steps of one servo phase.
class ProgressReport {
 public:
  explicit ProgressReport(const CellPreparation& prep) : prep_(prep), next_(prep.progressEvery) {}
  void at(const DemSystem& s, long steps) {
    if (!prep_.progress || steps < next_) return;
    const CellMeasures m = measureCell(s);
    prep_.progress(steps, m.pressure, m.unbalancedForceIndex);
    while (next_ <= steps) next_ += prep_.progressEvery;
  }

 private:
  const CellPreparation& prep_;
  long next_;
};

}  // namespace

// In slices: a packing at the edge of jamming can lose its pressure at fixed
// volume (a 4096-sphere frictionless cell fell to 0.7 % of the target while
// I_uf hovered at 0.013), and the relaxation then spent the whole budget on
// an unloaded cell. The band is ten times the servo's tolerance, so ordinary
// fluctuations while settling do not cut it short, and a relaxation that
// converges takes exactly the steps one call would.
long relaxWhileLoaded(DemSystem& s, double dt, const CellPreparation& prep, long budget,
                      const std::function<void(long)>& afterSlice) {
  constexpr long kSlice = 5000;  // a multiple of relax's check interval, so its checks fall where one call's would
  long steps = 0;
  while (steps < budget) {
    steps += relax(s, dt, prep.unbalancedTolerance, std::min(kSlice, budget - steps));
    if (afterSlice) afterSlice(steps);
    const double index = unbalancedForceIndex(s);
    if (index > 0.0 && index < prep.unbalancedTolerance) break;
    if (!within(stressErrors(s, prep.pressure), 10.0 * prep.pressureTolerance)) break;
  }
  return steps;
}

long servoToPressure(DemSystem& s, double dt, const CellPreparation& prep) {
  // The servo adjusts each diagonal entry of the velocity gradient L in
  // proportion to its stress error; dividing by the affine stiffness makes the
  // gain dimensionless (fraction of the error removed per chunk), and a small
  // fraction keeps the correction slower than a stress wave crosses the cell.
  constexpr long kChunk = 10;
  constexpr double kFraction = 0.05;
  long steps = 0;
  ProgressReport report(prep);
  while (steps < prep.maxSteps) {
    report.at(s, steps);
    const auto err = stressErrors(s, prep.pressure);
    if (within(err, prep.pressureTolerance)) {
      s.cell.velocityGradient = {};
      // A long relaxation reports too.
      steps += relaxWhileLoaded(s, dt, prep, prep.maxSteps - steps, [&](long relaxed) { report.at(s, steps + relaxed); });
      if (within(stressErrors(s, prep.pressure), prep.pressureTolerance) &&
          unbalancedForceIndex(s) < prep.unbalancedTolerance && coordinationNumber(s) > 0.0)
        return steps;
      continue;
    }
    const auto stiff = affineStiffness(s);
    Mat3 l{};
    const double limit = prep.maxStrainPerStep * kChunk;
    for (std::size_t v = 0; v < 6; ++v) {
      // Strain of this chunk that removes kFraction of the error if the response
      // were affine: d sigma_aa = C d eps_aa, d sigma_ab = 2 C d eps_ab (eps symmetric).
      const auto a = static_cast<std::size_t>(kVoigt[v][0]), b = static_cast<std::size_t>(kVoigt[v][1]);
      const double c = a == b ? stiff[v] : 2.0 * stiff[v];
      const double strain = std::clamp(c > 0.0 ? -kFraction * err[v] * prep.pressure / c : (a == b ? -limit : 0.0),
                                       -limit, limit);
      l[3 * a + b] = l[3 * b + a] = strain / (kChunk * dt);
    }
    s.cell.velocityGradient = l;
    for (long k = 0; k < kChunk; ++k) s.advance(dt);
    steps += kChunk;
  }
  s.cell.velocityGradient = {};
  const auto err = stressErrors(s, prep.pressure);
  std::string errors;
  for (double e : err) errors += (errors.empty() ? "" : ", ") + num(e);
  throw std::runtime_error("unit-cell preparation: servo did not reach " + num(prep.pressure) + " Pa within " +
                           std::to_string(prep.maxSteps) + " steps (relative stress errors " + errors + "; I_uf " +
                           num(unbalancedForceIndex(s)) + ")");
}

DemSystem prepareUnitCell(const CellPreparation& prep, PreparationLog* log) {
  checkPreparation(prep);
  const double rmin = 0.5 * prep.dMin, rmax = 0.5 * prep.dMax;
  // Mean r^3 of radii uniform in [rmin, rmax]: (rmax^4 - rmin^4) / (4 (rmax - rmin)).
  const double meanR3 = rmax > rmin ? (std::pow(rmax, 4) - std::pow(rmin, 4)) / (4.0 * (rmax - rmin)) : rmin * rmin * rmin;
  const double solid = static_cast<double>(prep.count) * 4.0 / 3.0 * std::numbers::pi * meanR3;
  const double side = std::cbrt(solid / prep.initialSolidFraction);
  const SphereSet set = randomPacking({0, 0, 0}, {side, side, side}, rmin, rmax, prep.count, prep.seed);
  require(set.radii.size() == prep.count, "random sequential addition placed only " + std::to_string(set.radii.size()) +
                                              " of " + std::to_string(prep.count) + " spheres; lower the initial solid fraction");
  DemSystem s;
  s.gravity = {};
  s.setContactLaw("hertz", "mindlin", "restitution");
  Material m;
  m.name = "grain";
  m.density = prep.density;
  m.poisson = prep.poisson;
  m.young = 2.0 * prep.shearModulus * (1.0 + prep.poisson);  // E = 2 G (1 + nu)
  m.restitution = restitutionOfDampingRatio(prep.contactDamping);
  m.friction = prep.friction;
  s.materials.add(m);
  s.particles.reserve(prep.count);
  for (std::size_t i = 0; i < set.radii.size(); ++i) s.particles.add(set.centres[i], set.radii[i], prep.density);
  s.cell.enabled = true;
  s.cell.h = {side, 0, 0, 0, side, 0, 0, 0, side};
  s.neighbors.skin = kDefaultSkinPerRadius * rmin;
  s.initialize();
  const double dt = prep.dtFactor * criticalTimeStep(s);
  s.massDamping = prep.massDampingDt / dt;  // c of -c m v (Liu Sec. 2.3.2, c_I)
  PreparationLog local;
  local.dt = dt;
  // Friction off during compression gives a denser packing (mu = 0 lets
  // grains slide into the voids); mu is switched on at the target pressure and
  // the servo restores the pressure with friction active.
  if (prep.frictionlessCompression) setFriction(s, false);
  local.compressionSteps = servoToPressure(s, dt, prep);
  const CellMeasures loose = measureCell(s);
  local.frictionlessPorosity = loose.porosity;
  local.frictionlessCoordination = loose.coordination;
  if (prep.frictionlessCompression) {
    setFriction(s, true);
    CellPreparation rest = prep;
    rest.maxSteps = prep.maxSteps - local.compressionSteps;
    local.frictionSteps = servoToPressure(s, dt, rest);
  }
  if (log) *log = local;
  return s;
}

DemSystem cloneCell(const DemSystem& cell) {
  std::stringstream buffer;
  writeCheckpoint(cell, buffer, "<copy>");
  DemSystem copy;
  readCheckpoint(copy, buffer, "<copy>");
  return copy;
}

DemSystem weakenedCell(const DemSystem& cell, std::size_t count, std::uint64_t seed, double dt, double tolerance,
                       long maxSteps) {
  const Particles& p = cell.particles;
  if (count >= p.size())
    throw std::runtime_error("weakened cell: cannot remove " + std::to_string(count) + " of " +
                             std::to_string(p.size()) + " spheres");
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::mt19937_64 rng(seed);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<std::uint8_t> removed(p.size(), 0);
  for (std::size_t k = 0; k < count; ++k) removed[order[k]] = 1;
  DemSystem w;
  w.gravity = {};
  const auto& names = cell.contactLawNames();
  w.setContactLaw(names[0], names[1], names[2]);
  w.setIntegrator(cell.integratorName());
  for (const Material& m : cell.materials.all()) w.materials.add(m);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!removed[i]) {
      const std::size_t k = w.particles.add(p.x[i], p.radius[i], cell.materials[p.material[i]].density, p.material[i]);
      w.particles.v[k] = p.v[i];
    }
  w.cell = cell.cell;
  w.cell.velocityGradient = {};
  w.neighbors.skin = cell.neighbors.skin;
  w.massDamping = cell.massDamping;
  w.initialize();
  const long steps = relax(w, dt, tolerance, maxSteps);
  if (steps >= maxSteps)
    throw std::runtime_error("weakened cell: I_uf = " + num(unbalancedForceIndex(w)) + " after " +
                             std::to_string(steps) + " relaxation steps (tolerance " + num(tolerance) + ")");
  return w;
}

void saveUnitCell(const DemSystem& cell, const std::string& base, double dt) {
  writeCheckpoint(cell, base + ".ckpt");
  {
    SnapshotWriter snapshot(base + ".h5");
    snapshot.write(cell);
  }
  io::H5File file = io::H5File::openForAppend(base + ".h5");
  const CellMeasures m = measureCell(cell);
  file.group("/cell");
  file.writeArray("/cell/h", std::span<const double>(cell.cell.h.data(), 9), 3);  // cell vectors as columns
  file.writeArray("/cell/stress", std::span<const double>(m.stress.data(), 9), 3);
  file.setAttribute("/cell", "pressure", m.pressure);
  file.setAttribute("/cell", "porosity", m.porosity);
  file.setAttribute("/cell", "coordination", m.coordination);
  file.setAttribute("/cell", "unbalanced_force_index", m.unbalancedForceIndex);
  file.setAttribute("/cell", "dt", dt);
  file.setAttribute("/cell", "mass_damping", cell.massDamping);
  file.setAttribute("/cell", "checkpoint", base + ".ckpt");
}

std::string JobOutcome::problem() const {
  std::string why;
  if (!relaxed)
    why = "I_uf = " + num(measures.unbalancedForceIndex) + " above the tolerance " + num(tolerance) + " after " +
          std::to_string(steps) + " steps (relaxation budget " + std::to_string(budget) +
          (endedStressFree ? "; ended early, stress-free: |mean stress| below " + num(stressFreePressure) + " Pa" : "") +
          ")";
  if (measures.coordination < minCoordination)
    why += std::string(why.empty() ? "" : "; ") + "coordination number " + num(measures.coordination) +
           " below the minimum " + num(minCoordination);
  if (why.empty()) return why;
  return why + " (porosity " + num(measures.porosity) + ", Z " + num(measures.coordination) + ", mean stress " +
         num(-measures.pressure) + " Pa)";
}

namespace {

/// The job's relaxation (Liu Sec. 2.3.2): as relax(), with the stress-free
/// exit checked once, after stressFreeAfter steps rounded up to a whole
/// number of I_uf checks, so a job the exit does not end takes bitwise the
/// steps it takes without it. Returns the steps taken.
long relaxJob(DemSystem& cell, const RelaxSettings& set, bool& endedStressFree) {
  endedStressFree = false;
  const long every = std::max(1L, set.checkEvery);
  const long probe = (set.stressFreeAfter + every - 1) / every * every;
  if (!(set.stressFreePressure > 0.0) || probe >= set.maxSteps)
    return relax(cell, set.dt, set.tolerance, set.maxSteps, set.checkEvery);
  long steps = relax(cell, set.dt, set.tolerance, probe, set.checkEvery);
  const double index = unbalancedForceIndex(cell);
  if (index > 0.0 && index < set.tolerance) return steps;
  if (std::abs(measureCell(cell).pressure) < set.stressFreePressure) {
    endedStressFree = true;
    return steps;
  }
  return steps + relax(cell, set.dt, set.tolerance, set.maxSteps - steps, set.checkEvery);
}

}  // namespace

JobOutcome runUnitCellJob(DemSystem& cell, const std::array<double, 9>& strainIncrement, const RelaxSettings& set) {
  JobOutcome out;
  out.tolerance = set.tolerance;
  out.minCoordination = set.minCoordination;
  out.budget = set.maxSteps;
  const bool loaded = std::any_of(strainIncrement.begin(), strainIncrement.end(), [](double v) { return v != 0.0; });
  if (loaded) {
    // The cell follows the increment affinely: dH/dt = L H with
    // L = d_eps / (n dt), so H_end = (I + d_eps / n)^n H_start, i.e. exp(d_eps) H to O(d_eps^2 / n).
    Mat3 l{};
    for (std::size_t k = 0; k < 9; ++k) l[k] = strainIncrement[k] / (static_cast<double>(set.loadSteps) * set.dt);
    cell.cell.velocityGradient = l;
    for (long k = 0; k < set.loadSteps; ++k) cell.advance(set.dt);
    cell.cell.velocityGradient = {};
    out.steps = set.loadSteps;
  }
  out.steps += relaxJob(cell, set, out.endedStressFree);
  out.stressFreePressure = set.stressFreePressure;
  out.measures = measureCell(cell);
  out.relaxed = out.measures.unbalancedForceIndex > 0.0 && out.measures.unbalancedForceIndex < set.tolerance;
  return out;
}

}  // namespace cosim::dem
