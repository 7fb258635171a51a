// The FemSolver adapter: scene parsing with named errors, the critical step
// guard, energies, bit-for-bit checkpoint/restore, HDF5 + XDMF snapshots.
#include <capnp/message.h>
#include <yaml-cpp/yaml.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "cosim/fem/solver/fem_solver.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::fem {
namespace {

std::string scene(const std::string& integrator, const std::string& extra = "") {
  return R"(scene: test
solvers:
  - name: other
    kind: dem
    params: {}
  - name: beam
    kind: fem
    params:
      mesh:
        box: {min: [0, 0, 0], max: [0.8, 12, 0.8], divisions: [2, 15, 2]}
      material: {model: st-venant-kirchhoff, E: 1.0e8, nu: 0.0, density: 1000}
      formulation: incompatible-modes
      sets:
        clamp: {box: {min: [-1, -0.01, -1], max: [2, 0.01, 2]}}
      boundary:
        - {set: clamp, dofs: [x, y, z], value: 0.0}
      loads:
        - {set: ymax, traction: [0, 0, -156.25]}
      integrator: )" + integrator + "\n" + extra;
}

struct Harness {
  capnp::MallocMessageBuilder inMsg, outMsg;
  proto::CouplingData::Builder in = inMsg.initRoot<proto::CouplingData>();
  proto::CouplingData::Builder out = outMsg.initRoot<proto::CouplingData>();
  void setup(FemSolver& s, const std::string& yaml, const std::string& runDir = "") {
    wire::SetupContext c{"scene.yaml", yaml, "beam", runDir, in.asReader()};
    s.setup(c, out);
  }
  void advance(FemSolver& s, std::uint32_t steps, double dt) {
    wire::AdvanceRequest r;
    r.steps = steps;
    r.dt = dt;
    r.inputs = in.asReader();
    s.advance(r, out);
  }
};

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const wire::SolverError& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(FemSolverAdapter, StaticCantileverThroughTheScene) {
  FemSolver s;
  Harness h;
  h.setup(s, scene("{type: static}"));
  h.advance(s, 1, 1.0);
  double tip = 0.0;
  const auto& nodes = s.model().mesh().nodeSet("ymax");
  for (Index n : nodes) tip += -s.state().u[3 * n + 2] / static_cast<double>(nodes.size());
  const double ref = 100.0 * 1728.0 / (3.0 * 1e8 * 0.8 * 0.8 * 0.8 * 0.8 / 12.0) + 100.0 * 12.0 / (5.0 / 6.0 * 5e7 * 0.64);
  std::printf("[solver static] tip %.6e m, Timoshenko %.6e m\n", tip, ref);
  EXPECT_LT(std::abs(tip - ref) / ref, 0.02);
  const auto e = s.energies();
  ASSERT_EQ(e.size(), 5u);
  EXPECT_GT(e[1].second, 0.0);
  EXPECT_EQ(e[3].first, "viscous_dissipated");
}

TEST(FemSolverAdapter, PeriodicKeyTiesOppositeFaces) {
  FemSolver s;
  Harness h;
  // The beam tied periodically across x (faces 0.8 apart) with a jump in z.
  h.setup(s, scene("{type: static}", "      periodic:\n        - {axis: x, jump: [0, 0, 1.0e-3]}\n"));
  const Model& m = s.model();
  const std::size_t xmax = m.mesh().nodeSet("xmax").size();
  // Every xmax dof is a slave, except the clamped ones, whose prescription
  // wins (both ends prescribed); on the clamp both sides are fixed.
  const std::size_t clampedXmax = 3;  // nodes of xmax on the clamp (3 through z)
  EXPECT_EQ(m.slaves().size(), 3 * xmax - 3 * clampedXmax);
  for (const SlaveDof& sd : m.slaves()) {
    const Vec3 d = m.mesh().node(static_cast<Index>(sd.dof / 3)) - m.mesh().node(static_cast<Index>(sd.master / 3));
    EXPECT_NEAR(std::abs(d[0]), 0.8, 1e-12);
    EXPECT_NEAR(d[1], 0.0, 1e-12);
  }
  h.advance(s, 1, 1.0);
  for (const SlaveDof& sd : m.slaves())
    EXPECT_NEAR(s.state().u[sd.dof] - s.state().u[sd.master], sd.jump.displacement(1.0), 1e-15);
}

TEST(FemSolverAdapter, BadPeriodicAndHourglassKeysAreNamed) {
  FemSolver s;
  Harness h;
  const std::string axis = errorOf([&] { h.setup(s, scene("{type: static}", "      periodic: [{axis: w}]\n")); });
  EXPECT_NE(axis.find("scene.yaml:20"), std::string::npos) << axis;
  EXPECT_NE(axis.find("periodic[0].axis must be x, y or z"), std::string::npos) << axis;
  const std::string unmatched = errorOf(
      [&] { h.setup(s, scene("{type: static}", "      periodic: [{min: xmin, max: xmax, offset: [0.7, 0, 0]}]\n")); });
  EXPECT_NE(unmatched.find("scene.yaml:20"), std::string::npos) << unmatched;
  EXPECT_NE(unmatched.find("periodic node"), std::string::npos) << unmatched;
  std::string viscous = scene("{type: static}", "      hourglass: {type: viscous, coefficient: 0.05}\n");
  viscous.replace(viscous.find("incompatible-modes"), 18, "one-point");
  const std::string implicit = errorOf([&] { h.setup(s, viscous); });
  EXPECT_NE(implicit.find("scene.yaml:19"), std::string::npos) << implicit;
  EXPECT_NE(implicit.find("viscous element forces (hourglass type viscous, stiffness_damping) need central-difference"), std::string::npos) << implicit;
  std::string sticky = scene("{type: central-difference}", "      hourglass: {type: sticky}\n");
  sticky.replace(sticky.find("incompatible-modes"), 18, "one-point");
  const std::string type = errorOf([&] { h.setup(s, sticky); });
  EXPECT_NE(type.find("scene.yaml:20"), std::string::npos) << type;
  EXPECT_NE(type.find("hourglass.type must be stiffness or viscous"), std::string::npos) << type;
  const std::string fullElement =
      errorOf([&] { h.setup(s, scene("{type: central-difference}", "      stiffness_damping: 1.0e-5\n")); });
  EXPECT_NE(fullElement.find("scene.yaml:20"), std::string::npos) << fullElement;
  EXPECT_NE(fullElement.find("stiffness_damping applies to formulation one-point only (formulation is incompatible-modes)"),
            std::string::npos)
      << fullElement;
  std::string negative = scene("{type: central-difference}", "      stiffness_damping: -1.0e-5\n");
  negative.replace(negative.find("incompatible-modes"), 18, "one-point");
  const std::string sign = errorOf([&] { h.setup(s, negative); });
  EXPECT_NE(sign.find("scene.yaml:20"), std::string::npos) << sign;
  EXPECT_NE(sign.find("stiffness_damping must be >= 0"), std::string::npos) << sign;
  // The scalar (old) form of the hourglass key is refused on a full element too.
  const std::string scalarHourglass =
      errorOf([&] { h.setup(s, scene("{type: central-difference}", "      hourglass: 0.05\n")); });
  EXPECT_NE(scalarHourglass.find("scene.yaml:20"), std::string::npos) << scalarHourglass;
  EXPECT_NE(scalarHourglass.find("hourglass applies to formulation one-point only (formulation is incompatible-modes)"),
            std::string::npos)
      << scalarHourglass;
}

TEST(FemSolverAdapter, InitialVelocityIsAnAffineFieldUnderThePrescribedOnes) {
  // v = v0 + L (X - origin): a homogeneous shear rate dv_x/dy plus a drift in z;
  // the clamped nodes keep v = 0 (Dirichlet wins).
  FemSolver s;
  Harness h;
  h.setup(s, scene("{type: central-difference}", "      initial_velocity: {velocity: [0, 0, 0.5], origin: [0, 1, 0], "
                                                 "gradient: {x: [0, 2.0, 0]}}\n"));
  capnp::MallocMessageBuilder msg;
  auto out = msg.initRoot<proto::CouplingData>();
  s.fields({"velocity"}, out);
  const auto v = wire::view(out.getArrays()[0].getValues());
  const auto& X = s.model().mesh().X;
  std::size_t free = 0;
  for (std::size_t n = 0; 3 * n < X.size(); ++n) {
    if (std::abs(X[3 * n + 1]) < 0.01) {  // clamped
      for (int d = 0; d < 3; ++d) EXPECT_EQ(v[3 * n + static_cast<std::size_t>(d)], 0.0);
      continue;
    }
    ++free;
    EXPECT_NEAR(v[3 * n], 2.0 * (X[3 * n + 1] - 1.0), 1e-12);
    EXPECT_EQ(v[3 * n + 1], 0.0);
    EXPECT_EQ(v[3 * n + 2], 0.5);
  }
  EXPECT_GT(free, 0u);
  const std::string bad = errorOf([&] {
    FemSolver t;
    Harness g;
    g.setup(t, scene("{type: central-difference}", "      initial_velocity: {gradient: {w: [0, 1, 0]}}\n"));
  });
  EXPECT_NE(bad.find("initial_velocity.gradient"), std::string::npos) << bad;
}

TEST(FemSolverAdapter, UnknownKeyNamesKeyAndLine) {
  FemSolver s;
  Harness h;
  const std::string msg = errorOf([&] { h.setup(s, scene("{type: static}", "      dampnig: 3\n")); });
  EXPECT_NE(msg.find("unknown key 'dampnig' in solvers[1].params"), std::string::npos) << msg;
  EXPECT_NE(msg.find("scene.yaml:20"), std::string::npos) << msg;
}

TEST(FemSolverAdapter, MissingSetAndBadIntegratorAreNamed) {
  FemSolver s;
  Harness h;
  std::string y = scene("{type: static}");
  y.replace(y.find("{set: clamp"), 11, "{set: clampp");
  const std::string msg = errorOf([&] { h.setup(s, y); });
  EXPECT_NE(msg.find("'clampp'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("boundary[0]"), std::string::npos) << msg;
  const std::string msg2 = errorOf([&] { h.setup(s, scene("{type: runge-kutta}")); });
  EXPECT_NE(msg2.find("integrator.type"), std::string::npos) << msg2;
}

// Checks inside the integrators, the material and the mesh generator are
// reported at the scene line that gave the values (the audit found bare ones).
TEST(FemSolverAdapter, IntegratorMaterialAndMeshLimitsNameTheLine) {
  auto setupError = [](const std::string& yaml) {
    FemSolver s;
    Harness h;
    return errorOf([&] { h.setup(s, yaml); });
  };
  const std::string beta = setupError(scene("{type: newmark, beta: -1}"));
  EXPECT_NE(beta.find("scene.yaml:19: solvers[1].params.integrator: newmark: need beta > 0"), std::string::npos) << beta;
  const std::string damping = setupError(scene("{type: central-difference, damping: -1}"));
  EXPECT_NE(damping.find("scene.yaml:19: solvers[1].params.integrator: central difference: damping must be >= 0"),
            std::string::npos) << damping;
  const std::string scale = setupError(scene("{type: central-difference, mass_scaling: 0}"));
  EXPECT_NE(scale.find("scene.yaml:19: solvers[1].params.integrator: mass scaling factor must be positive"),
            std::string::npos) << scale;
  std::string huge = scene("{type: central-difference}");
  huge.replace(huge.find("E: 1.0e8, nu: 0.0"), 17, "E: 1.0e308, nu: 0.45");
  const std::string overflow = setupError(huge);
  EXPECT_NE(overflow.find("scene.yaml:"), std::string::npos) << overflow;
  EXPECT_NE(overflow.find("E = 1e+308 Pa and nu = 0.45 give Lame constants beyond double range"), std::string::npos)
      << overflow;
  std::string many = scene("{type: central-difference}");
  many.replace(many.find("divisions: [2, 15, 2]"), 21, "divisions: [100000, 100000, 100000]");
  const std::string nodes = setupError(many);
  EXPECT_NE(nodes.find("scene.yaml:10: solvers[1].params.mesh.box.divisions give 1.00003e+15 nodes, more than the "
                       "4294967295 one mesh can number"),
            std::string::npos) << nodes;
}

/// The setup error of a scene (empty when it sets up), with an optional
/// weight profile sent by the coupler.
std::string setupError(const std::string& yaml, const WeightProfile* fromCoupler = nullptr) {
  FemSolver s;
  Harness h;
  if (fromCoupler) {
    auto wp = h.in.initWeightProfiles(1)[0];
    wp.setKind(fromCoupler->kind);
    wp.setAxis(static_cast<std::uint8_t>(fromCoupler->axis));
    wp.setStart(fromCoupler->start);
    wp.setEnd(fromCoupler->end);
  }
  try {
    h.setup(s, yaml);
  } catch (const wire::SolverError& e) {
    return e.what();
  }
  return "";
}

std::string withBoundary(const std::string& integrator, const std::string& entries);

#define EXPECT_MESSAGE(msg, text) EXPECT_NE((msg).find(text), std::string::npos) << (msg)

// The audit's boundary[].dofs cases: a scalar or an empty list was ignored (the
// beam ran unclamped), a map or nested list gave bare yaml-cpp text.
TEST(FemSolverAdapter, BoundaryDofsMustBeANonEmptyListOfAxes) {
  const std::string prefix = "scene.yaml:17: solvers[1].params.boundary[1].dofs";
  auto entry = [](const std::string& dofs, const std::string& kind = "displacement") {
    return withBoundary("{type: central-difference}", "        - {set: ymax, dofs: " + dofs + ", kind: " + kind + "}\n");
  };
  EXPECT_MESSAGE(setupError(entry("x")), prefix + ": expected a list of x, y, z, got 'x'");
  EXPECT_MESSAGE(setupError(entry("x", "velocity")), prefix + ": expected a list of x, y, z, got 'x'");
  EXPECT_MESSAGE(setupError(entry("[]")), prefix + ": expected a non-empty list of x, y, z, got an empty list");
  EXPECT_MESSAGE(setupError(entry("[]", "velocity")), prefix + ": expected a non-empty list of x, y, z");
  EXPECT_MESSAGE(setupError(entry("{x: 1}")), prefix + ": expected a list of x, y, z, got a map");
  EXPECT_MESSAGE(setupError(entry("[[x]]")), prefix + "[0]: expected a name, got a list (dofs is a list of x, y, z)");
  EXPECT_MESSAGE(setupError(entry("[x, w]")), prefix + " entries must be x, y or z, not 'w'");
  EXPECT_EQ(setupError(entry("[x]")), "");
}

// Entries of coupling.surfaces and keys of user maps are names; anything else
// is named instead of yaml-cpp's bare conversion text.
TEST(FemSolverAdapter, SurfaceNamesAndMapKeysMustBeNames) {
  const std::string p = "scene.yaml:20: solvers[1].params";
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      coupling: {surfaces: [{name: zmax}]}\n")),
                 p + ".coupling.surfaces[0]: expected a name, got a map (surfaces is a list of face set names)");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      coupling: {surfaces: zmax}\n")),
                 p + ".coupling.surfaces: expected a list of face set names, got 'zmax'");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      coupling: {zones: {[a]: {box: {min: [0, 0, 0], max: [1, 1, 1]}}}}\n")),
                 p + ".coupling.zones: expected a name as key, got a list");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      [a, b]: 1\n")), p + ": expected a name as key, got a list");
  std::string sets = scene("{type: static}");
  sets.replace(sets.find("clamp: {box"), 5, "{c: 1}");
  EXPECT_MESSAGE(setupError(sets), "scene.yaml:14: solvers[1].params.sets: expected a name as key, got a map");
  std::string name = scene("{type: static}");
  name.replace(name.find("name: other"), 11, "name: [other]");
  EXPECT_MESSAGE(setupError(name), "scene.yaml:3: solvers[0].name: expected a name, got a list");
  EXPECT_EQ(setupError(scene("{type: static}", "      coupling: {surfaces: [zmax]}\n")), "");
}

// A negative periodic tolerance silently dropped the tie; negative ramps were ignored.
TEST(FemSolverAdapter, PeriodicToleranceAndRampsAreChecked) {
  const std::string p = "scene.yaml:20: solvers[1].params";
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      periodic: [{axis: x, tolerance: -1}]\n")),
                 p + ".periodic[0].tolerance must be > 0");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      periodic: [{axis: x, tolerance: 0}]\n")),
                 p + ".periodic[0].tolerance must be > 0");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      periodic: [{axis: x, ramp: -1}]\n")),
                 p + ".periodic[0].ramp must be >= 0");
  EXPECT_MESSAGE(setupError(scene("{type: static}", "      load_ramp: -1\n")), p + ".load_ramp must be >= 0");
  EXPECT_MESSAGE(setupError(withBoundary("{type: static}", "        - {set: ymax, dofs: [x], value: 0.01, ramp: -1}\n")),
                 "scene.yaml:17: solvers[1].params.boundary[1].ramp must be >= 0");
  EXPECT_EQ(setupError(scene("{type: static}", "      periodic: [{axis: x, tolerance: 1.0e-6}]\n      load_ramp: 0.5\n")), "");
}

// max_iterations <= 0 and tolerance <= 0 surfaced as solver failures at the first step.
TEST(FemSolverAdapter, IterationLimitsAreCheckedAtSetup) {
  const std::string p = "scene.yaml:19: solvers[1].params.integrator";
  for (const std::string type : {"static", "dynamic-relaxation", "newmark"}) {
    EXPECT_MESSAGE(setupError(scene("{type: " + type + ", max_iterations: 0}")), p + ".max_iterations must be > 0");
    EXPECT_MESSAGE(setupError(scene("{type: " + type + ", max_iterations: -3}")), p + ".max_iterations must be > 0");
    EXPECT_MESSAGE(setupError(scene("{type: " + type + ", tolerance: 0}")), p + ".tolerance must be > 0");
    EXPECT_MESSAGE(setupError(scene("{type: " + type + ", tolerance: -1}")), p + ".tolerance must be > 0");
    EXPECT_EQ(setupError(scene("{type: " + type + ", tolerance: 1.0e-9, max_iterations: 5}")), "");
  }
}

// frequency: 1e308 and value: 1e308 gave NaN energies at setup without a key.
TEST(FemSolverAdapter, PrescriptionsBeyondDoubleRangeNameTheKey) {
  const std::string p = "scene.yaml:17: solvers[1].params.boundary[1]";
  auto entry = [](const std::string& e) { return withBoundary("{type: central-difference}", "        - {set: ymax, " + e + "}\n"); };
  EXPECT_MESSAGE(setupError(entry("dofs: [x], value: 0.01, frequency: 1e308")),
                 p + ".frequency: value x 2 pi frequency is not finite (value 0.01, frequency 1e+308 Hz)");
  EXPECT_MESSAGE(setupError(entry("dofs: [x], value: 1e300, frequency: 1e10, kind: velocity")),
                 p + ".frequency: value x 2 pi frequency is not finite");
  // incompatible modes stop at a non-finite residual; full integration reports a non-finite energy.
  EXPECT_MESSAGE(setupError(entry("dofs: [x], value: 1e308")),
                 p + ".value: a prescribed displacement of 1e+308 m: the model cannot take it (element ");
  std::string full = entry("dofs: [x], value: 1e100");
  full.replace(full.find("incompatible-modes"), 18, "full");
  EXPECT_MESSAGE(setupError(full), p + ".value: a prescribed displacement of 1e+100 m: it gives a non-finite strain energy");
  // A displacement that inverts the tip layer when applied alone is no verdict (the ramp brings the rest along).
  std::string neo = entry("dofs: [y], value: -5.0, ramp: 1.0");
  neo.replace(neo.find("st-venant-kirchhoff"), 19, "neo-hookean");
  EXPECT_EQ(setupError(neo), "");
  EXPECT_MESSAGE(setupError(entry("dofs: [x], value: 1e200, kind: velocity")),
                 p + ".value: the prescribed velocity of 1e+200 m/s gives a non-finite kinetic energy");
  EXPECT_MESSAGE(setupError(entry("dofs: [x], value: 1.0, ramp: 1e-320")), p + ".ramp: value / ramp is not a finite velocity");
  EXPECT_EQ(setupError(entry("dofs: [x], value: 0.5, ramp: 1.0e-3")), "");
}

// arlequin: in the params was not checked when the coupler sent its own profile.
TEST(FemSolverAdapter, ArlequinParamsAreCheckedWhenTheCouplerSendsAProfile) {
  const WeightProfile coupler{"linear", 1, -1.0, 13.0};
  const std::string p = "scene.yaml:20: solvers[1].params.arlequin: weight profile: ";
  for (const WeightProfile* sent : {static_cast<const WeightProfile*>(nullptr), &coupler}) {
    EXPECT_MESSAGE(setupError(scene("{type: static}", "      arlequin: {axis: y, start: 3.0, end: 3.0}\n"), sent),
                   p + "start and end must differ");
    EXPECT_MESSAGE(setupError(scene("{type: static}", "      arlequin: {kind: bogus, axis: y, start: 2, end: 4}\n"), sent),
                   p + "unknown kind 'bogus'");
    EXPECT_MESSAGE(setupError(scene("{type: static}", "      arlequin: {axis: w, start: 2, end: 4}\n"), sent),
                   "scene.yaml:20: solvers[1].params.arlequin.axis must be x, y or z");
    EXPECT_EQ(setupError(scene("{type: static}", "      arlequin: {axis: y, start: -1.0, end: 13.0}\n"), sent), "");
  }
}

TEST(FemSolverAdapter, ExplicitRefusesStepAboveCritical) {
  FemSolver s;
  Harness h;
  h.setup(s, scene("{type: central-difference}"));
  const double crit = s.criticalDt();
  ASSERT_GT(crit, 0.0);
  const std::string msg = errorOf([&] { h.advance(s, 1, 1.01 * crit); });
  EXPECT_NE(msg.find("exceeds the critical step"), std::string::npos) << msg;
  h.advance(s, 10, 0.9 * crit);
  EXPECT_EQ(s.step(), 10u);
  FemSolver forced;
  Harness h2;
  h2.setup(forced, scene("{type: central-difference, force: true}"));
  EXPECT_NO_THROW(h2.advance(forced, 1, 1.01 * crit));
}

/// The beam scene with extra boundary entries after the clamp.
std::string withBoundary(const std::string& integrator, const std::string& entries) {
  std::string y = scene(integrator);
  const std::string clamp = "        - {set: clamp, dofs: [x, y, z], value: 0.0}\n";
  y.insert(y.find(clamp) + clamp.size(), entries);
  return y;
}

TEST(FemSolverAdapter, SinusoidalBoundaryIsFollowedThroughARun) {
  // The tip face driven by two sines of 100 Hz: displacement kind in z, velocity
  // kind in x; central difference at 1e-4 s, 150 steps (1.5 periods).
  const double f = 100.0, a = 1.0e-3, vx = 0.02, dt = 1e-4, omega = 2.0 * 3.14159265358979323846 * f;
  FemSolver s;
  Harness h;
  h.setup(s, withBoundary("{type: central-difference}",
                          "        - {set: ymax, dofs: [z], value: 1.0e-3, frequency: 100}\n"
                          "        - {set: ymax, dofs: [x], value: 0.02, kind: velocity, frequency: 100}\n"));
  ASSERT_LT(dt, s.criticalDt());
  const auto& tip = s.model().mesh().nodeSet("ymax");
  ASSERT_EQ(tip.size(), 9u);
  const auto next = s.model().mesh().nodesInBox({-1, 11.19, -1}, {2, 11.21, 2}, 1e-9);
  ASSERT_EQ(next.size(), 9u);
  double maxErr = 0.0, maxNext = 0.0;
  for (int k = 1; k <= 150; ++k) {
    h.advance(s, 1, dt);
    const double t = s.state().time;
    for (Index n : tip) {
      maxErr = std::max(maxErr, std::abs(s.state().u[3 * n + 2] - a * std::sin(omega * t)));
      maxErr = std::max(maxErr, std::abs(s.state().v[3 * n + 2] - a * omega * std::cos(omega * t)));
      maxErr = std::max(maxErr, std::abs(s.state().u[3 * n] - vx * (1.0 - std::cos(omega * t)) / omega));
      maxErr = std::max(maxErr, std::abs(s.state().v[3 * n] - vx * std::sin(omega * t)));
    }
    for (Index n : next) maxNext = std::max(maxNext, std::abs(s.state().u[3 * n + 2]));
  }
  EXPECT_NEAR(s.state().time, 150 * dt, 1e-12);
  EXPECT_LT(maxErr, 1e-12);
  EXPECT_GT(maxNext, 0.1 * a);  // the layer next to the tip follows: the sine drives the beam, not just the tip values
  // Bad values name the key.
  const auto fails = [&](const std::string& entry) {
    return errorOf([&] {
      FemSolver t;
      Harness g;
      g.setup(t, withBoundary("{type: central-difference}", "        - " + entry + "\n"));
    });
  };
  const std::string negative = fails("{set: ymax, dofs: [z], value: 1.0e-3, frequency: -5}");
  EXPECT_NE(negative.find("boundary[1].frequency must be >= 0"), std::string::npos) << negative;
  const std::string nan = fails("{set: ymax, dofs: [z], value: 1.0e-3, frequency: .nan}");
  EXPECT_NE(nan.find("boundary[1].frequency must be finite"), std::string::npos) << nan;
  const std::string text = fails("{set: ymax, dofs: [z], value: 1.0e-3, frequency: fast}");
  EXPECT_NE(text.find("boundary[1].frequency must be a number"), std::string::npos) << text;
  const std::string both = fails("{set: ymax, dofs: [z], value: 1.0e-3, frequency: 10, ramp: 0.1}");
  EXPECT_NE(both.find("boundary[1].ramp cannot be combined with frequency"), std::string::npos) << both;
}

void checkpointRoundTrip(const std::string& integrator, double dt) {
  const auto dir = std::filesystem::temp_directory_path() / ("fem_ckpt_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  FemSolver a, b;
  Harness ha, hb;
  ha.setup(a, scene(integrator));
  hb.setup(b, scene(integrator));
  ha.advance(a, 20, dt);
  const std::string path = (dir / "state.bin").string();
  EXPECT_GT(a.checkpoint(path), 0u);
  ha.advance(a, 30, dt);
  b.restore(path);
  EXPECT_EQ(b.step(), 20u);
  hb.advance(b, 30, dt);
  EXPECT_EQ(a.step(), b.step());
  EXPECT_EQ(std::memcmp(&a.state().time, &b.state().time, sizeof(double)), 0);
  ASSERT_EQ(a.state().u.size(), b.state().u.size());
  EXPECT_EQ(std::memcmp(a.state().u.data(), b.state().u.data(), 8 * a.state().u.size()), 0);
  EXPECT_EQ(std::memcmp(a.state().v.data(), b.state().v.data(), 8 * a.state().v.size()), 0);
  double umax = 0.0;
  for (double u : a.state().u) umax = std::max(umax, std::abs(u));
  EXPECT_GT(umax, 0.0);
  // A NaN time (bytes 16-23, after the magic and the dof count) is refused, naming the file.
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    const double nan = std::nan("");
    f.seekp(16);
    f.write(reinterpret_cast<const char*>(&nan), 8);
  }
  try {
    b.restore(path);
    ADD_FAILURE() << "restored a NaN time";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(path + " holds a non-finite time"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(FemSolverAdapter, CheckpointRestoreIsBitForBitExplicit) { checkpointRoundTrip("{type: central-difference}", 1e-4); }
TEST(FemSolverAdapter, CheckpointRestoreIsBitForBitNewmark) { checkpointRoundTrip("{type: newmark}", 1e-3); }

TEST(FemSolverAdapter, FieldsAndSnapshots) {
  const auto dir = std::filesystem::temp_directory_path() / ("fem_out_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  FemSolver s;
  Harness h;
  h.setup(s, scene("{type: newmark}", "      output: {every: 5, file: beam.h5}\n"), dir.string());
  h.advance(s, 10, 1e-3);
  capnp::MallocMessageBuilder msg;
  auto out = msg.initRoot<proto::CouplingData>();
  s.fields({}, out);
  ASSERT_EQ(out.getArrays().size(), 3u);
  EXPECT_EQ(std::string(out.getArrays()[0].getName().cStr()), "displacement");
  EXPECT_EQ(out.getArrays()[0].getValues().size(), s.model().numDofs());
  std::ifstream x(dir / "beam.xmf");
  std::stringstream text;
  text << x.rdbuf();
  EXPECT_NE(text.str().find("TopologyType=\"Hexahedron\""), std::string::npos);
  EXPECT_NE(text.str().find("beam.h5:/snapshots/10/displacement"), std::string::npos);
  {
    auto f = cosim::io::H5File::openReadOnly(dir / "beam.h5");
    EXPECT_EQ(f.shape("/snapshots/10/stress")[1], 6u);
    EXPECT_EQ(f.shape("/mesh/topology")[0], s.model().mesh().numElements());
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cosim::fem

namespace cosim::fem {
namespace {

// Every scene in configs/fem sets up (the first solver of each).
TEST(FemSolverAdapter, ConfigsSetUp) {
  const char* src = std::getenv("COSIM_SOURCE_DIR");
  const std::filesystem::path dir = std::filesystem::path(src ? src : COSIM_FEM_SOURCE_DIR) / "configs" / "fem";
  const auto run = std::filesystem::temp_directory_path() / ("fem_cfg_" + std::to_string(::getpid()));
  std::filesystem::create_directories(run);
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    const YAML::Node root = YAML::Load(text.str());
    capnp::MallocMessageBuilder inMsg, outMsg;
    auto inputs = inMsg.initRoot<proto::CouplingData>();
    FemSolver s;
    wire::SetupContext c{entry.path().string(), text.str(), root["solvers"][0]["name"].as<std::string>(), run.string(),
                         inputs.asReader()};
    EXPECT_NO_THROW(s.setup(c, outMsg.initRoot<proto::CouplingData>())) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 3);
  std::filesystem::remove_all(run);
}

}  // namespace
}  // namespace cosim::fem

namespace cosim::fem {
namespace {

// Dynamic relaxation reaches the Newton static solution of the cantilever.
TEST(FemSolverAdapter, DynamicRelaxationMatchesStatic) {
  FemSolver relaxed, newton;
  Harness h1, h2;
  h1.setup(relaxed, scene("{type: dynamic-relaxation, tolerance: 1.0e-7}"));
  h2.setup(newton, scene("{type: static}"));
  h1.advance(relaxed, 1, 1.0);
  h2.advance(newton, 1, 1.0);
  double tipR = 0.0, tipN = 0.0;
  const auto& nodes = newton.model().mesh().nodeSet("ymax");
  for (Index n : nodes) {
    tipR -= relaxed.state().u[3 * n + 2] / static_cast<double>(nodes.size());
    tipN -= newton.state().u[3 * n + 2] / static_cast<double>(nodes.size());
  }
  std::printf("[dynamic relaxation] tip %.6e m, Newton %.6e m, difference %.3e\n", tipR, tipN, std::abs(tipR - tipN) / tipN);
  EXPECT_LT(std::abs(tipR - tipN) / tipN, 1e-3);
}

}  // namespace
}  // namespace cosim::fem

namespace cosim::fem {
namespace {

// Newmark with gamma > 1/2 and no beta takes beta = (gamma + 1/2)^2 / 4, which
// is unconditionally stable and damps the unresolved modes: a suddenly loaded
// beam stepped far above its highest mode's period stays bounded near the
// static deflection, while the same gamma with the trapezoidal beta = 1/4
// (2 beta < gamma: only conditionally stable) blows up.
double maxTipDeflection(const std::string& integrator, int steps) {
  FemSolver s;
  Harness h;
  h.setup(s, scene(integrator));
  double umax = 0.0;
  try {
    for (int k = 0; k < steps; ++k) {
      h.advance(s, 1, 2e-2);
      for (double u : s.state().u) umax = std::max(umax, std::abs(u));
    }
  } catch (const wire::SolverError&) {
    return std::numeric_limits<double>::infinity();  // non-finite state: refused by the integrator
  }
  return umax;
}

TEST(FemSolverAdapter, NewmarkGammaTakesTheStableBeta) {
  // Static tip deflection of the load case: P L^3 / (3 E I), P = 156.25 Pa x 0.64 m^2.
  const double statik = 156.25 * 0.64 * 12.0 * 12.0 * 12.0 / (3.0 * 1.0e8 * std::pow(0.8, 4) / 12.0);
  const double damped = maxTipDeflection("{type: newmark, gamma: 0.6, linear: true}", 300);
  const double unstable = maxTipDeflection("{type: newmark, gamma: 0.6, beta: 0.25, linear: true}", 300);
  std::printf("[newmark] max |u| at dt = 2e-2 s: gamma 0.6 with its default beta %.3e m, with beta 1/4 %.3e m "
              "(static tip %.3e m)\n", damped, unstable, statik);
  EXPECT_LT(damped, 2.5 * statik);
  EXPECT_GT(damped, 0.5 * statik);
  EXPECT_GT(unstable, 1e3 * statik);
}

}  // namespace
}  // namespace cosim::fem
