#include "cosim/wire/solver_host.hpp"

#include <capnp/message.h>
#include <kj/exception.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <cstdlib>
#include <iostream>
#include <new>
#include <thread>

#include "cosim/wire/clock.hpp"
#include "cosim/wire/endpoint.hpp"
#include "cosim/wire/log.hpp"
#include "cosim/wire/shm_link.hpp"
#include "cosim/wire/sockets.hpp"

namespace cosim::wire {

std::string resolveScenePath(const std::string& file, const std::string& baseDir) {
  const std::filesystem::path p(file);
  if (p.is_absolute() || baseDir.empty()) return file;
  const std::filesystem::path beside = std::filesystem::path(baseDir) / p;
  return std::filesystem::exists(beside) ? beside.string() : file;
}

std::string SetupContext::baseDir() const {
  return sceneDir.empty() ? std::filesystem::path(sceneFile).parent_path().string() : sceneDir;
}

const std::vector<std::string>& baseCapabilities() {
  static const std::vector<std::string> caps{"setup", "advance", "fields", "checkpoint", "restore", "shm-data"};
  return caps;
}

namespace {
using Which = proto::Envelope::Body::Which;
using std::chrono::milliseconds;

milliseconds toMs(double seconds) { return milliseconds(static_cast<long>(seconds * 1000.0)); }

void fillEnergies(capnp::List<proto::NamedValue>::Builder list, const NamedValues& values) {
  for (unsigned i = 0; i < values.size(); ++i) {
    list[i].setName(values[i].first);
    list[i].setValue(values[i].second);
  }
}

}  // namespace

namespace {
// What a setup message tells the solver (the run's setup and --check read it alike).
SetupContext setupContext(proto::Setup::Reader s) {
  SetupContext c{s.getSceneFile(), s.getSceneYaml(), s.getInstance(), s.getRunDir(), s.getInputs(), s.getResuming(),
                 s.getSceneDir()};
  if (s.hasPool() && s.getPool().getSize() > 0) {
    const auto pool = s.getPool();
    if (pool.getIndex() >= pool.getSize())
      throw SolverError(proto::Error::Code::BAD_INPUT, "setup: pool worker index " + std::to_string(pool.getIndex()) +
                                                           " is not below the pool's size " +
                                                           std::to_string(pool.getSize()));
    c.poolEntry = pool.getEntry();
    c.poolIndex = pool.getIndex();
    c.poolSize = pool.getSize();
  }
  return c;
}
}  // namespace

struct SolverHost::Impl {
  Solver& solver;
  HostOptions options;
  DealerSocket data;
  std::shared_ptr<ShmLink> link;  // the shared-memory data path, when the welcome offers one
  double spinS = 0.0;
  std::atomic<double> lastFromCoupler{monotonicSeconds()};
  std::atomic<bool> busy{false};
  std::atomic<bool> stopping{false};
  std::atomic<bool> couplerLost{false};
  std::thread heartbeat;
  std::uint64_t outSeq = 0;
  std::uint64_t lastInSeq = 0;
  bool setUp = false;
  double aheadSeconds = 0.0, aheadStartedAt = 0.0;  // the last workAhead, reported with the next advance

  Impl(Solver& s, HostOptions o)
      : solver(s), options(std::move(o)), data(options.endpoint, options.instance, options.serverKey) {}

  ~Impl() {
    stopping = true;
    if (heartbeat.joinable()) heartbeat.join();
  }

  OutMessage reply(std::uint64_t replyTo, std::size_t words = 256) {
    OutMessage m = link ? link->message(words) : OutMessage(words);
    auto env = m.envelope();
    env.setSeq(++outSeq);
    env.setReplyTo(replyTo);
    return m;
  }

  void sendError(std::uint64_t replyTo, proto::Error::Code code, const std::string& text,
                 bool fatal = false) {
    auto m = reply(replyTo);
    auto e = m.envelope().getBody().initError();
    e.setCode(code);
    e.setMessage(text);
    e.setFatal(fatal);
    send(m);
  }

  /// Through the lane when there is one; a message that is not in it follows
  /// its "on ZeroMQ" descriptor on the socket.
  void send(const OutMessage& m) {
    if (!link || !link->post(m)) data.send(m);
  }

  /// Maps the segment the welcome names; false (told to the coupler) when it cannot.
  bool mapDataSegment(proto::Welcome::Reader w) {
    if (!w.hasDataSegment() || w.getDataSegment().size() == 0) return true;
    try {
      link = ShmLink::open(w.getDataSegment(), w.getDoorbell());
      spinS = w.getSpinS();
      return true;
    } catch (const std::exception& e) {
      const std::string why = std::string("cannot use the shared-memory data path: ") + e.what();
      log::error(why);
      sendError(0, proto::Error::Code::UNSUPPORTED, why, true);
      return false;
    }
  }

  /// The next message from the coupler within about 50 ms, by its lane.
  std::optional<Received> receiveShared() {
    waitForDoorbell(link->incomingBell(), spinS, 0.05, [this] { return link->hasIncoming(); });
    if (auto item = link->take()) {
      if (item->kind == LaneItem::Kind::message) return Received{{}, std::move(item->message), {}, item->bytes};
      if (item->kind == LaneItem::Kind::malformed)
        return Received{{}, std::nullopt, "in shared memory: " + item->error, item->bytes};
      // The next request travels on the socket: wait for it there, in order.
      while (!couplerLost && !stopping)
        if (auto r = data.receive(milliseconds(50))) return r;
      return std::nullopt;
    }
    return data.receive(milliseconds(0));  // what the coupler sends besides requests (errors)
  }

  void sendHello() {
    OutMessage m;
    auto env = m.envelope();
    env.setSeq(++outSeq);
    auto h = env.getBody().initHello();
    const auto info = solver.info();
    h.setProtocolMajor(info.protocolMajor);
    h.setProtocolMinor(info.protocolMinor);
    h.setSolverKind(info.kind);
    h.setVersion(info.version);
    h.setInstance(options.instance);
    h.setPid(static_cast<std::uint32_t>(::getpid()));
    h.setHost(thisHostName());
    auto caps = h.initCapabilities(static_cast<unsigned>(info.capabilities.size()));
    for (unsigned i = 0; i < info.capabilities.size(); ++i) caps.set(i, info.capabilities[i]);
    data.send(m);
  }

  /// Waits for the coupler's welcome; false (and a logged reason) when refused or silent.
  bool awaitWelcome() {
    const double deadline = monotonicSeconds() + options.connectTimeoutS;
    while (monotonicSeconds() < deadline) {
      auto r = data.receive(milliseconds(100));
      if (!r) continue;
      if (!r->message) {
        log::warn("dropped a malformed message while waiting for welcome: " + r->error);
        continue;
      }
      auto env = r->message->envelope();
      if (env.getBody().which() == Which::WELCOME) {
        auto w = env.getBody().getWelcome();
        if (const auto mine = solver.info().protocolMajor; w.getProtocolMajor() != mine) {
          log::error("the coupler speaks protocol " + std::to_string(w.getProtocolMajor()) + "." +
                     std::to_string(w.getProtocolMinor()) + ", this solver " + std::to_string(mine) + "." +
                     std::to_string(proto::PROTOCOL_MINOR) + " (major versions must match): leaving");
          return false;
        }
        if (w.getHeartbeatIntervalS() > 0) options.heartbeatIntervalS = w.getHeartbeatIntervalS();
        if (w.getHeartbeatTimeoutS() > 0) options.heartbeatTimeoutS = w.getHeartbeatTimeoutS();
        return mapDataSegment(w);
      }
      if (env.getBody().which() == Which::ERROR) {
        log::error(std::string("the coupler refused this solver: ") +
                   env.getBody().getError().getMessage().cStr());
        return false;
      }
      log::warn("ignored '" + bodyName(env) + "' while waiting for welcome");
    }
    log::error("no welcome from the coupler at " + options.endpoint + " within " +
               std::to_string(options.connectTimeoutS) + " s");
    return false;
  }

  void heartbeatLoop() {
    DealerSocket hb(options.endpoint, options.instance + "#hb", options.serverKey);
    double nextBeat = 0.0;
    double lostAt = 0.0;
    std::uint64_t seq = 0;
    while (!stopping) {
      const double now = monotonicSeconds();
      if (now >= nextBeat) {
        OutMessage m(64);
        auto env = m.envelope();
        env.setSeq(++seq);
        auto beat = env.getBody().initHeartbeat();
        beat.setSentAtS(now);
        beat.setBusy(busy);
        hb.send(m);
        nextBeat = now + options.heartbeatIntervalS;
      }
      if (auto r = hb.receive(toMs(std::min(options.heartbeatIntervalS, 0.1))); r)
        lastFromCoupler = monotonicSeconds();
      const double silent = monotonicSeconds() - lastFromCoupler;
      if (!couplerLost && silent > options.heartbeatTimeoutS) {
        couplerLost = true;
        lostAt = monotonicSeconds();
        log::error("the coupler went away (silent for " + std::to_string(silent) + " s); exiting");
      }
      // A computation that does not return cannot be interrupted safely: give
      // it one more timeout to finish, then leave without it.
      if (couplerLost && monotonicSeconds() - lostAt > options.heartbeatTimeoutS) std::_Exit(4);
    }
  }

  void handle(const InMessage& in) {
    auto env = in.envelope();
    const auto seq = env.getSeq();
    const auto which = env.getBody().which();
    if (which == Which::HEARTBEAT) return;
    if (seq <= lastInSeq) {
      sendError(seq, proto::Error::Code::OUT_OF_ORDER,
                "request seq " + std::to_string(seq) + " ('" + bodyName(env) +
                    "') does not follow seq " + std::to_string(lastInSeq) + "; dropped");
      return;
    }
    if (seq != lastInSeq + 1)
      log::warn("request seq jumped from " + std::to_string(lastInSeq) + " to " + std::to_string(seq));
    lastInSeq = seq;
    busy = true;
    try {
      dispatch(env);
    } catch (const SolverError& e) {
      sendError(seq, e.code(), e.what());
    } catch (const std::bad_alloc&) {
      // Sizes come from the scene (mesh divisions, particle counts, array
      // lengths): say so instead of a bare "std::bad_alloc".
      sendError(seq, which == Which::SETUP ? proto::Error::Code::BAD_INPUT : proto::Error::Code::SOLVER_FAILURE,
                "'" + bodyName(env) + "' ran out of memory: the scene asks for more than this machine holds "
                "(check its sizes: mesh divisions, particle counts, array lengths)");
    } catch (const kj::Exception& e) {
      sendError(seq, proto::Error::Code::MALFORMED,
                std::string("could not read '") + bodyName(env) + "': " + e.getDescription().cStr());
    } catch (const std::exception& e) {
      sendError(seq, proto::Error::Code::INTERNAL, std::string("'") + bodyName(env) + "' failed: " + e.what());
    }
    busy = false;
  }

  void requireSetup(proto::Envelope::Reader env) const {
    if (!setUp)
      throw SolverError(proto::Error::Code::UNEXPECTED, "'" + bodyName(env) + "' before setup");
  }

  void dispatch(proto::Envelope::Reader env) {
    const auto seq = env.getSeq();
    auto body = env.getBody();
    switch (body.which()) {
      case Which::SETUP: return onSetup(seq, body.getSetup());
      case Which::ADVANCE: requireSetup(env); return onAdvance(seq, body.getAdvance());
      case Which::FIELDS_REQUEST: requireSetup(env); return onFields(seq, body.getFieldsRequest());
      case Which::CHECKPOINT: {
        requireSetup(env);
        const std::string path = body.getCheckpoint().getPath();
        const auto bytes = solver.checkpoint(path);
        auto m = reply(seq);
        auto done = m.envelope().getBody().initCheckpointDone();
        done.setPath(path);
        done.setBytes(bytes);
        return send(m);
      }
      case Which::RESTORE: {
        requireSetup(env);
        solver.restore(body.getRestore().getPath());
        auto m = reply(seq);
        auto done = m.envelope().getBody().initRestored();
        done.setTime(solver.time());
        done.setStep(solver.step());
        return send(m);
      }
      case Which::ADOPT_CELLS: {
        requireSetup(env);
        auto m = reply(seq, solver.outputWordsHint());
        solver.adoptCells(body.getAdoptCells(), m.envelope().getBody().initCellsAdopted().initOutputs());
        return send(m);
      }
      case Which::SHUTDOWN: {
        auto m = reply(seq);
        m.envelope().getBody().setShutdownDone();
        send(m);
        stopping = true;
        return;
      }
      case Which::HELLO: case Which::WELCOME: case Which::SETUP_DONE: case Which::ADVANCED:
      case Which::FIELDS: case Which::CHECKPOINT_DONE: case Which::RESTORED: case Which::ERROR:
      case Which::SHUTDOWN_DONE: case Which::HEARTBEAT: case Which::CELLS_ADOPTED:
        throw SolverError(proto::Error::Code::UNEXPECTED,
                          "a solver does not accept '" + bodyName(env) + "' messages");
    }
    throw SolverError(proto::Error::Code::UNSUPPORTED,
                      "unknown message kind " + bodyName(env) + " (newer protocol?)");
  }

  void onSetup(std::uint64_t seq, proto::Setup::Reader s) {
    const SetupContext ctx = setupContext(s);
    auto m = reply(seq, solver.outputWordsHint());
    auto done = m.envelope().getBody().initSetupDone();
    solver.setup(ctx, done.initOutputs());
    setUp = true;
    done.setCriticalDt(solver.criticalDt());
    const auto energies = solver.energies();  // may cost an element loop: once
    fillEnergies(done.initEnergies(static_cast<unsigned>(energies.size())), energies);
    send(m);
  }

  void onAdvance(std::uint64_t seq, proto::Advance::Reader a) {
    if (a.getSteps() == 0 || !(a.getDt() > 0.0) || !std::isfinite(a.getDt()))
      throw SolverError(proto::Error::Code::BAD_INPUT,
                        "advance needs steps > 0 and a finite dt > 0 (got steps = " +
                            std::to_string(a.getSteps()) + ", dt = " + std::to_string(a.getDt()) + ")");
    AdvanceRequest req{a.getSteps(), a.getDt(), a.getTime(), a.getExchange(), a.getInputs(), std::nullopt};
    if (a.hasInputsEnd()) req.inputsEnd = a.getInputsEnd();
    auto m = reply(seq, solver.outputWordsHint());
    auto done = m.envelope().getBody().initAdvanced();
    const double start = monotonicSeconds();
    solver.advance(req, done.initOutputs());
    done.setTime(solver.time());
    done.setStep(solver.step());
    // Only when asked: a velocity-dependent (Hertz) step is a sweep over the
    // particles, and the coupler reads it on its series rows only.
    if (a.getWantCriticalDt()) done.setCriticalDt(solver.criticalDt());
    if (a.getWantEnergies()) {
      const auto energies = solver.energies();
      fillEnergies(done.initEnergies(static_cast<unsigned>(energies.size())), energies);
    }
    // Energies and the critical step are the solver's work too (sweeps over its model), not the wire's.
    done.setComputeSeconds(monotonicSeconds() - start);
    done.setComputeStartedAt(start);
    done.setAheadSeconds(aheadSeconds);
    done.setAheadStartedAt(aheadStartedAt);
    send(m);
    workAhead();
  }

  /// The solver's work ahead (Solver::workAhead), timed for the next reply.
  /// Its reply is out: a failure here cannot be answered, so it is logged,
  /// and the next request meets the solver's state as it was.
  void workAhead() {
    aheadSeconds = aheadStartedAt = 0.0;
    const double start = monotonicSeconds();
    try {
      if (!solver.workAhead()) return;
    } catch (const std::exception& e) {
      log::warn(std::string("work ahead of the next advance failed: ") + e.what());
      return;
    }
    aheadStartedAt = start;
    aheadSeconds = monotonicSeconds() - start;
  }

  void onFields(std::uint64_t seq, proto::FieldsRequest::Reader f) {
    std::vector<std::string> names;
    for (auto n : f.getNames()) names.emplace_back(n.cStr());
    auto m = reply(seq, solver.outputWordsHint());
    auto out = m.envelope().getBody().initFields();
    solver.fields(names, out.initData());
    out.setTime(solver.time());
    send(m);
  }

  int run() {
    sendHello();
    if (!awaitWelcome()) return 3;
    lastFromCoupler = monotonicSeconds();
    heartbeat = std::thread([this] { heartbeatLoop(); });
    while (!stopping) {
      auto r = link ? receiveShared() : data.receive(milliseconds(50));
      if (couplerLost) return 4;
      if (!r) continue;
      lastFromCoupler = monotonicSeconds();
      if (!r->message) {
        log::warn("malformed message from the coupler: " + r->error);
        sendError(0, proto::Error::Code::MALFORMED, "malformed message: " + r->error);
        continue;
      }
      handle(*r->message);
    }
    return 0;
  }
};

SolverHost::SolverHost(Solver& solver, HostOptions options)
    : impl_(std::make_unique<Impl>(solver, std::move(options))) {}
SolverHost::~SolverHost() = default;
int SolverHost::run() { return impl_->run(); }

namespace {
std::string readKeyFile(const std::string& path) {
  std::ifstream in(path);
  std::string key;
  if (!(in >> key)) throw std::invalid_argument("cannot read a server key from '" + path + "'");
  return key;
}

void usage(const char* argv0) {
  std::cerr << "usage: " << argv0
            << " --endpoint ENDPOINT --name INSTANCE [--connect-timeout SECONDS] [--server-key-file FILE]\n"
               "       [--log-level LEVEL]\n"
               "       "
            << argv0 << " --check SETUP_FILE\n       " << argv0
            << " --version | --capabilities\n"
               "A solver process: the coupler starts it (or you start it by hand, e.g. under srun)\n"
               "and it connects to the coupler's ENDPOINT as INSTANCE (its name in the scene).\n"
               "--check sets up from a setup message the coupler wrote (coupler check) and exits:\n"
               "0 when the solver accepts its scene section, 2 with the reason when it does not.\n";
}

// --check: the setup a run would do, from the setup message in `file`, and
// nothing else (no socket, no step). A SolverError is the user's input.
int checkSetup(Solver& solver, const std::string& file) {
  const InMessage in = InMessage::load(file);
  const auto body = in.envelope().getBody();
  if (!body.isSetup()) throw MalformedMessage("'" + file + "' holds no setup message");
  const auto s = body.getSetup();
  log::setPrefix(s.getInstance());
  capnp::MallocMessageBuilder scratch;
  try {
    solver.setup(setupContext(s), scratch.initRoot<proto::CouplingData>());
  } catch (const SolverError& e) {
    std::cerr << e.what() << "\n";
    return 2;
  }
  return 0;
}
}  // namespace

int solverMain(int argc, char** argv, const std::function<std::unique_ptr<Solver>()>& factory) {
  std::signal(SIGPIPE, SIG_IGN);
  keepLargeBuffersOnHeap();
  HostOptions options;
  std::string checkFile;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
        return argv[++i];
      };
      if (arg == "--endpoint") options.endpoint = value();
      else if (arg == "--name") options.instance = value();
      else if (arg == "--connect-timeout") options.connectTimeoutS = std::stod(value());
      else if (arg == "--server-key-file") options.serverKey = readKeyFile(value());
      else if (arg == "--log-level") log::setLevel(log::parseLevel(value()));
      else if (arg == "--check") checkFile = value();
      else if (arg == "--version") { std::cout << factory()->info().version << "\n"; return 0; }
      else if (arg == "--capabilities") {
        for (const auto& c : factory()->info().capabilities) std::cout << c << "\n";
        return 0;
      } else if (arg == "--help" || arg == "-h") { usage(argv[0]); return 0; }
      else throw std::invalid_argument("unknown argument '" + arg + "'");
    }
    if (checkFile.empty() && (options.endpoint.empty() || options.instance.empty()))
      throw std::invalid_argument("--endpoint and --name are required");
    if (const char* key = std::getenv("COSIM_SERVER_KEY"); key && options.serverKey.empty()) options.serverKey = key;
  } catch (const std::exception& e) {
    std::cerr << argv[0] << ": " << e.what() << "\n";
    usage(argv[0]);
    return 2;
  }
  if (!checkFile.empty()) {
    try {
      return checkSetup(*factory(), checkFile);
    } catch (const std::exception& e) {
      log::error(e.what());
      return 1;
    }
  }
  log::setPrefix(options.instance);
  try {
    auto solver = factory();
    SolverHost host(*solver, options);
    return host.run();
  } catch (const std::exception& e) {
    log::error(e.what());
    return 1;
  }
}

}  // namespace cosim::wire
