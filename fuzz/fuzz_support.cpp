#include "fuzz_support.hpp"

#include <capnp/message.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <system_error>

#if defined(_OPENMP)
#include <omp.h>
#endif

#include "cosim/util/host_memory.hpp"

namespace cosim::fuzz {
namespace fs = std::filesystem;

namespace {

// What a solver's size checks may take: a few thousand DEM particles, a few
// hundred PD particles with their bonds, a few hundred FEM nodes. Larger
// scenes are refused by the solvers' own checks, with their own messages.
constexpr double kSolverMemoryBytes = 4.0 * 1024 * 1024;

fs::path makeScratchDir() {
  const fs::path base = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
  std::string pattern = (base / "cosim-fuzz-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) {
    std::perror("cosim fuzz: mkdtemp");
    std::abort();
  }
  return pattern;
}

void removeScratchDir() {
  std::error_code ec;
  fs::remove_all(scratchDir(), ec);
}

}  // namespace

std::optional<std::string_view> inputText(const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInputBytes) return std::nullopt;
  return std::string_view(reinterpret_cast<const char*>(data), size);
}

Bytes bytesOf(std::string_view text) { return Bytes(text.begin(), text.end()); }

const fs::path& scratchDir() {
  static const fs::path dir = [] {
    fs::path d = makeScratchDir();
    std::atexit(removeScratchDir);
    return d;
  }();
  return dir;
}

fs::path writeScratch(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const fs::path path = scratchDir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) finding("cannot write the scratch file " + path.string());
  return path;
}

fs::path writeScratch(const std::string& name, std::string_view text) {
  return writeScratch(name, reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

Bytes readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

const char* const kParticleCsv =
    "x,y,z,r,vx,vy,vz\n"
    "0,0,0,0.001,0,0,0\n"
    "0.0021,0,0,0.001,-0.1,0,0\n"
    "0,0.0023,0,0.0012,0,0,0\n";

// Two hexahedra along x with named end faces and volume (Gmsh 4.1 ASCII).
const char* const kBarMsh = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
3
2 1 "left"
2 2 "right"
3 3 "solid"
$EndPhysicalNames
$Entities
0 0 2 1
1 0 0 0 0 1 1 1 1 0
2 2 0 0 2 1 1 1 2 0
1 0 0 0 2 1 1 1 3 0
$EndEntities
$Nodes
1 12 1 12
3 1 0 12
1
2
3
4
5
6
7
8
9
10
11
12
0 0 0
1 0 0
2 0 0
0 1 0
1 1 0
2 1 0
0 0 1
1 0 1
2 0 1
0 1 1
1 1 1
2 1 1
$EndNodes
$Elements
3 4 1 4
2 1 3 1
1 1 4 10 7
2 2 3 1
2 3 6 12 9
3 1 5 2
3 1 2 5 4 7 8 11 10
4 2 3 6 5 8 9 12 11
$EndElements
)";

const char* const kPointFile =
    "# x y z volume\n"
    "0 0 0 1e-9\n"
    "0.001 0 0 1e-9\n"
    "0.002 0 0 1e-9\n"
    "0 0.001 0 1e-9\n"
    "0.001 0.001 0 1e-9\n"
    "0.002 0.001 0 1e-9\n"
    "0 0 0.001 1e-9\n"
    "0.001 0 0.001 1e-9\n"
    "0.002 0 0.001 1e-9\n"
    "0 0.001 0.001 1e-9\n"
    "0.001 0.001 0.001 1e-9\n"
    "0.002 0.001 0.001 1e-9\n";

void writeFixtures() {
  writeScratch("particles.csv", kParticleCsv);
  writeScratch("bar.msh", kBarMsh);
  writeScratch("points.txt", kPointFile);
}

bool namesOnlyPlainFiles(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Scalar:
      return node.Scalar().find('/') == std::string::npos;
    case YAML::NodeType::Sequence:
      for (const auto& item : node)
        if (!namesOnlyPlainFiles(item)) return false;
      return true;
    case YAML::NodeType::Map:
      for (const auto& kv : node)
        if (!namesOnlyPlainFiles(kv.first) || !namesOnlyPlainFiles(kv.second)) return false;
      return true;
    default:
      return true;
  }
}

bool takesScene(std::string_view text) {
  // A '/' in a value is written as one or as an escape of a quoted scalar.
  if (text.find_first_of("/\\") == std::string_view::npos) return true;
  try {
    return namesOnlyPlainFiles(YAML::Load(std::string(text)));
  } catch (const YAML::Exception&) {
    return true;
  }
}

std::string sourceText(const std::string& relative) {
  const fs::path path = fs::path(COSIM_FUZZ_SOURCE_DIR) / relative;
  std::ifstream in(path);
  if (!in) finding("seed source " + path.string() + " is missing");
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

YAML::Node shippedSolver(const std::string& config, const std::string& instance) {
  const YAML::Node scene = YAML::Load(sourceText(config));
  for (const auto& entry : scene["solvers"])
    if (entry["name"].as<std::string>() == instance) return YAML::Clone(entry);
  finding(config + " has no solver '" + instance + "'");
}

Bytes sceneWith(YAML::Node entry) {
  entry["name"] = kInstance;
  YAML::Node scene;
  scene["solvers"].push_back(entry);
  YAML::Emitter out;
  out << scene;
  return bytesOf(std::string(out.c_str()) + "\n");
}

void prepareSolverTarget() {
  util::capAvailableMemory(kSolverMemoryBytes);
  writeFixtures();
#if defined(_OPENMP)
  omp_set_num_threads(1);
#endif
}

void setUp(wire::Solver& solver, std::string_view sceneYaml) {
  // Emptied for every setup: fuzzed snapshot names would pile up files.
  const fs::path runDir = scratchDir() / "run";
  fs::remove_all(runDir);
  fs::create_directories(runDir);
  wire::SetupContext context{kSceneFile, std::string(sceneYaml), kInstance, runDir.string(), {}, false,
                             scratchDir().string()};
  capnp::MallocMessageBuilder outputs;
  solver.setup(context, outputs.initRoot<proto::CouplingData>());
}

void advance(wire::Solver& solver, std::uint32_t steps, double dt, proto::CouplingData::Reader inputs) {
  wire::AdvanceRequest request;
  request.steps = steps;
  request.dt = dt;
  request.time = solver.time();
  request.inputs = inputs;
  capnp::MallocMessageBuilder outputs;
  solver.advance(request, outputs.initRoot<proto::CouplingData>());
}

void resume(wire::Solver& solver, const std::uint8_t* data, std::size_t size, const std::string& file, double dt) {
  const auto path = writeScratch(file, data, size);
  try {
    solver.restore(path.string());
  } catch (const wire::SolverError& e) {
    return userError(e, {file});
  }
  try {
    advance(solver, 1, dt);
  } catch (const wire::SolverError& e) {
    userError(e);
  }
}

void userError(const std::exception& e, std::initializer_list<std::string_view> files) {
  const std::string_view message = e.what();
  for (const auto file : files)
    if (message.find(file) != std::string_view::npos) return userError(e);
  finding("an error that names no file: " + std::string(message));
}

void userError(const std::exception& e) {
  static const bool verbose = std::getenv("COSIM_FUZZ_VERBOSE") != nullptr;
  if (verbose) std::cerr << "user error: " << e.what() << "\n";
}

void finding(const std::string& what) {
  std::cerr << "cosim fuzz finding: " << what << std::endl;
  std::abort();
}

}  // namespace cosim::fuzz
