#include "cosim/dem/cell/unit_cell_worker.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <span>
#include <sstream>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/solver/yaml_section.hpp"
#include <capnp/message.h>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/solver.hpp"

namespace cosim::dem {
namespace {

using wire::SolverError;
using Code = proto::Error::Code;

constexpr char kMagic[8] = {'C', 'O', 'S', 'I', 'M', 'G', 'M', 'H'};
// 3: the stress-free exit; 2: on_failure (older files restore with the exit
// off, and version 1 as on_failure: stop)
constexpr std::uint32_t kVersion = 3;

/// A prepared cell from `file` (relative: against baseDir, then as given);
/// `fail(message)` reports a problem where the file was named.
template <class Fail>
DemSystem readCell(const std::string& file, const std::string& baseDir, Fail fail) {
  DemSystem cell;
  try {
    readCheckpoint(cell, wire::resolveScenePath(file, baseDir));
  } catch (const std::exception& e) {
    fail(e.what());
  }
  if (!cell.cell.enabled) fail("'" + file + "' holds no periodic cell (prepare it with dem_prepare_cell)");
  cell.cell.velocityGradient = {};
  return cell;
}

DemSystem loadCell(const YamlSection& s, const std::string& key, const std::string& baseDir) {
  return readCell(s.text(key), baseDir, [&](const std::string& message) { s.fail(key, message); });
}

/// The k-th entry of unit_cells.variants: another prepared cell (another seed).
DemSystem loadVariant(const YamlSection& s, const YAML::Node& entry, std::size_t k, const std::string& baseDir) {
  const std::string where = s.where(entry) + ": " + s.path() + ".variants[" + std::to_string(k) + "]";
  return readCell(toText(entry, where), baseDir, [&](const std::string& message) { throw SceneError(where + ": " + message); });
}

/// One UnitCellResults list of n cells, filled cell by cell (jobs and the setup report).
struct ResultRows {
  std::span<std::uint32_t> ids;
  std::span<double> stress, porosity, coordination, index;
  std::span<std::uint32_t> steps;
  proto::UnitCellResults::Builder list;
  ResultRows(proto::UnitCellResults::Builder r, unsigned n)
      : ids(wire::view(r.initCellIds(n))),
        stress(wire::view(r.initStresses(9 * n))),
        porosity(wire::view(r.initPorosities(n))),
        coordination(wire::view(r.initCoordinationNumbers(n))),
        index(wire::view(r.initUnbalancedForceIndices(n))),
        steps(wire::view(r.initRelaxationSteps(n))),
        list(r) {}
  /// Flags cell k failed (the list is sized on the first failure: empty means none failed).
  void fail(unsigned k) {
    if (!list.hasFailed()) list.initFailed(static_cast<unsigned>(ids.size()));
    list.getFailed().set(k, true);
  }
  void set(unsigned k, std::uint32_t id, const CellMeasures& m, std::uint32_t relaxationSteps) {
    ids[k] = id;
    for (unsigned c = 0; c < 9; ++c) stress[9 * k + c] = m.stress[c];
    porosity[k] = m.porosity;
    coordination[k] = m.coordination;
    index[k] = m.unbalancedForceIndex;
    steps[k] = relaxationSteps;
  }
};

/// Which of the files a cell starts from, by its id alone (so every worker and
/// every stride agree): a splitmix64 hash, spatially uncorrelated over a mesh
/// numbered row by row. 0 is `file`, k > 0 the k-th entry of `variants`.
std::size_t variantOf(std::uint32_t id, std::size_t files) {
  std::uint64_t z = static_cast<std::uint64_t>(id) + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return static_cast<std::size_t>((z ^ (z >> 31)) % files);
}

/// The relaxation step: dt, or dt_factor x the smallest critical step of the
/// cells' files (variants may hold a smaller sphere than `file`).
RelaxSettings readRelaxSettings(const YamlSection& s, const std::vector<DemSystem>& prototypes) {
  RelaxSettings r;
  const double factor = s.positive("dt_factor", 0.5);
  if (factor > 1.0) s.fail("dt_factor", "must not exceed 1");
  double critical = std::numeric_limits<double>::max();
  for (const DemSystem& p : prototypes) critical = std::min(critical, criticalTimeStep(p));
  r.dt = s.positive("dt", factor * critical);
  r.tolerance = s.positive("tolerance", 0.01);
  r.maxSteps = s.integer("max_steps", 20000);
  if (r.maxSteps < 1) s.fail("max_steps", "must be at least 1");
  r.loadSteps = s.integer("load_steps", 100);
  if (r.loadSteps < 1) s.fail("load_steps", "must be at least 1");
  r.minCoordination = s.number("min_coordination", 2.0);
  if (r.minCoordination < 0.0) s.fail("min_coordination", "must not be negative");
  const std::string onFailure = s.has("on_failure") ? s.text("on_failure") : "stop";
  if (onFailure != "stop" && onFailure != "continue")
    s.fail("on_failure", "expected stop (the advance fails naming the cells) or continue (their stresses go back "
                         "as they stand, flagged failed), got '" + onFailure + "'");
  r.continueOnFailure = onFailure == "continue";
  if (s.has("stress_free_exit")) {
    const YamlSection e = s.child("stress_free_exit", {"pressure", "after"});
    r.stressFreePressure = e.positive("pressure");
    r.stressFreeAfter = e.integer("after", 2000);
    if (r.stressFreeAfter < 1) e.fail("after", "must be at least 1 relaxation step");
  }
  return r;
}

std::array<double, 9> increment(std::span<const double> values, std::size_t k, std::uint32_t id) {
  std::array<double, 9> d{};
  for (std::size_t c = 0; c < 9; ++c) {
    d[c] = values[9 * k + c];
    if (!std::isfinite(d[c]))
      throw SolverError(Code::BAD_INPUT, "unit-cell jobs: non-finite strain increment for cell " + std::to_string(id));
  }
  return d;
}

}  // namespace

std::unique_ptr<UnitCellWorker> UnitCellWorker::fromParams(const YAML::Node& node, const std::string& sceneFile,
                                                           const std::string& baseDir, PoolShare share) {
  const std::string dir = baseDir.empty() ? std::filesystem::path(sceneFile).parent_path().string() : baseDir;
  const YamlSection params(node, sceneFile, "params", {"unit_cells"});
  const YamlSection s = params.child("unit_cells", {"file", "first_id", "count", "stride", "weakened", "dt", "dt_factor",
                                                    "tolerance", "max_steps", "load_steps", "min_coordination",
                                                    "mass_damping", "on_failure", "variants", "stress_free_exit"});
  // The cells' starting states: `file`, and the optional `variants` (cells
  // prepared with other seeds), one chosen per cell id by variantOf.
  const YAML::Node variants = s.node("variants");
  if (variants && (!variants.IsSequence() || variants.size() == 0))
    s.fail("variants", "expected a non-empty list of cell files");
  std::vector<DemSystem> prototypes;
  prototypes.reserve(1 + (variants ? variants.size() : 0));
  prototypes.push_back(loadCell(s, "file", dir));
  for (std::size_t k = 0; variants && k < variants.size(); ++k) prototypes.push_back(loadVariant(s, variants[k], k, dir));
  if (s.has("mass_damping")) {
    const double c = s.number("mass_damping");
    if (c < 0.0) s.fail("mass_damping", "must not be negative");
    for (auto& p : prototypes) p.massDamping = c;
  }
  auto worker = std::make_unique<UnitCellWorker>(readRelaxSettings(s, prototypes));
  const DemSystem& prototype = prototypes.front();
  const long first = s.integer("first_id", 0), count = s.integer("count", 1), stride = s.integer("stride", 1);
  if (first < 0) s.fail("first_id", "must not be negative");
  if (count < 1) s.fail("count", "must be at least 1");
  if (stride < 1) s.fail("stride", "must be at least 1");
  if (count < static_cast<long>(share.size))
    s.fail("count", "the pool's " + std::to_string(share.size) + " workers share " + std::to_string(count) +
                        " cells: at least one cell per worker");
  // The entry's k-th cell, first_id + k stride, belongs to worker k mod size.
  const auto kOf = [&](long id) { return id >= first && (id - first) % stride == 0 ? (id - first) / stride : -1L; };
  const auto listed = [&](long id) { return kOf(id) >= 0 && kOf(id) < count; };
  const auto held = [&](long id) { return listed(id) && kOf(id) % share.size == share.index; };
  std::set<std::uint32_t> weakIds;
  std::unique_ptr<DemSystem> weak;
  if (s.has("weakened")) {
    const YamlSection w = s.child("weakened", {"file", "ids"});
    weak = std::make_unique<DemSystem>(loadCell(w, "file", dir));
    weak->massDamping = prototype.massDamping;
    const YAML::Node ids = w.node("ids");
    if (!ids || !ids.IsSequence()) w.fail("ids", "expected a list of cell ids");
    for (const auto& id : ids) {
      const long v = id.as<long>(-1);
      if (!listed(v))
        w.fail("ids", "cell id " + id.as<std::string>("?") + " is not among this worker's cells (first_id + k stride, k < count)");
      if (held(v)) weakIds.insert(static_cast<std::uint32_t>(v));
    }
  }
  for (long k = share.index; k < count; k += share.size) {
    const auto id = static_cast<std::uint32_t>(first + k * stride);
    worker->add(id, cloneCell(weakIds.count(id) ? *weak : prototypes[variantOf(id, prototypes.size())]));
  }
  return worker;
}

void UnitCellWorker::add(std::uint32_t id, DemSystem cell) {
  if (index_.count(id)) throw std::runtime_error("unit cell " + std::to_string(id) + " added twice");
  index_[id] = cells_.size();
  ids_.push_back(id);
  cells_.push_back(std::make_unique<DemSystem>(std::move(cell)));
}

DemSystem& UnitCellWorker::cell(std::uint32_t id) {
  const auto it = index_.find(id);
  if (it == index_.end())
    throw SolverError(Code::BAD_INPUT, "unit-cell jobs: cell " + std::to_string(id) + " is not held by this worker (it holds " +
                                           std::to_string(ids_.size()) + " cells from " +
                                           (ids_.empty() ? std::string("-") : std::to_string(ids_.front())) + ")");
  return *cells_[it->second];
}

void UnitCellWorker::answer(proto::CouplingData::Reader inputs, proto::CouplingData::Builder outputs) {
  if (!inputs.hasUnitCellJobs()) return;
  const auto jobLists = inputs.getUnitCellJobs();
  auto resultLists = outputs.initUnitCellResults(jobLists.size());
  std::string failures;
  for (unsigned list = 0; list < jobLists.size(); ++list) run(jobLists[list], resultLists[list], failures);
  refuseFailures(failures);
  writeFineTimeStep(outputs);
}

void UnitCellWorker::run(proto::UnitCellJobs::Reader jobs, proto::UnitCellResults::Builder results,
                         std::string& failures) {
  const auto ids = wire::view(jobs.getCellIds());
  const auto strains = wire::view(jobs.getStrainIncrements());
  if (strains.size() != 9 * ids.size())
    throw SolverError(Code::BAD_INPUT, "unit-cell jobs: " + std::to_string(strains.size()) + " strain values for " +
                                           std::to_string(ids.size()) + " cells (need 9 each)");
  for (std::uint32_t id : ids) cell(id);  // every id known before any cell moves
  const auto n = static_cast<unsigned>(ids.size());
  ResultRows rows(results, n);
  for (unsigned k = 0; k < n; ++k) {
    const JobOutcome o = runUnitCellJob(cell(ids[k]), increment(strains, k, ids[k]), relax_);
    rows.set(k, ids[k], o.measures, static_cast<std::uint32_t>(o.steps));
    if (const std::string why = o.problem(); !why.empty()) {
      rows.fail(k);
      failures += (failures.empty() ? "" : "; ") + std::string("cell ") + std::to_string(ids[k]) + ": " + why;
    }
  }
}

void UnitCellWorker::refuseFailures(const std::string& failures) const {
  if (!failures.empty() && !relax_.continueOnFailure)
    throw SolverError(Code::SOLVER_FAILURE, "unit cells failed: " + failures);
}

void UnitCellWorker::adopt(proto::AdoptCells::Reader request, proto::CouplingData::Builder outputs) {
  const std::string path = request.getPath();
  const std::string what = "adopting unit cells from " + path;
  std::unique_ptr<UnitCellWorker> lost;
  try {
    lost = restore(path);
  } catch (const std::exception& e) {
    throw SolverError(Code::BAD_INPUT, what + ": " + e.what());
  }
  if (!lost) throw SolverError(Code::BAD_INPUT, what + ": not a unit-cell worker checkpoint");
  if (!(lost->relax_ == relax_))
    throw SolverError(Code::BAD_INPUT, what + ": its cells relaxed with other unit_cells settings (dt, tolerance, "
                                              "max_steps, load_steps, min_coordination, on_failure, stress_free_exit) "
                                              "than this worker's, so their answers here would differ; give the "
                                              "pool's workers the same settings");
  const auto ids = wire::view(request.getCellIds());
  for (std::uint32_t id : ids) {
    if (index_.count(id)) throw SolverError(Code::BAD_INPUT, what + ": this worker holds unit cell " + std::to_string(id) + " already");
    if (!lost->index_.count(id))
      throw SolverError(Code::BAD_INPUT, what + ": the checkpoint holds no unit cell " + std::to_string(id));
  }
  const auto jobLists = request.getJobs();
  const std::set<std::uint32_t> adopted(ids.begin(), ids.end());
  for (auto jobs : jobLists)
    for (std::uint32_t id : wire::view(jobs.getCellIds()))
      if (!adopted.count(id))
        throw SolverError(Code::BAD_INPUT, what + ": a replayed job names unit cell " + std::to_string(id) +
                                               ", which is not among the cells adopted");
  for (std::uint32_t id : ids) add(id, std::move(lost->cell(id)));
  std::string failures;
  if (jobLists.size() == 0) {
    const auto n = static_cast<unsigned>(ids.size());
    ResultRows rows(outputs.initUnitCellResults(1)[0], n);
    for (unsigned k = 0; k < n; ++k) rows.set(k, ids[k], measureCell(cell(ids[k])), 0);
  } else {
    // The jobs before the last were answered by the lost worker already: only
    // their effect on the cells' states counts, so their results are scratch.
    for (unsigned list = 0; list + 1 < jobLists.size(); ++list) {
      capnp::MallocMessageBuilder scratch;
      std::string ignored;
      run(jobLists[list], scratch.initRoot<proto::UnitCellResults>(), ignored);
    }
    run(jobLists[jobLists.size() - 1], outputs.initUnitCellResults(1)[0], failures);
  }
  refuseFailures(failures);
  writeFineTimeStep(outputs);
}

void UnitCellWorker::writeFineTimeStep(proto::CouplingData::Builder outputs) const {
  // Liu 2016 Eqs. 63-64 for the tightest of this worker's cells, with the
  // pseudo-time step the cells relax with, so the coupler can report the
  // fine/coarse time-step relation (Eq. 66).
  FineTimeStep tightest;
  for (const auto& c : cells_) {
    const FineTimeStep f = fineTimeStep(*c);
    if (f.criticalDt > 0.0 && (tightest.criticalDt == 0.0 || f.criticalDt < tightest.criticalDt)) tightest = f;
  }
  auto a = outputs.initArrays(1)[0];
  a.setName(proto::FINE_TIME_STEP_ARRAY);  // gmh.capnp
  a.setComponents(6);
  auto v = wire::view(a.initValues(6));
  const double values[6] = {relax_.dt, tightest.criticalDt, tightest.omegaMax, tightest.dampingFraction,
                            tightest.omegaN, tightest.omegaTheta};
  std::copy(std::begin(values), std::end(values), v.begin());
}

void UnitCellWorker::report(proto::CouplingData::Builder outputs) const {
  const auto n = static_cast<unsigned>(ids_.size());
  ResultRows rows(outputs.initUnitCellResults(1)[0], n);
  for (unsigned k = 0; k < n; ++k) rows.set(k, ids_[k], measureCell(*cells_[k]), 0);
  writeFineTimeStep(outputs);
}

std::uint64_t UnitCellWorker::checkpoint(const std::string& path) const {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open checkpoint for writing");
  auto pod = [&out](const auto& v) { out.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
  pod(kMagic);
  pod(kVersion);
  pod(relax_.dt); pod(relax_.tolerance); pod(relax_.maxSteps); pod(relax_.loadSteps); pod(relax_.checkEvery);
  pod(relax_.minCoordination);
  pod(static_cast<std::uint8_t>(relax_.continueOnFailure));
  pod(relax_.stressFreePressure); pod(relax_.stressFreeAfter);
  pod(time); pod(steps);
  pod(static_cast<std::uint64_t>(cells_.size()));
  for (std::size_t k = 0; k < cells_.size(); ++k) {
    pod(ids_[k]);
    writeCheckpoint(*cells_[k], out, path);
  }
  out.flush();
  if (!out) throw std::runtime_error(path + ": write failed");
  return static_cast<std::uint64_t>(out.tellp());
}

std::unique_ptr<UnitCellWorker> UnitCellWorker::restore(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open checkpoint");
  char magic[8] = {};
  in.read(magic, 8);
  if (!in || std::memcmp(magic, kMagic, 8) != 0) return nullptr;
  auto pod = [&in, &path](auto& v) {
    in.read(reinterpret_cast<char*>(&v), sizeof(v));
    if (!in) throw std::runtime_error(path + ": truncated unit-cell worker checkpoint");
  };
  std::uint32_t version = 0;
  pod(version);
  if (version < 1 || version > kVersion)
    throw std::runtime_error(path + ": unsupported unit-cell worker checkpoint version " + std::to_string(version));
  RelaxSettings r;
  pod(r.dt); pod(r.tolerance); pod(r.maxSteps); pod(r.loadSteps); pod(r.checkEvery); pod(r.minCoordination);
  if (version >= 2) {
    std::uint8_t proceed = 0;
    pod(proceed);
    if (proceed > 1) throw std::runtime_error(path + ": corrupt unit-cell worker checkpoint (on_failure)");
    r.continueOnFailure = proceed == 1;
  }
  if (version >= 3) {
    pod(r.stressFreePressure); pod(r.stressFreeAfter);
    if (!(r.stressFreePressure >= 0.0) || r.stressFreeAfter < 0)
      throw std::runtime_error(path + ": corrupt unit-cell worker checkpoint (stress-free exit)");
  }
  auto worker = std::make_unique<UnitCellWorker>(r);
  pod(worker->time); pod(worker->steps);
  std::uint64_t count = 0;
  pod(count);
  if (count > (std::uint64_t{1} << 24)) throw std::runtime_error(path + ": corrupt unit-cell worker checkpoint (cell count)");
  for (std::uint64_t k = 0; k < count; ++k) {
    std::uint32_t id = 0;
    pod(id);
    DemSystem cell;
    readCheckpoint(cell, in, path);
    worker->add(id, std::move(cell));
  }
  return worker;
}

}  // namespace cosim::dem
