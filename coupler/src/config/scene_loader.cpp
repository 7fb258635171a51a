#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/util/cpu_affinity.hpp"

namespace cosim::coupler {
namespace fs = std::filesystem;
using config::Diagnostics;
using config::MapReader;
using config::Range;

namespace {

// Instance and coupling names: they become routing ids and HDF5 group names,
// and `solver.array` references split at the dot, so no dots.
bool isInstanceName(const std::string& name) {
  static const std::regex pattern("[A-Za-z][A-Za-z0-9_-]*");
  return std::regex_match(name, pattern);
}

// The binary each solver kind runs when a scene names no `binary`.
const std::map<std::string, std::string>& defaultBinaries() {
  static const std::map<std::string, std::string> m{
      {"dem", "dem_solver"}, {"fem", "fem_solver"}, {"pd", "pd_solver"}, {"mock", "mock_solver"}};
  return m;
}

bool isExecutable(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0;
}

fs::path ownDirectory() {
  std::error_code ec;
  auto exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

void readTransport(MapReader& m, Scene& scene) {
  auto& t = scene.transport;
  scene.transportKindGiven = m.has("kind");
  t.kind = m.choice("kind", {"ipc", "tcp"}, std::string("ipc")) == "tcp" ? wire::TransportOptions::Kind::tcp
                                                                        : wire::TransportOptions::Kind::ipc;
  scene.transportInterfaceGiven = m.has("interface");
  scene.transportCurveGiven = m.has("curve");
  t.interface = m.string("interface", "127.0.0.1");
  t.port = static_cast<int>(m.integer("port", 0, 0, 65535));
  t.curve = m.boolean("curve", false);
  auto& l = scene.link;
  l.heartbeatIntervalS = m.number("heartbeat_interval", 0.5, Range::positive());
  l.heartbeatTimeoutS = m.number("heartbeat_timeout", 10.0, Range::positive());
  l.requestTimeoutS = m.number("request_timeout", 3600.0, Range::positive());
  const std::string data = m.choice("data", {"auto", "shm", "zmq"}, std::string("auto"));
  l.shm.mode = data == "shm" ? wire::ShmOptions::Mode::shm
               : data == "zmq" ? wire::ShmOptions::Mode::zmq
                               : wire::ShmOptions::Mode::automatic;
  l.shm.spinS = 1e-6 * m.number("shm_spin_us", 1e6 * l.shm.spinS, Range::closed(0.0, 1e6));
  l.shm.laneBytes = static_cast<std::uint64_t>(m.integer("shm_lane_mib", 1024, 1, 1 << 20)) << 20;
  scene.connectTimeoutS = m.number("connect_timeout", 30.0, Range::positive());
  if (l.heartbeatTimeoutS <= 2.0 * l.heartbeatIntervalS)
    m.error("heartbeat_timeout", "must be more than twice heartbeat_interval (" +
                                     config::formatNumber(l.heartbeatIntervalS) + " s), or every late beat is a fault");
  if (t.kind == wire::TransportOptions::Kind::ipc && m.has("port"))
    m.error("port", "only a tcp transport has a port");
  if (t.kind == wire::TransportOptions::Kind::ipc && t.curve)
    m.error("curve", "applies to tcp only (an ipc socket is private to its 0700 run directory)");
}

/// `resources: {cpus_per_task, memory, overlap}` of a solver started by srun.
void readResources(MapReader& parent, SlurmResources& r) {
  MapReader m(parent.node("resources"), parent.keyPath("resources"), parent.diagnostics());
  if (!m.valid()) return;
  for (const char* key : {"tasks", "nodes"})
    if (m.has(key) && m.integer(key, 1, 1, 1000000) != 1)
      m.error(key, "a solver instance is one process (one task on one node); declare a pool's workers as solvers "
                   "of their own, and Slurm spreads their steps over the allocation's nodes");
  r.cpusPerTask = static_cast<int>(m.integer("cpus_per_task", 1, 1, 100000));
  if (m.has("memory")) {
    r.memory = m.requireString("memory");
    static const std::regex memory("[1-9][0-9]*[KMGT]?");
    if (!std::regex_match(r.memory, memory))
      m.error("memory", "expected a size as srun --mem takes it (e.g. 512M, 4G), got '" + r.memory + "'");
  }
  r.overlap = m.boolean("overlap", false);
  m.finish();
}

/// `pool: {workers, workers_per_node}`: the entry stands for `workers` solvers of its kind.
void readPool(MapReader& parent, SolverSpec& s) {
  MapReader m(parent.node("pool"), parent.keyPath("pool"), parent.diagnostics());
  if (!m.valid()) return;
  if (!m.has("workers")) m.error("workers", "missing: how many workers the pool starts");
  s.poolSize = static_cast<int>(m.optionalInteger("workers", 1, 10000).value_or(0));
  if (m.has("workers_per_node")) {
    if (s.launch != SolverSpec::Launch::srun)
      m.error("workers_per_node", "places job steps on nodes: applies to launch: srun only");
    else s.workersPerNode = static_cast<int>(m.integer("workers_per_node", 1, 1, 100000));
  }
  m.finish();
  if (!s.kind.empty() && s.kind != "dem")
    parent.error("pool", "a pool's workers are dem_solver unit-cell workers (kind: dem, params.unit_cells), not '" +
                             s.kind + "'");
}

/// A pool entry's workers: `<entry>-0` .. `<entry>-<N-1>`, each with the entry's settings.
void addPoolWorkers(MapReader& m, const SolverSpec& entry, Scene& scene, std::set<std::string>& names) {
  for (int k = 0; k < entry.poolSize; ++k) {
    SolverSpec w = entry;
    w.name = entry.name + "-" + std::to_string(k);
    w.poolEntry = entry.name;
    w.poolIndex = k;
    if (!names.insert(w.name).second)
      m.error("pool", "its worker '" + w.name + "' has the name of a solver already declared");
    scene.solvers.push_back(std::move(w));
  }
}

void readSolver(MapReader& m, const std::string& sceneDir, Scene& scene, std::set<std::string>& names) {
  SolverSpec s;
  s.line = m.mark().line + 1;
  s.name = m.requireString("name");
  if (m.has("name") && s.name.empty()) m.error("name", "must not be empty");
  if (!s.name.empty() && !isInstanceName(s.name))
    m.error("name", "'" + s.name + "' is not a valid instance name (letters, digits, '_', '-', starting with a letter)");
  if (!s.name.empty() && !names.insert(s.name).second) m.error("name", "a solver named '" + s.name + "' is already declared");
  s.kind = m.requireString("kind");
  const auto binary = m.optionalString("binary");
  const auto launch = m.choice("launch", {"spawn", "attach", "srun"}, std::string("spawn"));
  s.launch = launch == "attach" ? SolverSpec::Launch::attach
             : launch == "srun" ? SolverSpec::Launch::srun
                                : SolverSpec::Launch::spawn;
  if (m.has("resources")) {
    if (s.launch != SolverSpec::Launch::srun) m.error("resources", "applies to launch: srun (a Slurm job step) only");
    else readResources(m, s.resources);
  }
  if (m.has("pool")) readPool(m, s);
  s.args = m.stringList("args");
  s.extraCapabilities = m.stringList("requires");
  m.node("params");  // the solver's own section: the solver validates it at setup
  if (m.has("params") && !m.node("params").IsMap()) m.error("params", "expected a map of the solver's parameters");
  if (!s.kind.empty() && !binary && !defaultBinaries().count(s.kind)) {
    std::string kinds;
    for (const auto& [k, b] : defaultBinaries()) kinds += (kinds.empty() ? "" : ", ") + k;
    m.error("kind", "'" + s.kind + "' has no default binary (known kinds: " + kinds + "); name one with `binary:`");
  }
  const std::string wanted = binary ? *binary : (defaultBinaries().count(s.kind) ? defaultBinaries().at(s.kind) : "");
  s.binary = wanted;
  if (s.launch != SolverSpec::Launch::attach && !wanted.empty()) {
    s.binary = findExecutable(wanted, sceneDir);
    if (s.binary.empty())
      m.error(binary ? "binary" : "kind", "solver executable '" + wanted +
                                              "' not found (looked next to the scene for paths, else in $COSIM_BIN_DIR, "
                                              "the coupler's directory and $PATH)");
  }
  m.finish();
  if (s.poolSize > 0) addPoolWorkers(m, s, scene, names);
  else scene.solvers.push_back(std::move(s));
}

void readSolvers(MapReader& root, const std::string& sceneDir, Scene& scene) {
  auto list = root.node("solvers");
  if (!list.IsDefined() || list.IsNull()) {
    root.diagnostics().error(root.mark(), "scene: missing required key 'solvers' (the solver instances to run)");
    return;
  }
  if (!list.IsSequence() || list.size() == 0) {
    root.error("solvers", "expected a non-empty list of solver instances");
    return;
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    MapReader m(list[i], "solvers[" + std::to_string(i) + "]", root.diagnostics());
    if (m.valid()) readSolver(m, sceneDir, scene, names);
  }
}

void readCouplings(MapReader& root, Scene& scene) {
  auto list = root.node("couplings");
  if (!list.IsDefined() || list.IsNull()) return;
  if (!list.IsSequence()) {
    root.error("couplings", "expected a list of couplings");
    return;
  }
  std::set<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    MapReader m(list[i], "couplings[" + std::to_string(i) + "]", root.diagnostics());
    if (!m.valid()) continue;
    const auto name = m.string("name", "coupling" + std::to_string(i));
    if (!isInstanceName(name))
      m.error("name", "'" + name + "' is not a valid coupling name (letters, digits, '_', '-', starting with a letter)");
    if (!names.insert(name).second) m.error("name", "a coupling named '" + name + "' is already declared");
    const auto kind = m.requireString("kind");
    if (kind.empty()) continue;
    if (!CouplingRegistry::has(kind)) {
      m.error("kind", "unknown coupling kind '" + kind + "' (known: " + CouplingRegistry::namesJoined() + ")");
      continue;
    }
    auto coupling = CouplingRegistry::make(kind, name, m, scene.solvers);
    m.finish();
    if (coupling) scene.couplings.push_back(std::move(coupling));
  }
}

void readAnalysis(MapReader& root, Scene& scene) {
  if (!root.has("analysis")) {
    root.node("analysis");
    return;
  }
  MapReader m(root.node("analysis"), "analysis", root.diagnostics());
  if (!m.valid()) return;
  const auto kind = m.requireString("reference");
  if (kind.empty()) return;
  if (!ReferenceRegistry::has(kind)) {
    m.error("reference", "unknown reference '" + kind + "' (known: " + ReferenceRegistry::namesJoined() + ")");
    return;
  }
  scene.reference = ReferenceRegistry::make(kind, m, scene.solvers);
  m.finish();
}

void readSchedule(MapReader& root, Scene& scene) {
  if (!root.has("schedule")) {
    root.diagnostics().error(root.mark(), "scene: missing required key 'schedule'");
    root.node("schedule");
    return;
  }
  MapReader m(root.node("schedule"), "schedule", root.diagnostics());
  if (!m.valid()) return;
  const auto kind = m.requireString("kind");
  if (kind.empty()) return;
  if (!ScheduleRegistry::has(kind)) {
    m.error("kind", "unknown schedule '" + kind + "' (known: " + ScheduleRegistry::namesJoined() + ")");
    return;
  }
  scene.schedule = ScheduleRegistry::make(kind, m, scene.solvers);
  m.finish();
}

void readPlacement(MapReader& root, Scene& scene) {
  if (!root.has("placement")) {
    root.node("placement");
    return;
  }
  MapReader m(root.node("placement"), "placement", root.diagnostics());
  if (!m.valid()) return;
  auto& p = scene.placement;
  p.kind = m.choice("processes", {"spread", "packed"}, std::string("spread")) == "packed" ? PlacementSpec::Kind::packed
                                                                                       : PlacementSpec::Kind::spread;
  const bool hasCpus = m.has("cpus");
  const auto items = m.stringList("cpus");
  for (const auto& item : items) {
    std::size_t used = 0;
    long cpu = -1;
    try {
      cpu = std::stol(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != item.size() || cpu < 0 || cpu >= CPU_SETSIZE) {
      m.error("cpus", "'" + item + "' is not a CPU number (0 to " + std::to_string(CPU_SETSIZE - 1) + ")");
      continue;
    }
    if (std::find(p.cpus.begin(), p.cpus.end(), cpu) != p.cpus.end()) {
      m.error("cpus", "CPU " + item + " is listed twice");
      continue;
    }
    // Checked here so that `coupler check` says it too; the run checks again
    // when it applies the placement (the affinity may change in between).
    try {
      util::requireAllowed(static_cast<int>(cpu));
    } catch (const std::runtime_error& e) {
      m.error("cpus", e.what());
      continue;
    }
    p.cpus.push_back(static_cast<int>(cpu));
  }
  if (hasCpus && p.kind != PlacementSpec::Kind::packed)
    m.error("cpus", "applies to `processes: packed` only (spread leaves the placement to the OS)");
  else if (hasCpus && items.empty())
    m.error("cpus", "an empty list; leave it out to pack on the CPU the coupler starts on");
  m.finish();
}

void readOutput(MapReader& root, Scene& scene) {
  scene.output.dir = "runs/" + scene.name;
  if (!root.has("output")) {
    root.node("output");
    return;
  }
  MapReader m(root.node("output"), "output", root.diagnostics());
  if (!m.valid()) return;
  scene.output.dir = m.string("dir", scene.output.dir);
  if (std::any_of(scene.output.dir.begin(), scene.output.dir.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; }))
    m.error("dir", "contains a control character, which no directory name should");
  scene.output.flushInterval = m.integer("flush_interval", 100, 1, 1000000000);
  scene.output.seriesEvery = m.integer("series_every", 1, 1, 1000000000);
  scene.output.checkpointInterval = m.integer("checkpoint_interval", 0, 0, 1000000000);
  for (const auto& item : m.stringList("record")) {
    const auto dot = item.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == item.size()) {
      m.error("record", "'" + item + "' is not of the form solver.array");
      continue;
    }
    RecordSpec r{item.substr(0, dot), item.substr(dot + 1)};
    if (!scene.solver(r.solver)) m.error("record", "'" + item + "' names no declared solver '" + r.solver + "'");
    scene.output.record.push_back(r);
  }
  m.finish();
}

}  // namespace

std::string findExecutable(const std::string& name, const std::string& sceneDir) {
  if (name.find('/') != std::string::npos) {
    fs::path p(name);
    if (p.is_relative()) p = fs::path(sceneDir) / p;
    return isExecutable(p) ? fs::absolute(p).lexically_normal().string() : std::string();
  }
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("COSIM_BIN_DIR")) dirs.emplace_back(env);
  dirs.push_back(ownDirectory());
  if (const char* path = std::getenv("PATH")) {
    std::stringstream s(path);
    for (std::string d; std::getline(s, d, ':');)
      if (!d.empty()) dirs.emplace_back(d);
  }
  for (const auto& d : dirs)
    if (!d.empty() && isExecutable(d / name)) return (d / name).string();
  return {};
}

std::vector<std::string> solversNamed(const std::string& name, const std::vector<SolverSpec>& solvers) {
  std::vector<std::string> named;
  for (const auto& s : solvers)
    if (s.name == name || (s.poolSize > 0 && s.poolEntry == name)) named.push_back(s.name);
  return named;
}

std::string declaredSolverNames(const std::vector<SolverSpec>& solvers) {
  std::string names;
  for (const auto& s : solvers) {
    if (s.poolSize > 0 && s.poolIndex > 0) continue;
    names += (names.empty() ? "" : ", ") + (s.poolSize > 0 ? s.poolEntry + " (a pool of " + std::to_string(s.poolSize) + ")" : s.name);
  }
  return names;
}

const SolverSpec* Scene::solver(const std::string& n) const {
  for (const auto& s : solvers)
    if (s.name == n) return &s;
  return nullptr;
}

bool Scene::usesSlurm() const {
  return std::any_of(solvers.begin(), solvers.end(), [](const SolverSpec& s) { return s.launch == SolverSpec::Launch::srun; });
}

std::vector<std::string> Scene::requiredCapabilities(const std::string& solverName) const {
  std::set<std::string> caps{"setup", "advance"};
  if (output.checkpointInterval > 0) caps.insert({"checkpoint", "restore"});
  for (const auto& c : couplings) {
    const auto parts = c->participants();
    if (std::find(parts.begin(), parts.end(), solverName) != parts.end())
      for (const auto& cap : c->requiredCapabilities(solverName)) caps.insert(cap);
  }
  if (reference)
    for (const auto& cap : reference->requiredCapabilities(solverName)) caps.insert(cap);
  if (const auto* s = solver(solverName)) {
    caps.insert(s->extraCapabilities.begin(), s->extraCapabilities.end());
    if (s->poolSize > 0) caps.insert("pool-member");
  }
  return {caps.begin(), caps.end()};
}

Scene loadScene(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw config::ConfigError({path + ": cannot open the scene file"});
  std::stringstream text;
  text << in.rdbuf();
  return loadSceneText(text.str(), path, fs::absolute(path).parent_path().string());
}

/// A job step may run on another node: unless the scene says otherwise the
/// coupler listens on every interface over tcp, with CurveZMQ, so that only
/// the run's own solvers are heard.
void defaultClusterTransport(Scene& scene) {
  auto& t = scene.transport;
  if (scene.transportKindGiven) return;
  t.kind = wire::TransportOptions::Kind::tcp;
  if (!scene.transportInterfaceGiven) t.interface = "0.0.0.0";
  if (!scene.transportCurveGiven) t.curve = true;
}

Scene loadSceneText(const std::string& text, const std::string& displayName, const std::string& sceneDir) {
  Scene scene;
  scene.file = displayName;
  scene.sceneDir = sceneDir.empty() ? "." : sceneDir;
  scene.text = text;
  const YAML::Node rootNode = config::loadYamlString(scene.text, displayName);
  Diagnostics diag(displayName);
  if (!rootNode.IsMap()) {
    diag.error(rootNode.Mark(), "a scene is a map with keys scene, schedule, solvers, couplings, transport, output, placement");
    diag.throwIfAny();
  }
  MapReader root(rootNode, "", diag);
  scene.name = root.requireString("scene");
  static const std::regex namePattern("[A-Za-z0-9][A-Za-z0-9_.-]*");
  if (!scene.name.empty() && !std::regex_match(scene.name, namePattern))
    root.error("scene", "'" + scene.name + "' is not a valid scene name (letters, digits, '_', '.', '-')");
  scene.description = root.string("description", "");
  if (root.has("transport")) {
    MapReader t(root.node("transport"), "transport", diag);
    if (t.valid()) {
      readTransport(t, scene);
      t.finish();
    }
  } else {
    root.node("transport");
  }
  readSolvers(root, sceneDir, scene);
  if (scene.usesSlurm()) defaultClusterTransport(scene);
  readSchedule(root, scene);
  readCouplings(root, scene);
  readAnalysis(root, scene);
  readOutput(root, scene);
  readPlacement(root, scene);
  root.finish();
  diag.throwIfAny();
  return scene;
}

}  // namespace cosim::coupler
