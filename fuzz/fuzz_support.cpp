#include "fuzz_support.hpp"

#include <capnp/dynamic.h>
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

void readValue(const capnp::DynamicValue::Reader& v, int depth);

void readStruct(const capnp::DynamicStruct::Reader& s, int depth) {
  if (depth > 64) return;
  for (const auto field : s.getSchema().getFields())
    if (s.has(field)) readValue(s.get(field), depth + 1);
}

void readValue(const capnp::DynamicValue::Reader& v, int depth) {
  switch (v.getType()) {
    case capnp::DynamicValue::TEXT: (void)v.as<capnp::Text>().size(); break;
    case capnp::DynamicValue::DATA: (void)v.as<capnp::Data>().size(); break;
    case capnp::DynamicValue::LIST:
      for (const auto item : v.as<capnp::DynamicList>()) readValue(item, depth + 1);
      break;
    case capnp::DynamicValue::STRUCT: readStruct(v.as<capnp::DynamicStruct>(), depth); break;
    default: break;  // numbers, bools, enums: read by get() already
  }
}

}  // namespace

void readEverywhere(proto::Envelope::Reader envelope) { readStruct(capnp::toDynamic(envelope), 0); }

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
  writeScratch("bar.msh", barMesh());
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

std::string barMesh() { return sourceText("tests/fem/data/two_hex_bar.msh"); }

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
  // The solvers' size checks read it (util::availableMemoryBytes), as they
  // would a user's limit: scenes that would take seconds to build are refused.
  ::setenv("COSIM_MEMORY_LIMIT", std::to_string(kSolverMemoryBytes).c_str(), 1);
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

int setUpScene(wire::Solver& solver, const std::uint8_t* data, std::size_t size, std::initializer_list<std::string_view> files) {
  const auto text = inputText(data, size);
  if (!text || !takesScene(*text)) return -1;
  try {
    setUp(solver, *text);
  } catch (const wire::SolverError& e) {
    userError(e, files);
  }
  return 0;
}

int setUpWithFile(wire::Solver& solver, std::string_view sceneYaml, const std::string& file, const std::uint8_t* data, std::size_t size) {
  if (size > kMaxInputBytes) return -1;
  writeScratch(file, data, size);
  try {
    setUp(solver, sceneYaml);
  } catch (const wire::SolverError& e) {
    userError(e, {file, kSceneFile});
  }
  return 0;
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
