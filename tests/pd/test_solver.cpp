// The PdSolver adapter: scene parsing and its errors, critical step, sub-steps
// with held or interpolated inputs, hybrid particles, checkpoint/restore
// (bit-for-bit continuation), fields, energies and HDF5/XDMF snapshots.
#include <gtest/gtest.h>

#include <capnp/message.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cosim/io/h5_file.hpp"
#include "cosim/pd/pd_solver.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::pd {
namespace {

using cosim::proto::CouplingData;

std::string scene(const std::string& extraParams = "", const std::string& bodyExtra = "") {
  return "solvers:\n"
         "  - name: other\n"
         "    kind: dem\n"
         "    params: {}\n"
         "  - name: pd\n"
         "    kind: pd\n"
         "    params:\n"
         "      bodies:\n"
         "        - name: bar\n"
         "          shape: box\n"
         "          min: [0, 0, 0]\n"
         "          max: [0.012, 0.004, 0.004]\n"
         "          spacing: 0.001\n"
         "          horizon: 3\n"
         "          model: lps\n"
         "          surface_correction: true\n"
         "          material: {E: 1.0e9, nu: 0.25, rho: 1000}\n" +
         bodyExtra + extraParams;
}

cosim::wire::SetupContext context(const std::string& yaml, const std::string& runDir = "") {
  cosim::wire::SetupContext c;
  c.sceneFile = "scene.yaml";
  c.sceneYaml = yaml;
  c.instance = "pd";
  c.runDir = runDir;
  return c;
}

struct Fixture {
  capnp::MallocMessageBuilder out;
  PdSolver solver;
  explicit Fixture(const std::string& yaml, const std::string& runDir = "") {
    solver.setup(context(yaml, runDir), out.initRoot<CouplingData>());
  }
};

std::string setupError(const std::string& yaml) {
  try {
    Fixture f(yaml);
  } catch (const cosim::wire::SolverError& e) {
    return e.what();
  }
  return "";
}

// Advance with a hybrid force F (start) and optionally F1 (end) on one particle.
void advance(PdSolver& s, std::uint32_t steps, double dt, std::uint32_t id, double f0, double f1, bool end) {
  capnp::MallocMessageBuilder in0, in1, out;
  auto d0 = in0.initRoot<CouplingData>();
  auto h0 = d0.initHybridForces(1)[0];
  h0.initIds(1).set(0, id);
  h0.initForces(3).set(2, f0);
  cosim::wire::AdvanceRequest req;
  req.steps = steps;
  req.dt = dt;
  req.inputs = d0.asReader();
  if (end) {
    auto d1 = in1.initRoot<CouplingData>();
    auto h1 = d1.initHybridForces(1)[0];
    h1.initIds(1).set(0, id);
    h1.initForces(3).set(2, f1);
    req.inputsEnd = d1.asReader();
  }
  s.advance(req, out.initRoot<CouplingData>());
}

double momentumZ(PdSolver& s) {
  const auto& p = s.system().particles();
  double m = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) m += p.mass[i] * p.velocity[3 * i + 2];
  return m;
}

TEST(PdSolverSetup, HybridParticlesAndCapabilities) {
  Fixture f(scene());
  const auto caps = f.solver.info().capabilities;
  EXPECT_NE(std::find(caps.begin(), caps.end(), "hybrid-particles"), caps.end());
  EXPECT_NE(std::find(caps.begin(), caps.end(), "checkpoint"), caps.end());
  const auto out = f.out.getRoot<CouplingData>().asReader();
  ASSERT_EQ(out.getHybridParticles().size(), 1u);
  const auto h = out.getHybridParticles()[0];
  EXPECT_EQ(h.getIds().size(), 12u * 4u * 4u - 10u * 2u * 2u);  // outer layer of 12 x 4 x 4
  EXPECT_EQ(h.getPositions().size(), 3u * h.getIds().size());
  EXPECT_NEAR(h.getRadii()[0], std::cbrt(3e-9 / (4.0 * M_PI)), 1e-15);
  ASSERT_EQ(h.getHorizons().size(), 1u);
  EXPECT_NEAR(h.getHorizons()[0], 3e-3, 1e-15);
  EXPECT_GT(f.solver.criticalDt(), 0.0);
  // After an advance: states alone, in the set's order (pddem.capnp).
  const auto id = h.getIds()[5];
  capnp::MallocMessageBuilder in, after;
  auto d = in.initRoot<CouplingData>();
  auto hf = d.initHybridForces(1)[0];
  hf.initIds(1).set(0, id);
  hf.initForces(3).set(2, 1.0);
  cosim::wire::AdvanceRequest req;
  req.steps = 1;
  req.dt = 0.5 * f.solver.criticalDt();
  req.inputs = d.asReader();
  f.solver.advance(req, after.initRoot<CouplingData>());
  const auto s = after.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  EXPECT_EQ(s.getIds().size() + s.getBodyIds().size() + s.getReferencePositions().size() + s.getRadii().size() +
                s.getHorizons().size(),
            0u);
  ASSERT_EQ(s.getPositions().size(), h.getPositions().size());
  ASSERT_EQ(s.getVelocities().size(), h.getVelocities().size());
  // The pushed particle is the set's sixth: the force entered after the
  // drift (HybridVelocityIsTheNextDrift), so it has not moved yet but will.
  EXPECT_GT(s.getVelocities()[3 * 5 + 2], 0.0);
  EXPECT_EQ(s.getPositions()[3 * 5 + 2], h.getPositions()[3 * 5 + 2]);
  EXPECT_EQ(s.getVelocities()[3 * 6 + 2], 0.0);
}

TEST(PdSolverSetup, BadInputNamesKeyAndLine) {
  auto msg = setupError(scene("", "          colour: red\n"));
  EXPECT_NE(msg.find("scene.yaml:18: unknown key 'colour' in body"), std::string::npos) << msg;
  msg = setupError(scene("      speed: 3\n"));
  EXPECT_NE(msg.find("scene.yaml:18: unknown key 'speed' in params"), std::string::npos) << msg;
  msg = setupError(scene("      critical_step: sideways\n"));
  EXPECT_NE(msg.find("scene.yaml:18: 'critical_step' must be rule or measured"), std::string::npos) << msg;
  std::string s = scene();
  s.replace(s.find("spacing: 0.001"), 14, "spacing: -0.001");
  msg = setupError(s);
  EXPECT_NE(msg.find("scene.yaml:13: 'spacing' must be positive"), std::string::npos) << msg;
  s = scene();
  s.replace(s.find("horizon: 3"), 10, "horizon: 0");
  msg = setupError(s);
  EXPECT_NE(msg.find("scene.yaml:14: 'horizon' must be positive"), std::string::npos) << msg;
  msg = setupError(scene("",
                         "        - name: second\n"
                         "          min: [0.005, 0, 0]\n"
                         "          max: [0.02, 0.004, 0.004]\n"
                         "          spacing: 0.001\n"
                         "          model: lps\n"
                         "          material: {E: 1.0e9, nu: 0.25, rho: 1000}\n"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'second' overlaps body 'bar'"), std::string::npos) << msg;
  const auto file = std::filesystem::temp_directory_path() / "pd_solver_nan_points.txt";
  std::ofstream(file) << "0.1 0.1 0.1 1e-9\n0.1 0.2 nan 1e-9\n";
  msg = setupError(scene("",
                         "        - name: cloud\n"
                         "          shape: points\n"
                         "          file: " + file.string() + "\n"
                         "          model: lps\n"
                         "          material: {E: 1.0e9, nu: 0.25, rho: 1000}\n"));
  EXPECT_NE(msg.find("body 'cloud'"), std::string::npos) << msg;
  EXPECT_NE(msg.find(file.string() + ":2"), std::string::npos) << msg;
  msg = setupError(scene("      boundary:\n        - {select: {body: nowhere}, type: fixed}\n"));
  EXPECT_NE(msg.find("nowhere"), std::string::npos) << msg;
  // K = E / (3 (1 - 2 nu)) overflows: an infinite wave speed would give a
  // critical step of 0, which the coupler reads as "no limit".
  s = scene();
  s.replace(s.find("E: 1.0e9, nu: 0.25"), 18, "E: 1.0e308, nu: 0.48");
  msg = setupError(s);
  EXPECT_NE(msg.find("scene.yaml:17: body 'bar': material E, nu, rho give a bulk modulus of inf Pa and a wave speed "
                     "of inf m/s: both must be finite and positive"),
            std::string::npos) << msg;
}

std::string withReplaced(std::string s, const std::string& from, const std::string& to) {
  s.replace(s.find(from), from.size(), to);
  return s;
}

// Lattices too large for the 32-bit particle index or the memory are refused
// before anything is allocated, naming the key to change (a horizon of 30 on
// 27000 particles used to throw std::bad_alloc inside an OpenMP region, a box
// of 1e200 m used to become one particle).
TEST(PdSolverSetup, BodyTooLargeIsRefusedNamingSpacingOrHorizon) {
  auto msg = setupError(withReplaced(scene(), "spacing: 0.001", "spacing: 1.0e-7"));
  EXPECT_NE(msg.find("scene.yaml:13: body 'bar': 'spacing' 1e-07 gives about 1.92e+14 particles"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("4294967295 a 32-bit particle index holds"), std::string::npos) << msg;
  // 300 x 100 x 100 particles fit; with horizon 100 each bonds to all others.
  auto s = withReplaced(withReplaced(scene(), "spacing: 0.001", "spacing: 4.0e-5"), "horizon: 3", "horizon: 100");
  msg = setupError(s);
  EXPECT_NE(msg.find("scene.yaml:14: body 'bar': 'horizon' 100 gives about 9e+12 bonds for 3e+06 particles ("),
            std::string::npos) << msg;
  EXPECT_NE(msg.find("of memory available"), std::string::npos) << msg;
  msg = setupError(withReplaced(scene(), "max: [0.012,", "max: [1.0e200,"));
  EXPECT_NE(msg.find("scene.yaml:13: body 'bar': 'spacing' 0.001 gives about 1.6e+204 particles"), std::string::npos)
      << msg;
  msg = setupError(withReplaced(withReplaced(scene(), "max: [0.012,", "max: [1.0e308,"), "min: [0,", "min: [-1.0e308,"));
  EXPECT_NE(msg.find("scene.yaml:13: body 'bar': 'spacing' 0.001 gives about inf particles"), std::string::npos)
      << msg;
}

// One particle, or a particle with no partner within the horizon, has no
// stiffness: refused instead of running with an oversized or loose particle.
TEST(PdSolverSetup, BodyWithoutBondsIsRefused) {
  auto msg = setupError(withReplaced(scene(), "spacing: 0.001", "spacing: 1.0"));
  EXPECT_NE(msg.find("scene.yaml:9: body 'bar': 1 particle at spacing 1 (horizon 3 x spacing): a body needs at "
                     "least 2; use a 'spacing' finer than the body"),
            std::string::npos) << msg;
  msg = setupError(withReplaced(scene(), "horizon: 3", "horizon: 0.5"));
  EXPECT_NE(msg.find("scene.yaml:9: body 'bar': particle 0 at (0.0005, 0.0005, 0.0005) has no partner within the "
                     "horizon 0.0005 (0.5 x spacing 0.001, 192 particles)"),
            std::string::npos) << msg;
  msg = setupError(scene("",
                         "        - name: grain\n"
                         "          shape: sphere\n"
                         "          center: [1, 1, 1]\n"
                         "          radius: 0.0001\n"
                         "          spacing: 0.001\n"
                         "          model: lps\n"
                         "          material: {E: 1.0e9, nu: 0.25, rho: 1000}\n"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'grain': 1 particle at spacing 0.001"), std::string::npos) << msg;
  // Just above half a spacing every particle has its face neighbours.
  EXPECT_EQ(setupError(withReplaced(scene(), "horizon: 3", "horizon: 0.6")), "");
}

TEST(PdSolverSetup, CountsMustBeWholeNumbers) {
  for (const char* every : {"0.5", "1e30", "0", "-2"}) {
    const auto msg = setupError(scene(std::string("      output: {file: pd.h5, every: ") + every + "}\n"));
    EXPECT_NE(msg.find(std::string("scene.yaml:18: 'every' must be a whole number from 1 to 1000000000, got ") + every),
              std::string::npos) << msg;
  }
  for (const char* n : {"0.5", "1e30", "0"}) {
    const auto msg = setupError(scene(std::string("      quasi_static: {max_iterations: ") + n + "}\n"));
    EXPECT_NE(msg.find(std::string("scene.yaml:18: 'max_iterations' must be a whole number from 1 to 1000000000, got ") + n),
              std::string::npos) << msg;
  }
  auto msg = setupError(scene("      quasi_static: {tolerance: 0}\n"));
  EXPECT_NE(msg.find("scene.yaml:18: 'tolerance' must be positive"), std::string::npos) << msg;
  msg = setupError(scene("      quasi_static: {tolerance: 1e-4, max_iterations: 2e3}\n"));
  EXPECT_EQ(msg, "");
}

// Errors found while building the system name the line of the entry and its
// key path, not just the file.
TEST(PdSolverSetup, EntryErrorsNameLineAndKeyPath) {
  auto msg = setupError(scene("      boundary:\n"
                              "        - {select: {body: bar, min: [-1, -1, -1], max: [0.001, 1, 1]}}\n"
                              "        - {select: {body: bar, min: [5, 5, 5], max: [6, 6, 6]}, type: fixed}\n"));
  EXPECT_NE(msg.find("scene.yaml:20: boundary[1]: boundary condition selects no particle of body 'bar' in the box "
                     "[5, 5, 5] to [6, 6, 6]"),
            std::string::npos) << msg;
  msg = setupError(scene("      loads:\n"
                         "        - {select: {min: [5, 5, 5], max: [6, 6, 6]}, force: [1, 0, 0]}\n"));
  EXPECT_NE(msg.find("scene.yaml:19: loads[0]: load selects no particle in the box [5, 5, 5] to [6, 6, 6]"),
            std::string::npos) << msg;
  msg = setupError(scene("      loads:\n"
                         "        - select: {body: nowhere}\n"
                         "          force: [1, 0, 0]\n"));
  EXPECT_NE(msg.find("scene.yaml:19: select names unknown body 'nowhere'"), std::string::npos) << msg;
  msg = setupError(scene("", "          influence: banana\n"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'bar': unknown influence function 'banana' (known: constant, inverse, "
                     "gaussian)"),
            std::string::npos) << msg;
  msg = setupError(withReplaced(scene("", "          influence: inverse\n"), "model: lps", "model: pmb"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'bar': 'influence' applies to model lps only"), std::string::npos) << msg;
  // Interior particles have no normal: a normal condition on them only would do nothing.
  msg = setupError(withReplaced(scene("      boundary:\n"
                                      "        - select: {min: [0.0055, 0.0055, 0.0055], max: [0.0065, 0.0065, 0.0065]}\n"
                                      "          type: normal\n"),
                                "max: [0.012, 0.004, 0.004]", "max: [0.012, 0.012, 0.012]"));
  EXPECT_NE(msg.find("scene.yaml:19: boundary[0]: normal boundary condition selects no surface particle"),
            std::string::npos) << msg;
}

TEST(PdSolverSetup, KeysOfAnotherShapeAreRefused) {
  auto msg = setupError(scene("", "          radius: 0.1\n"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'bar': 'radius' does not apply to shape box"), std::string::npos) << msg;
  msg = setupError(scene("", "          file: points.txt\n"));
  EXPECT_NE(msg.find("scene.yaml:18: body 'bar': 'file' does not apply to shape box"), std::string::npos) << msg;
  msg = setupError(scene("",
                         "        - name: ball\n"
                         "          shape: sphere\n"
                         "          center: [1, 1, 1]\n"
                         "          radius: 0.003\n"
                         "          axis: x\n"
                         "          spacing: 0.001\n"
                         "          model: lps\n"
                         "          material: {E: 1.0e9, nu: 0.25, rho: 1000}\n"));
  EXPECT_NE(msg.find("scene.yaml:22: body 'ball': 'axis' does not apply to shape sphere"), std::string::npos) << msg;
}

// One Verlet step per request, force held: the hybrid velocity sent is the
// next drift's, v + dt/2 a with the state's forces, so a particle's next
// position is x + dt v whatever force the next request brings (the force
// enters after the drift), and DEM's driven sphere ends its step where PD's
// particle does. The old scheme (the new force in the first half kick)
// missed by dt^2/2 (G - F)/m, 1e-8 m here.
TEST(PdSolverAdvance, HybridVelocityIsTheNextDrift) {
  Fixture f(scene());
  const auto set = f.out.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  const std::uint32_t id = set.getIds()[5];
  const double dt = 0.5 * f.solver.criticalDt();
  capnp::MallocMessageBuilder out;
  auto push = [&](double fz) {
    capnp::MallocMessageBuilder in;
    auto d = in.initRoot<CouplingData>();
    auto hf = d.initHybridForces(1)[0];
    hf.initIds(1).set(0, id);
    hf.initForces(3).set(2, fz);
    cosim::wire::AdvanceRequest req;
    req.steps = 1;
    req.dt = dt;
    req.inputs = d.asReader();
    f.solver.advance(req, out.initRoot<CouplingData>());
    const auto h = out.getRoot<CouplingData>().asReader().getHybridParticles()[0];
    const auto x = cosim::wire::view(h.getPositions()), v = cosim::wire::view(h.getVelocities());
    return std::pair{std::vector<double>(x.begin(), x.end()), std::vector<double>(v.begin(), v.end())};
  };
  push(1.0);
  const auto [x1, w1] = push(1.0);
  const auto [x2, w2] = push(-3.0);
  double worst = 0.0;
  for (std::size_t k = 0; k < x1.size(); ++k) worst = std::max(worst, std::abs(x2[k] - (x1[k] + dt * w1[k])));
  EXPECT_LT(worst, 1e-17) << "largest miss of the drift, m";
  EXPECT_GT(std::abs(x2[3 * 5 + 2] - x1[3 * 5 + 2]), 1e4 * 1e-17);  // the pushed particle moved
}

// The hybrid watch (pddem.capnp, hybrid_watch.hpp): once DEM's reply lists
// the hybrids it watches for PD's last full message, PD sends their states
// alone (bitwise the states of a full message) while every hybrid stays
// within half the margin of that message's position, its drift over DEM's
// interval counted; a stale set, DEM's sendAll, or a hybrid beyond the
// margin bring every state back, and a malformed set is refused.
TEST(PdSolverAdvance, HybridStatesFollowTheWatchSet) {
  Fixture f(scene()), reference(scene());
  ASSERT_EQ(f.out.getRoot<CouplingData>().asReader().getHybridParticles()[0].getSerial(), 1u);
  const auto set = f.out.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  const std::uint32_t pushed = set.getIds()[5];
  const double dt = 0.5 * f.solver.criticalDt();
  struct Watch {
    std::uint64_t basis = 0;
    std::vector<std::uint32_t> watched;
    double margin = 0.0;
    bool sendAll = false;
  };
  capnp::MallocMessageBuilder out, refOut;
  std::uint64_t exchange = 0;
  auto advance = [&](const Watch& w) {
    capnp::MallocMessageBuilder in;
    auto d = in.initRoot<CouplingData>();
    auto hf = d.initHybridForces(1)[0];
    hf.initIds(1).set(0, pushed);
    hf.initForces(3).set(2, 5.0);
    hf.setSendAll(w.sendAll);
    if (w.basis > 0) {
      hf.setWatchSet(true);
      hf.setWatchBasis(w.basis);
      hf.setWatchMargin(w.margin);
      hf.setWatchInterval(dt);
      auto l = hf.initWatched(static_cast<unsigned>(w.watched.size()));
      for (unsigned k = 0; k < w.watched.size(); ++k) l.set(k, w.watched[k]);
    }
    cosim::wire::AdvanceRequest req;
    req.steps = 1;
    req.dt = dt;
    req.exchange = ++exchange;
    req.inputs = d.asReader();
    f.solver.advance(req, out.initRoot<CouplingData>());
    hf.setWatchSet(false);  // the reference run gets no watch set: every state
    reference.solver.advance(req, refOut.initRoot<CouplingData>());
    return out.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  };
  // DEM's set for the setup's message (serial 1): particles 2 and 5.
  auto h = advance({1, {2, 5}, 1e-3});
  EXPECT_TRUE(h.getPartial());
  EXPECT_EQ(h.getSerial(), 2u);
  EXPECT_EQ(h.getWatchBasis(), 1u);
  ASSERT_EQ(h.getIndices().size(), 2u);
  const auto full = refOut.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  EXPECT_FALSE(full.getPartial());
  for (unsigned r = 0; r < 2; ++r)
    for (unsigned d = 0; d < 3; ++d) {
      const unsigned q = h.getIndices()[r];
      EXPECT_EQ(h.getPositions()[3 * r + d], full.getPositions()[3 * q + d]);
      EXPECT_EQ(h.getVelocities()[3 * r + d], full.getVelocities()[3 * q + d]);
    }
  // DEM asks for every state: a full message (serial 3), and the set of message 1 is stale now.
  EXPECT_FALSE(advance({0, {}, 0.0, true}).getPartial());
  EXPECT_FALSE(advance({1, {2, 5}, 1e-3}).getPartial());
  // The set of message 4 (the last full one) with a margin the pushed particle
  // stays inside, then one it passes: its drift dt v is about 2e-9 m a step.
  EXPECT_TRUE(advance({4, {5}, 1e-3}).getPartial());
  EXPECT_TRUE(advance({5, {5}, 1e-11}).getPartial());  // message 5 was partial: a stale basis
  EXPECT_FALSE(advance({4, {5}, 1e-11}).getPartial());
  try {
    advance({7, {5, 2}, 1e-3});
    FAIL() << "a watched set out of order was accepted";
  } catch (const cosim::wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("watched set position"), std::string::npos) << e.what();
  }
}

// Solver::workAhead: after a one-step advance PD computes the next step's
// half kick, drift and bond forces while DEM evaluates the contact force.
// Every reply, the state, the energies, a fields reply and a checkpoint are
// bitwise those of a run that does not work ahead, also where the next
// request is not the step begun (another dt, two sub-steps, fields, a
// checkpoint: the state goes back first). A body whose bonds may break, or
// `work_ahead: false`, does not work ahead.
TEST(PdSolverAdvance, WorkAheadIsBitwiseTheStepItBegan) {
  const std::string yaml = scene("", "          velocity: [0.01, 0, -0.02]\n");
  Fixture ahead(yaml), plain(yaml);
  const auto set = ahead.out.getRoot<CouplingData>().asReader().getHybridParticles()[0];
  const std::uint32_t a = set.getIds()[3], b = set.getIds()[17];
  const double dt = 0.5 * ahead.solver.criticalDt();
  auto same = [](const std::vector<double>& x, const std::vector<double>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  capnp::MallocMessageBuilder outA, outP;
  int worked = 0;
  auto request = [&](int k, std::uint32_t steps, double step) {
    capnp::MallocMessageBuilder in;
    auto d = in.initRoot<CouplingData>();
    auto hf = d.initHybridForces(1)[0];
    auto ids = hf.initIds(2);
    ids.set(0, a);
    ids.set(1, b);
    auto f = hf.initForces(6);
    for (unsigned q = 0; q < 6; ++q) f.set(q, std::sin(0.7 * k + q) * (q % 3 == 2 ? 40.0 : 10.0));
    cosim::wire::AdvanceRequest req;
    req.steps = steps;
    req.dt = step;
    req.exchange = static_cast<std::uint64_t>(k);
    req.inputs = d.asReader();
    ahead.solver.advance(req, outA.initRoot<CouplingData>());
    plain.solver.advance(req, outP.initRoot<CouplingData>());
    const auto ha = outA.getRoot<CouplingData>().asReader().getHybridParticles()[0];
    const auto hp = outP.getRoot<CouplingData>().asReader().getHybridParticles()[0];
    ASSERT_EQ(ha.getPositions().size(), hp.getPositions().size());
    for (unsigned q = 0; q < ha.getPositions().size(); ++q) {
      ASSERT_EQ(ha.getPositions()[q], hp.getPositions()[q]) << "request " << k << ", value " << q;
      ASSERT_EQ(ha.getVelocities()[q], hp.getVelocities()[q]) << "request " << k << ", value " << q;
    }
    EXPECT_EQ(ahead.solver.energies(), plain.solver.energies()) << "request " << k;
    const auto& pa = ahead.solver.system().particles();
    const auto& pp = plain.solver.system().particles();
    EXPECT_TRUE(same(pa.displacement, pp.displacement) && same(pa.velocity, pp.velocity) &&
                same(pa.internalForce, pp.internalForce) && same(pa.externalForce, pp.externalForce))
        << "request " << k;
    worked += ahead.solver.workAhead() ? 1 : 0;
  };
  int k = 0;
  for (; k < 6; ++k) request(k, 1, dt);
  EXPECT_EQ(worked, 6);
  EXPECT_THROW(ahead.solver.energies(), cosim::wire::SolverError);  // asked with the advance, not between
  request(k++, 1, 0.5 * dt);  // another step: taken back, then stepped
  request(k++, 2, dt);        // two sub-steps, held force: the first half kick has it
  EXPECT_EQ(worked, 7);       // none after the two sub-steps
  request(k++, 1, dt);
  capnp::MallocMessageBuilder fieldsA, fieldsP;
  ahead.solver.fields({"position", "velocity", "force"}, fieldsA.initRoot<CouplingData>());
  plain.solver.fields({"position", "velocity", "force"}, fieldsP.initRoot<CouplingData>());
  const auto fa = fieldsA.getRoot<CouplingData>().asReader().getArrays();
  const auto fp = fieldsP.getRoot<CouplingData>().asReader().getArrays();
  for (unsigned q = 0; q < fa.size(); ++q) {
    const auto va = fa[q].getValues(), vp = fp[q].getValues();
    for (unsigned r = 0; r < va.size(); ++r) ASSERT_EQ(va[r], vp[r]) << fa[q].getName().cStr() << " " << r;
  }
  for (int n = 0; n < 3; ++n) request(k++, 1, dt);
  const auto dir = std::filesystem::temp_directory_path() / "pd_solver_ahead";
  std::filesystem::create_directories(dir);
  ahead.solver.checkpoint((dir / "ahead.bin").string());
  plain.solver.checkpoint((dir / "plain.bin").string());
  auto bytes = [](const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(bytes(dir / "ahead.bin"), bytes(dir / "plain.bin"));
  for (int n = 0; n < 3; ++n) request(k++, 1, dt);
  EXPECT_EQ(worked, 14);
  const auto pmb = std::string(yaml).replace(yaml.find("model: lps"), 10, "model: pmb");
  Fixture intact(pmb);
  advance(intact.solver, 1, dt, a, 1.0, 0.0, false);
  EXPECT_TRUE(intact.solver.workAhead());
  Fixture breaking(pmb + "          critical_stretch: 0.01\n");
  advance(breaking.solver, 1, dt, a, 1.0, 0.0, false);
  EXPECT_FALSE(breaking.solver.workAhead());
  Fixture off(scene("      work_ahead: false\n"));
  advance(off.solver, 1, dt, a, 1.0, 0.0, false);
  EXPECT_FALSE(off.solver.workAhead());
}

TEST(PdSolverAdvance, CriticalStepRefusedUnlessForced) {
  Fixture f(scene());
  const double crit = f.solver.criticalDt();
  try {
    advance(f.solver, 1, 1.5 * crit, 0, 0.0, 0.0, false);
    FAIL() << "dt above the critical step was accepted";
  } catch (const cosim::wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds the PD critical step"), std::string::npos) << e.what();
  }
  Fixture forced(scene("      force: true\n"));
  advance(forced.solver, 1, 1.5 * crit, 0, 0.0, 0.0, false);
  EXPECT_EQ(forced.solver.step(), 1u);
  // critical_step: measured reports the bar's own limit (above the rule) and
  // the refusal says how the step was found.
  Fixture measured(scene("      critical_step: measured\n"));
  const double limit = measured.solver.criticalDt();
  EXPECT_GT(limit, crit);
  advance(measured.solver, 1, limit, 0, 0.0, 0.0, false);
  try {
    advance(measured.solver, 1, 1.01 * limit, 0, 0.0, 0.0, false);
    FAIL() << "dt above the measured critical step was accepted";
  } catch (const cosim::wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("2 / omega_max, measured at setup"), std::string::npos) << e.what();
  }
}

// The energy balance (K + U) - (K_0 + U_0) = W stops a run whose step is above
// the stable limit long before a value is non-finite, and leaves a stable
// run alone; energy_tolerance: 0 turns it off.
struct Runaway {
  std::size_t stoppedAt = 0;  // advance (1-based) whose energies threw; 0: none
  std::string message;
  bool finite = true;
};

Runaway pushAndWatch(const std::string& extra, double dtOverCritical, std::size_t advances) {
  Fixture f(scene(extra));
  const double dt = dtOverCritical * f.solver.criticalDt();
  const auto id = f.out.getRoot<CouplingData>().asReader().getHybridParticles()[0].getIds()[0];
  Runaway r;
  for (std::size_t k = 1; k <= advances && r.stoppedAt == 0; ++k) {
    advance(f.solver, 1, dt, id, k < 20 ? 1.0 : 0.0, 0.0, false);
    try {
      f.solver.energies();
    } catch (const cosim::wire::SolverError& e) {
      r.stoppedAt = k;
      r.message = e.what();
    }
  }
  for (const double u : f.solver.system().particles().displacement) r.finite = r.finite && std::isfinite(u);
  return r;
}

TEST(PdSolverEnergyBalance, AStepAboveTheStableLimitIsStoppedWhileValuesAreFinite) {
  // This bar (delta = 3 dx) runs at 1.2 x dx / c without the check tripping in
  // 400 steps; at 1.5 x it grows from the first steps.
  const auto unstable = pushAndWatch("      force: true\n", 1.5, 400);
  std::printf("[measured] LPS bar at 1.5 x the critical step: energy check stopped it at advance %zu\n",
              unstable.stoppedAt);
  ASSERT_GT(unstable.stoppedAt, 0u) << "a run at 1.5 x the critical step was never stopped";
  EXPECT_TRUE(unstable.finite);
  EXPECT_NE(unstable.message.find("energy balance broken"), std::string::npos) << unstable.message;
  EXPECT_NE(unstable.message.find("energy_tolerance"), std::string::npos) << unstable.message;
  EXPECT_EQ(pushAndWatch("", 0.9, 2000).stoppedAt, 0u) << "a stable run was stopped";
  EXPECT_EQ(pushAndWatch("      force: true\n      energy_tolerance: 0\n", 1.5, 20).stoppedAt, 0u);
  EXPECT_NE(setupError(scene("      energy_tolerance: -1\n")).find("scene.yaml:"), std::string::npos);
  EXPECT_NE(setupError(scene("      energy_tolerance: -1\n")).find("energy_tolerance"), std::string::npos);
}

// With the energy check off, a step far above the stable limit runs until
// the state overflows: the finite check after the advance stops it, naming
// the particle and its body.
TEST(PdSolverAdvance, ANonFiniteStateIsStoppedNamingTheParticle) {
  Fixture f(scene("      force: true\n      energy_tolerance: 0\n"));
  const double dt = 3.0 * f.solver.criticalDt();
  const auto id = f.out.getRoot<CouplingData>().asReader().getHybridParticles()[0].getIds()[0];
  std::string message;
  std::size_t k = 1;
  for (; k <= 20000 && message.empty(); ++k) {
    try {
      advance(f.solver, 1, dt, id, k < 20 ? 1.0 : 0.0, 0.0, false);
    } catch (const cosim::wire::SolverError& e) {
      message = e.what();
    }
  }
  std::printf("[measured] LPS bar at 3 x the critical step, no energy check: stopped at advance %zu\n", k - 1);
  EXPECT_NE(message.find("non-finite displacement or velocity of particle"), std::string::npos) << message;
  EXPECT_NE(message.find("(body '"), std::string::npos) << message;
}

TEST(PdSolverAdvance, InputsHeldOrInterpolatedOverSubSteps) {
  // Internal forces cancel, so the body's momentum change is the impulse of
  // the hybrid force: n dt F0 when held, n dt (F0 + F1) / 2 when interpolated.
  const std::uint32_t n = 8;
  Fixture held(scene());
  const double dt = 0.5 * held.solver.criticalDt();
  const auto id = held.out.getRoot<CouplingData>().asReader().getHybridParticles()[0].getIds()[0];
  advance(held.solver, n, dt, id, 1.0, 3.0, true);
  EXPECT_NEAR(momentumZ(held.solver) / (n * dt * 1.0), 1.0, 1e-9);
  Fixture interp(scene("      inputs: interpolate\n"));
  advance(interp.solver, n, dt, id, 1.0, 3.0, true);
  EXPECT_NEAR(momentumZ(interp.solver) / (n * dt * 2.0), 1.0, 1e-9);
  EXPECT_EQ(interp.solver.step(), n);
  EXPECT_NEAR(interp.solver.time(), n * dt, 1e-18);
  // The force acts on the particle it names from the first update on.
  const auto& p = interp.solver.system().particles();
  EXPECT_GT(p.displacement[3 * id + 2], 0.0);
  // Work of the hybrid force is counted.
  const auto e = interp.solver.energies();
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[2].first, "external_work");
  EXPECT_GT(e[2].second, 0.0);
}

// A force sent with its stiffness (pd-dem-contact `forces: linearised`)
// follows its particle: after the sub-steps the external force of the particle
// is F - K (x - x_F), evaluated at its end position; a correction that would
// reverse the force leaves none (a contact cannot pull).
void advanceLinearised(PdSolver& s, std::uint32_t steps, double dt, std::uint32_t id, const double (&f)[3],
                       const double (&x)[3], const double (&k)[6]) {
  capnp::MallocMessageBuilder in, out;
  auto d = in.initRoot<CouplingData>();
  auto h = d.initHybridForces(1)[0];
  h.initIds(1).set(0, id);
  auto fl = h.initForces(3);
  auto xl = h.initPositions(3);
  auto kl = h.initStiffness(6);
  for (unsigned a = 0; a < 3; ++a) fl.set(a, f[a]), xl.set(a, x[a]);
  for (unsigned a = 0; a < 6; ++a) kl.set(a, k[a]);
  cosim::wire::AdvanceRequest req;
  req.steps = steps;
  req.dt = dt;
  req.inputs = d.asReader();
  s.advance(req, out.initRoot<CouplingData>());
}

TEST(PdSolverAdvance, LinearisedForcesFollowTheirParticle) {
  Fixture run(scene());
  const double dt = 0.5 * run.solver.criticalDt();
  const auto id = run.out.getRoot<CouplingData>().asReader().getHybridParticles()[0].getIds()[0];
  const auto& p = run.solver.system().particles();
  const double x0[3] = {p.reference[3 * id], p.reference[3 * id + 1], p.reference[3 * id + 2]};
  const double f[3] = {0.1, -0.2, 1.0};
  const double k[6] = {1e4, 2e4, 3e4, 1e3, 2e3, 3e3};
  advanceLinearised(run.solver, 8, dt, id, f, x0, k);
  const double* u = &p.displacement[3 * id];
  ASSERT_GT(u[2], 0.0);
  const double expected[3] = {f[0] - (k[0] * u[0] + k[3] * u[1] + k[4] * u[2]),
                              f[1] - (k[3] * u[0] + k[1] * u[1] + k[5] * u[2]),
                              f[2] - (k[4] * u[0] + k[5] * u[1] + k[2] * u[2])};
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(p.externalForce[3 * id + a], expected[a], 1e-12) << a;
  EXPECT_GT(std::abs(expected[2] - f[2]), 0.05);  // the correction is not negligible here
  // Evaluated 1 mm below: following it would pull the particle back.
  const double below[3] = {x0[0], x0[1], x0[2] - 1e-3};
  advanceLinearised(run.solver, 1, dt, id, f, below, k);
  for (int a = 0; a < 3; ++a) EXPECT_EQ(p.externalForce[3 * id + a], 0.0) << a;
  // Stiffness of the wrong size is refused.
  capnp::MallocMessageBuilder in, out;
  auto d = in.initRoot<CouplingData>();
  auto h = d.initHybridForces(1)[0];
  h.initIds(1).set(0, id);
  h.initForces(3);
  h.initPositions(3);
  h.initStiffness(5);
  cosim::wire::AdvanceRequest req;
  req.steps = 1;
  req.dt = dt;
  req.inputs = d.asReader();
  EXPECT_THROW(run.solver.advance(req, out.initRoot<CouplingData>()), cosim::wire::SolverError);
}

TEST(PdSolverCheckpoint, RestoreContinuesBitForBit) {
  const auto dir = std::filesystem::temp_directory_path() / "pd_solver_ckpt";
  std::filesystem::create_directories(dir);
  const auto path = (dir / "state.bin").string();
  const std::string yaml = scene("", "          velocity: [0.01, 0, 0]\n");
  Fixture a(yaml);
  const double dt = 0.5 * a.solver.criticalDt();
  advance(a.solver, 10, dt, 3, 0.5, 0.0, false);
  EXPECT_GT(a.solver.checkpoint(path), 0u);
  advance(a.solver, 10, dt, 3, 0.25, 0.0, false);
  Fixture b(yaml);
  b.solver.restore(path);
  EXPECT_EQ(b.solver.step(), 10u);
  advance(b.solver, 10, dt, 3, 0.25, 0.0, false);
  const auto& pa = a.solver.system().particles();
  const auto& pb = b.solver.system().particles();
  EXPECT_EQ(std::memcmp(pa.displacement.data(), pb.displacement.data(), pa.displacement.size() * sizeof(double)), 0);
  EXPECT_EQ(std::memcmp(pa.velocity.data(), pb.velocity.data(), pa.velocity.size() * sizeof(double)), 0);
  EXPECT_EQ(a.solver.time(), b.solver.time());
  EXPECT_EQ(a.solver.energies(), b.solver.energies());
  // A checkpoint of another setup is refused with a message, state untouched.
  Fixture c(scene("", "").replace(scene().find("0.012"), 5, "0.010"));
  try {
    c.solver.restore(path);
    FAIL() << "mismatched checkpoint accepted";
  } catch (const cosim::wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
  }
  EXPECT_EQ(c.solver.step(), 0u);
}

TEST(PdSolverFields, NamedArraysAndUnknownName) {
  Fixture f(scene());
  capnp::MallocMessageBuilder out;
  f.solver.fields({}, out.initRoot<CouplingData>());
  const auto arrays = out.getRoot<CouplingData>().asReader().getArrays();
  EXPECT_EQ(arrays.size(), PdSolver::fieldNames().size());
  const std::size_t n = f.solver.system().particles().size();
  for (const auto a : arrays) EXPECT_EQ(a.getValues().size(), n * a.getComponents()) << a.getName().cStr();
  capnp::MallocMessageBuilder out2;
  EXPECT_THROW(f.solver.fields({"temperature"}, out2.initRoot<CouplingData>()), cosim::wire::SolverError);
}

TEST(PdSolverOutput, SnapshotsWithXdmfSidecar) {
  const auto dir = std::filesystem::temp_directory_path() / "pd_solver_out";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    Fixture f(scene("      output: {file: pd.h5, every: 2}\n"), dir.string());
    const double dt = 0.5 * f.solver.criticalDt();
    for (int k = 0; k < 4; ++k) advance(f.solver, 3, dt, 0, 1.0, 0.0, false);
  }
  auto file = cosim::io::H5File::openReadOnly(dir / "pd.h5");
  EXPECT_TRUE(file.exists("/snapshots/0/position"));
  EXPECT_TRUE(file.exists("/snapshots/6/von_mises"));
  EXPECT_TRUE(file.exists("/snapshots/12/strain"));
  EXPECT_FALSE(file.exists("/snapshots/3"));
  const auto shape = file.shape("/snapshots/12/strain");
  ASSERT_EQ(shape.size(), 2u);
  EXPECT_EQ(shape[0], 12u * 4u * 4u);
  EXPECT_EQ(shape[1], 6u);
  std::ifstream xmf(dir / "pd.xmf");
  std::stringstream text;
  text << xmf.rdbuf();
  EXPECT_NE(text.str().find("TopologyType=\"Polyvertex\""), std::string::npos);
  EXPECT_NE(text.str().find("pd.h5:/snapshots/12/displacement"), std::string::npos);
  EXPECT_NE(text.str().find("Name=\"damage\""), std::string::npos);
}

TEST(PdSolverScene, WaveBarDemoSceneRuns) {
  // configs/pd/wave_bar.yaml: set up from the scene file and advance a few
  // exchanges at the scene's dt; the driven end moves, nothing blows up.
  const char* src = std::getenv("COSIM_SOURCE_DIR");
  const std::filesystem::path file =
      std::filesystem::path(src ? src : COSIM_PD_SOURCE_DIR) / "configs/pd/wave_bar.yaml";
  std::ifstream in(file);
  ASSERT_TRUE(in) << file;
  std::stringstream text;
  text << in.rdbuf();
  const auto dir = std::filesystem::temp_directory_path() / "pd_wave_bar";
  std::filesystem::create_directories(dir);
  capnp::MallocMessageBuilder out;
  PdSolver s;
  cosim::wire::SetupContext c;
  c.sceneFile = file.string();
  c.sceneYaml = text.str();
  c.instance = "bar";
  c.runDir = dir.string();
  s.setup(c, out.initRoot<CouplingData>());
  EXPECT_GT(s.criticalDt(), 5.0e-8);
  for (int k = 0; k < 20; ++k) advance(s, 1, 5.0e-8, 0, 0.0, 0.0, false);
  EXPECT_NEAR(s.system().particles().displacement[0], 1.0 * 20 * 5.0e-8, 1e-15);
  EXPECT_TRUE(std::filesystem::exists(dir / "wave_bar.h5"));
}

}  // namespace
}  // namespace cosim::pd

namespace cosim::pd {
namespace {

TEST(PdSolverQuasiStatic, RelaxationReachesTheStaticStretch) {
  // The 12 x 4 x 4 LPS bar of scene(), clamped at x = 0 and pulled by an
  // applied end load: each advance relaxes to equilibrium (short bar, so the
  // gauge sits close to both ends; 5 % tolerance).
  Fixture f(scene("      quasi_static: {tolerance: 1.0e-6}\n"
                  "      boundary:\n"
                  "        - {select: {min: [-1, -1, -1], max: [0.001, 1, 1]}, type: fixed}\n"
                  "      loads:\n"
                  "        - {select: {min: [0.011, -1, -1], max: [1, 1, 1]}, force: [16.0, 0, 0]}\n"));
  advance(f.solver, 1, 1e-7, 0, 0.0, 0.0, false);
  const auto& p = f.solver.system().particles();
  // Mean u_x at x = 3.5 mm and 8.5 mm against P / (E A), A = 16 mm^2.
  auto mean = [&](double x) {
    double s = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (std::abs(p.reference[3 * i] - x) < 1e-6) { s += p.displacement[3 * i]; ++n; }
    return s / n;
  };
  const double strain = (mean(8.5e-3) - mean(3.5e-3)) / 5e-3;
  const double expected = 16.0 / (1.0e9 * 16e-6);
  std::printf("[measured] quasi-static solver bar: strain / (P/EA) - 1 = %+.3f %%\n", 100.0 * (strain / expected - 1.0));
  EXPECT_NEAR(strain / expected, 1.0, 0.05);
  EXPECT_EQ(f.solver.step(), 1u);
}

}  // namespace
}  // namespace cosim::pd
