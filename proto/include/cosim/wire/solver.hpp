#pragma once
// The narrow interface every solver process implements. The SolverHost turns
// protocol messages into these calls; a solver never touches a socket.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "data.capnp.h"
#include "session.capnp.h"

namespace cosim::wire {

struct SolverInfo {
  std::string kind;     // "dem", "fem", "pd", "mock" ...
  std::string version;
  std::vector<std::string> capabilities;
  // The protocol this solver was built against: the schema's constants,
  // unless the binary deliberately speaks another version.
  std::uint16_t protocolMajor = proto::PROTOCOL_MAJOR;
  std::uint16_t protocolMinor = proto::PROTOCOL_MINOR;
};

/// What a solver throws for anything the coupler should hear about. The
/// message names the file, key, entity or step; the code classifies it.
class SolverError : public std::runtime_error {
 public:
  SolverError(proto::Error::Code code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  proto::Error::Code code() const { return code_; }

 private:
  proto::Error::Code code_;
};

/// A relative file named in a scene: looked up in `baseDir` (the scene's
/// directory) first, then as given (relative to the working directory).
std::string resolveScenePath(const std::string& file, const std::string& baseDir);

struct SetupContext {
  std::string sceneFile;
  std::string sceneYaml;
  std::string instance;
  std::string runDir;
  proto::CouplingData::Reader inputs;
  bool resuming = false;  // a restore follows (coupler run --resume): append to existing output files
  std::string sceneDir = {};  // where relative paths in the scene resolve; empty: sceneFile's directory
  /// A worker of a pool entry (`solvers[i].pool`): the entry whose params it
  /// reads, its index and the worker count (poolSize 0: not in a pool).
  std::string poolEntry = {};
  std::uint32_t poolIndex = 0, poolSize = 0;
  /// The directory relative paths in the scene (meshes, particle and cell files) resolve against.
  std::string baseDir() const;
  /// The name of the scene entry whose params this solver reads: its pool's, else its own.
  const std::string& paramsEntry() const { return poolSize > 0 ? poolEntry : instance; }
};

/// The SolverHost refuses an advance with steps = 0 or a dt that is not
/// finite and positive before it reaches a solver.
struct AdvanceRequest {
  std::uint32_t steps = 0;
  double dt = 0.0;
  double time = 0.0;
  std::uint64_t exchange = 0;
  proto::CouplingData::Reader inputs;
  std::optional<proto::CouplingData::Reader> inputsEnd;  // for interpolation in sub-steps
};

using NamedValues = std::vector<std::pair<std::string, double>>;

class Solver {
 public:
  virtual ~Solver() = default;
  virtual SolverInfo info() const = 0;
  /// Reads the solver's own section of the scene; fills the coupling data
  /// the couplings need at time zero.
  virtual void setup(const SetupContext& context, proto::CouplingData::Builder outputs) = 0;
  virtual void advance(const AdvanceRequest& request, proto::CouplingData::Builder outputs) = 0;
  /// Named fields on request (empty list = all it offers).
  virtual void fields(const std::vector<std::string>& names, proto::CouplingData::Builder out) = 0;
  /// Writes the full state to path; returns the bytes written.
  virtual std::uint64_t checkpoint(const std::string& path) = 0;
  virtual void restore(const std::string& path) = 0;
  virtual double time() const = 0;
  virtual std::uint64_t step() const = 0;
  /// Largest stable step for the current state; 0 when unlimited.
  virtual double criticalDt() const = 0;
  virtual NamedValues energies() const = 0;
  /// Called by the host right after it sent an advance's reply, before it
  /// waits for the next request. A solver may compute here what its next
  /// advance needs from the state it just reported alone (PD: the next step's
  /// half kick, drift and bond forces), so that work overlaps the coupler's
  /// and the other solvers'. Whatever request comes next must be answered
  /// bitwise as if nothing had been done ahead. Returns whether it did any
  /// work (the host reports its time with the next advance).
  virtual bool workAhead() { return false; }
  /// A GMH worker (capability unit-cell-adoption) takes over the unit cells a
  /// lost worker held: loads them from its checkpoint, runs the jobs they were
  /// sent since, and answers with the results of the last jobs (session.capnp).
  virtual void adoptCells(proto::AdoptCells::Reader /*request*/, proto::CouplingData::Builder /*outputs*/) {
    throw SolverError(proto::Error::Code::UNSUPPORTED, "this solver holds no unit cells to adopt others into");
  }
  /// Size hint (8-byte words) for reply buffers, so large outputs stay in one segment.
  virtual std::size_t outputWordsHint() const { return 1024; }
};

/// Capabilities every conforming solver has.
const std::vector<std::string>& baseCapabilities();

}  // namespace cosim::wire
