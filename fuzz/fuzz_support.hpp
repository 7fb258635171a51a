#pragma once
// What the fuzz targets share: the input size bound, a scratch directory for
// the files a reader opens, small fixture files for the setups that name
// one, seeds from the shipped configs, and setting up a solver the way
// `solverMain --check` does.
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cosim/wire/solver.hpp"
#include "session.capnp.h"

namespace cosim::fuzz {

using Bytes = std::vector<std::uint8_t>;

/// Inputs above this are refused unread: a config or a small checkpoint is
/// far smaller, and larger inputs only make an execution slower.
constexpr std::size_t kMaxInputBytes = 64 * 1024;

/// The name of the solver instance the params targets set up.
constexpr const char* kInstance = "fuzz";
/// The scene file name the params targets report errors under.
constexpr const char* kSceneFile = "fuzz.yaml";

/// The input as text; empty when it is larger than kMaxInputBytes.
std::optional<std::string_view> inputText(const std::uint8_t* data, std::size_t size);
Bytes bytesOf(std::string_view text);

/// A directory of this process (under /dev/shm where there is one, so that
/// writing an input costs no disk), removed at exit. Holds the fixtures.
const std::filesystem::path& scratchDir();
/// Writes the bytes to scratchDir()/name and returns the path.
std::filesystem::path writeScratch(const std::string& name, const std::uint8_t* data, std::size_t size);
std::filesystem::path writeScratch(const std::string& name, std::string_view text);
Bytes readBytes(const std::filesystem::path& path);

/// Small files in scratchDir() that params may name: particles.csv (DEM),
/// bar.msh (FEM, the Gmsh reader test's two-hexahedron bar), points.txt
/// (PD). Their texts are seeds of the file targets.
extern const char* const kParticleCsv;
std::string barMesh();
extern const char* const kPointFile;
void writeFixtures();

/// Whether no scalar of the tree holds a '/': a setup then opens only the
/// files of scratchDir() (relative names resolve there first), never a
/// device or a large file elsewhere that a fuzzed path could name.
bool namesOnlyPlainFiles(const YAML::Node& node);
/// Whether a params target takes the scene text: not when it parses and a
/// value names a path (namesOnlyPlainFiles). Text that does not parse is
/// taken: reporting it is the setup's job.
bool takesScene(std::string_view text);

/// The `solvers:` entry named `instance` of a shipped config (path relative to
/// the source tree); the params targets' seeds edit such entries to stay small.
YAML::Node shippedSolver(const std::string& config, const std::string& instance);
/// A scene text holding only `entry`, renamed kInstance: a params target's input.
Bytes sceneWith(YAML::Node entry);
/// The text of a file of the source tree.
std::string sourceText(const std::string& relative);

/// Lowers the memory the solvers' size checks allow (COSIM_MEMORY_LIMIT)
/// to what sets up in milliseconds, writes the fixtures and keeps OpenMP to
/// one thread. Called once by every solver target.
void prepareSolverTarget();

/// The setup the coupler would ask for: `sceneYaml`, instance kInstance, scene
/// file kSceneFile, scene directory scratchDir(), an empty run directory in
/// it, no inputs.
void setUp(wire::Solver& solver, std::string_view sceneYaml);
/// The params targets' step: a scene text (refused unread unless
/// takesScene) set up; a SolverError must name one of `files` (the scene
/// file kSceneFile among them).
/// Returns libFuzzer's verdict (-1: not taken into the corpus).
int setUpScene(wire::Solver& solver, const std::uint8_t* data, std::size_t size, std::initializer_list<std::string_view> files);
/// The file targets' step: the bytes written to scratchDir()/file and the
/// scene `sceneYaml`, which names it, set up; a SolverError must name the
/// file or the scene.
int setUpWithFile(wire::Solver& solver, std::string_view sceneYaml, const std::string& file, const std::uint8_t* data, std::size_t size);
/// One advance of `steps` steps of `dt` from the solver's time.
void advance(wire::Solver& solver, std::uint32_t steps, double dt, proto::CouplingData::Reader inputs = {});

/// A resume from the checkpoint bytes, as `coupler run --resume` asks for it:
/// written to scratchDir()/file and restored (a SolverError must name the
/// file), then, once accepted, one step of dt (a SolverError of any message).
void resume(wire::Solver& solver, const std::uint8_t* data, std::size_t size, const std::string& file, double dt);

/// A user error as the readers report them names the file at fault (scene,
/// mesh, particle, point or checkpoint file): `e` must name one of `files`,
/// else it is a finding. Printed when $COSIM_FUZZ_VERBOSE is set, to see
/// where the seeds stop.
void userError(const std::exception& e, std::initializer_list<std::string_view> files);
/// The same for an error that need not name a file (one of a step after a restore).
void userError(const std::exception& e);

/// Reads every field of a message, everywhere, through Cap'n Proto's dynamic
/// API: what any reader of a received message might touch.
void readEverywhere(proto::Envelope::Reader envelope);

/// Reports an outcome that is a finding (an exception that is no user error)
/// and aborts, so that libFuzzer keeps the input.
[[noreturn]] void finding(const std::string& what);

}  // namespace cosim::fuzz
