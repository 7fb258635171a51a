#pragma once
// The loop every solver binary runs: connect to the coupler, say hello, wait
// for welcome, dispatch requests to a Solver, answer errors instead of
// crashing, keep heartbeats going on a second socket while a request is being
// computed, and leave when the coupler says shutdown or goes silent.
#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "cosim/wire/solver.hpp"

namespace cosim::wire {

struct HostOptions {
  std::string endpoint;
  std::string instance;
  double connectTimeoutS = 60.0;      // how long to wait for the welcome
  double heartbeatIntervalS = 0.5;    // replaced by the coupler's welcome
  double heartbeatTimeoutS = 10.0;    // replaced by the coupler's welcome
  std::string serverKey;              // CurveZMQ public key of the coupler (Z85), if it uses one
};

class SolverHost {
 public:
  SolverHost(Solver& solver, HostOptions options);
  ~SolverHost();
  /// Runs until shutdown (returns 0) or until the coupler is lost or refuses
  /// the hello (returns non-zero).
  int run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// A solver binary's whole main(): parses --endpoint, --name,
/// --connect-timeout, --server-key-file, --log-level, answers --version and
/// --capabilities, then runs a SolverHost around the solver the factory makes.
/// The coupler's CurveZMQ public key comes from --server-key-file or the
/// environment variable COSIM_SERVER_KEY (how the coupler passes it to the
/// solvers it starts: not visible in `ps`).
int solverMain(int argc, char** argv, const std::function<std::unique_ptr<Solver>()>& factory);

}  // namespace cosim::wire
