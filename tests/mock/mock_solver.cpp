// mock_solver: a scriptable peer that speaks the real protocol through the
// real SolverHost. Tests use it to drive the coupler: deterministic payloads
// checked bit for bit, and scripted failures (die, freeze, stall, error, NaN).
//
// Its scene params: seed, length (doubles in the "state" array it emits),
// expect_seed/expect_length (the peer pattern it checks what it receives
// against), compute_seconds, critical_dt (critical_dt_later from exchange
// critical_dt_from on; negative ones are reported as given), and die_at /
// freeze_at / stall_at / fail_at / nan_at (an exchange number; nan_at: 0 is
// the setup reply). Besides "state" it emits "digest", "mismatches",
// "history" (a running hash of everything it has received, the state a
// checkpoint must carry: a skipped or wrong restore changes every later value) and,
// with count_critical_dt: true, "critical_dt_calls" (how often the host has
// asked it for its critical step; not checkpointed).
// Hello-time behaviour comes from the command line, before the scene is read:
// --mock-protocol-major N, --mock-kind K, --mock-capabilities a,b,c.
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include "cosim/config/config_reader.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/solver_host.hpp"
#include "mock_pattern.hpp"

namespace {
using cosim::wire::SolverError;
using Code = cosim::proto::Error::Code;

struct Script {
  std::uint64_t seed = 1;
  std::size_t length = 16;
  std::optional<std::uint64_t> expectSeed;
  std::size_t expectLength = 16;
  double computeSeconds = 0.0;
  double criticalDt = 0.0;
  double criticalDtLater = 0.0;  // 0: critical_dt throughout
  std::uint64_t criticalDtFrom = 0;
  bool countCriticalDt = false;
  std::uint64_t dieAt = 0, freezeAt = 0, stallAt = 0, failAt = 0;
  std::optional<std::uint64_t> nanAt;  // 0: the setup reply's energy
};

struct HelloOverrides {
  std::uint16_t protocolMajor = cosim::proto::PROTOCOL_MAJOR;
  std::string kind = "mock";
  std::optional<std::vector<std::string>> capabilities;
};

class MockSolver final : public cosim::wire::Solver {
 public:
  explicit MockSolver(HelloOverrides hello) : hello_(std::move(hello)) {}

  cosim::wire::SolverInfo info() const override {
    cosim::wire::SolverInfo i;
    i.kind = hello_.kind;
    i.version = "mock 1.0";
    i.protocolMajor = hello_.protocolMajor;
    i.capabilities = hello_.capabilities.value_or(cosim::wire::baseCapabilities());
    if (!hello_.capabilities) i.capabilities.push_back("arrays");
    return i;
  }

  void setup(const cosim::wire::SetupContext& ctx, cosim::proto::CouplingData::Builder out) override {
    readScript(ctx);
    exchange_ = 0;
    emit(out, {});
  }

  void advance(const cosim::wire::AdvanceRequest& req, cosim::proto::CouplingData::Builder out) override {
    exchange_ = req.exchange;
    // Scripted faults; 0 means never (advances are numbered from 1).
    if (exchange_ == script_.dieAt) std::raise(SIGKILL);
    if (exchange_ == script_.freezeAt) std::raise(SIGSTOP);
    if (exchange_ == script_.stallAt)
      for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
    if (exchange_ == script_.failAt)
      throw SolverError(Code::SOLVER_FAILURE, "scripted failure at exchange " + std::to_string(exchange_));
    if (script_.computeSeconds > 0) std::this_thread::sleep_for(std::chrono::duration<double>(script_.computeSeconds));
    time_ = req.time + req.steps * req.dt;
    step_ += req.steps;
    emit(out, req.inputs);
  }

  void fields(const std::vector<std::string>& names, cosim::proto::CouplingData::Builder out) override {
    for (const auto& n : names)
      if (n != "state") throw SolverError(Code::BAD_INPUT, "the mock has no field '" + n + "' (it offers: state)");
    const auto state = cosim::mock::pattern(script_.seed, exchange_, script_.length);
    cosim::wire::addArray(out.initArrays(1), 0, "state", 1, state);
  }

  std::uint64_t checkpoint(const std::string& path) override {
    std::ofstream f(path, std::ios::binary);
    if (!f) throw SolverError(Code::BAD_INPUT, "cannot write checkpoint '" + path + "'");
    f << "mock-checkpoint 2\n" << exchange_ << " " << step_ << " " << std::hexfloat << time_ << " " << energy_ << " "
      << history_ << "\n";
    return static_cast<std::uint64_t>(f.tellp());
  }

  void restore(const std::string& path) override {
    std::ifstream f(path);
    std::string magic;
    int version = 0;
    if (!(f >> magic >> version) || magic != "mock-checkpoint" || version != 2)
      throw SolverError(Code::BAD_INPUT, "'" + path + "' is not a mock checkpoint (version 2)");
    std::string t, e;
    if (!(f >> exchange_ >> step_ >> t >> e >> history_))
      throw SolverError(Code::BAD_INPUT, "'" + path + "' is truncated");
    time_ = std::strtod(t.c_str(), nullptr);
    energy_ = std::strtod(e.c_str(), nullptr);
  }

  double time() const override { return time_; }
  std::uint64_t step() const override { return step_; }
  double criticalDt() const override {
    ++criticalDtCalls_;
    return script_.criticalDtLater != 0.0 && exchange_ >= script_.criticalDtFrom ? script_.criticalDtLater
                                                                                  : script_.criticalDt;
  }
  cosim::wire::NamedValues energies() const override { return {{"kinetic", energy_}}; }
  std::size_t outputWordsHint() const override { return script_.length + 256; }

 private:
  void readScript(const cosim::wire::SetupContext& ctx) {
    try {
      const auto params = cosim::config::solverParams(ctx.sceneYaml, ctx.sceneFile, ctx.instance);
      cosim::config::Diagnostics diag(ctx.sceneFile);
      cosim::config::MapReader m(params, "solvers." + ctx.instance + ".params", diag);
      const long big = 1L << 40;
      script_.seed = static_cast<std::uint64_t>(m.integer("seed", 1, 0, big));
      script_.length = static_cast<std::size_t>(m.integer("length", 16, 0, big));
      if (auto s = m.optionalInteger("expect_seed", 0, big)) script_.expectSeed = static_cast<std::uint64_t>(*s);
      script_.expectLength = static_cast<std::size_t>(m.integer("expect_length", static_cast<long>(script_.length), 0, big));
      script_.computeSeconds = m.number("compute_seconds", 0.0, cosim::config::Range::nonNegative());
      // Any finite value, so a script can report a broken (negative) step.
      script_.criticalDt = m.number("critical_dt", 0.0);
      script_.criticalDtLater = m.number("critical_dt_later", 0.0);
      script_.criticalDtFrom = static_cast<std::uint64_t>(m.integer("critical_dt_from", 0, 0, big));
      script_.countCriticalDt = m.boolean("count_critical_dt", false);
      script_.dieAt = static_cast<std::uint64_t>(m.integer("die_at", 0, 0, big));
      script_.freezeAt = static_cast<std::uint64_t>(m.integer("freeze_at", 0, 0, big));
      script_.stallAt = static_cast<std::uint64_t>(m.integer("stall_at", 0, 0, big));
      script_.failAt = static_cast<std::uint64_t>(m.integer("fail_at", 0, 0, big));
      if (auto n = m.optionalInteger("nan_at", 0, big)) script_.nanAt = static_cast<std::uint64_t>(*n);
      m.finish();
      diag.throwIfAny();
    } catch (const cosim::config::ConfigError& e) {
      throw SolverError(Code::BAD_INPUT, e.what());
    }
  }

  void emit(cosim::proto::CouplingData::Builder out, cosim::proto::CouplingData::Reader inputs) {
    const auto state = cosim::mock::pattern(script_.seed, exchange_, script_.length);
    double digest[2] = {-1.0, -1.0};
    double mismatches = 0.0;
    std::uint64_t fp = 0;
    cosim::proto::NamedArray::Reader received;
    if (cosim::wire::findArray(inputs.getArrays(), "state", received)) {
      const auto values = cosim::wire::view(received.getValues());
      fp = cosim::wire::fingerprint(values);
      digest[0] = static_cast<double>(fp >> 32);
      digest[1] = static_cast<double>(fp & 0xffffffffull);
      if (script_.expectSeed) {
        // What the peer emitted one exchange earlier (its setup output at exchange 1).
        const auto expected = cosim::mock::pattern(*script_.expectSeed, exchange_ - 1, script_.expectLength);
        if (expected.size() != values.size()) mismatches = static_cast<double>(std::max(expected.size(), values.size()));
        else
          for (std::size_t i = 0; i < values.size(); ++i)
            if (std::memcmp(&expected[i], &values[i], sizeof(double)) != 0) mismatches += 1.0;
      }
    }
    history_ = cosim::mock::splitmix64(history_ ^ fp ^ cosim::mock::splitmix64(exchange_));
    const double history[2] = {static_cast<double>(history_ >> 32), static_cast<double>(history_ & 0xffffffffull)};
    energy_ = script_.nanAt == exchange_ ? std::nan("") : 0.5 * static_cast<double>(exchange_);
    const double calls = static_cast<double>(criticalDtCalls_);
    auto arrays = out.initArrays(script_.countCriticalDt ? 5 : 4);
    cosim::wire::addArray(arrays, 0, "state", 1, state);
    cosim::wire::addArray(arrays, 1, "digest", 2, digest);
    cosim::wire::addArray(arrays, 2, "mismatches", 1, std::span<const double>(&mismatches, 1));
    cosim::wire::addArray(arrays, 3, "history", 2, history);
    if (script_.countCriticalDt)
      cosim::wire::addArray(arrays, 4, "critical_dt_calls", 1, std::span<const double>(&calls, 1));
  }

  HelloOverrides hello_;
  Script script_;
  std::uint64_t exchange_ = 0;
  std::uint64_t step_ = 0;
  double time_ = 0.0;
  double energy_ = 0.0;
  std::uint64_t history_ = 0;  // running hash of the received states (checkpointed)
  mutable std::uint64_t criticalDtCalls_ = 0;
};

std::vector<std::string> splitCommas(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  HelloOverrides hello;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--mock-protocol-major" && i + 1 < argc) hello.protocolMajor = static_cast<std::uint16_t>(std::stoi(argv[++i]));
    else if (a == "--mock-kind" && i + 1 < argc) hello.kind = argv[++i];
    else if (a == "--mock-capabilities" && i + 1 < argc) hello.capabilities = splitCommas(argv[++i]);
    else rest.push_back(argv[i]);
  }
  return cosim::wire::solverMain(static_cast<int>(rest.size()), rest.data(),
                                 [&] { return std::make_unique<MockSolver>(hello); });
}
