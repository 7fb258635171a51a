// Hybrid PD particles in DEM (Hartmann 2022 Sec. 3): the family exclusion
// rule, driven kinematics over sub-steps, and the returned forces (contact
// and wall forces, no body force, averaged over the interval).
#include <capnp/message.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "cosim/dem/solver/dem_solver.hpp"
#include "cosim/dem/solver/hybrid_spheres.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::dem {
namespace {

TEST(HybridFamilies, SameBodyWithinTheHorizonIsExcludedOtherPairsAreNot) {
  // Body 0 on a line at spacing 1, horizon 2; body 1 interleaved.
  const std::vector<std::uint32_t> bodies{0, 0, 0, 0, 1, 1};
  const std::vector<double> x{0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0, 0.5, 0, 0, 2.5001, 0, 0};
  const std::vector<double> horizons{2.0, 2.0};
  auto pairs = familyPairs(bodies, x, horizons);
  std::sort(pairs.begin(), pairs.end());
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> expected{{0, 1}, {0, 2}, {1, 2}, {1, 3}, {2, 3}};
  // (0, 3) lies 3 apart; (4, 5) lie 2.0001 apart: beyond the horizon, contact allowed.
  EXPECT_EQ(pairs, expected);
  EXPECT_THROW(familyPairs({0, 2}, {0, 0, 0, 1, 0, 0}, horizons), std::invalid_argument);
  EXPECT_THROW(familyPairs({0, 0}, {0, 0, 0}, horizons), std::invalid_argument);
}

const char* kScene = R"(scene: {name: t}
solvers:
  - name: particles
    kind: dem
    params:
      contact: {normal: hertz, tangential: none, damping: none}
      gravity: [0, 0, -9.81]
      materials:
        - {name: grain, density: 1000, young: 1.0e7, poisson: 0.25}
        - {name: pd-surface, density: 1100, young: 2.0e7, poisson: 0.3}
      hybrid: {material: pd-surface}
      overlap_tolerance: 0.2   # the scene starts in contact: the sphere on A, E on C
      particles:
        - sphere: {position: [0, 0, 0.0195], radius: 0.01, material: grain}
      walls:
        - {type: plane, point: [0, 0, -0.0095], normal: [0, 0, 1], material: grain}
)";

// Hybrid particles of one body (horizon 0.015): A under the free sphere, B in
// A's family (overlapping A, excluded), C on the floor, E above C beyond the
// horizon (self-contact across the surface), D far away in the air.
struct Hybrids {
  std::vector<std::uint32_t> ids{10, 11, 12, 13, 14};
  std::vector<double> x{0, 0, 0, 0.012, 0, 0, 0.1, 0, 0, 0.3, 0, 0.5, 0.1, 0, 0.019};
  std::vector<double> v{0, 0, 0, 0, 0, 0, 0, 0, -1e-3, 0, 0, 0, 0, 0, 0};
  /// With the set (ids, bodies, reference positions, radii, horizons) or,
  /// as PD sends after setup, states alone in the set's order.
  void write(proto::CouplingData::Builder data, bool withSet = true) const {
    auto h = data.initHybridParticles(1)[0];
    const auto n = static_cast<unsigned>(ids.size());
    std::copy(x.begin(), x.end(), wire::view(h.initPositions(3 * n)).begin());
    std::copy(v.begin(), v.end(), wire::view(h.initVelocities(3 * n)).begin());
    h.setWantStiffness(wantStiffness);
    h.setSerial(serial);
    if (!withSet) return;
    std::copy(ids.begin(), ids.end(), wire::view(h.initIds(n)).begin());
    wire::view(h.initBodyIds(n));
    std::copy(x.begin(), x.end(), wire::view(h.initReferencePositions(3 * n)).begin());
    for (double& r : wire::view(h.initRadii(n))) r = 0.01;
    wire::view(h.initHorizons(1))[0] = 0.015;
  }
  /// The hybrid watch's partial states: set positions `indices` only, resting on full message `basis`.
  void writePartial(proto::CouplingData::Builder data, const std::vector<std::uint32_t>& indices,
                    std::uint64_t basis) const {
    auto h = data.initHybridParticles(1)[0];
    const auto m = static_cast<unsigned>(indices.size());
    auto idx = wire::view(h.initIndices(m));
    auto px = wire::view(h.initPositions(3 * m));
    auto pv = wire::view(h.initVelocities(3 * m));
    for (unsigned r = 0; r < m; ++r) {
      idx[r] = indices[r];
      for (unsigned d = 0; d < 3; ++d) {
        px[3 * r + d] = x[3 * indices[r] + d];
        pv[3 * r + d] = v[3 * indices[r] + d];
      }
    }
    h.setPartial(true);
    h.setWatchBasis(basis);
    h.setSerial(serial);
  }
  bool wantStiffness = false;
  std::uint64_t serial = 0;  // the message's name for the hybrid watch (exchange + 1)
};

struct DemRun {
  DemSolver solver;
  capnp::MallocMessageBuilder in, out;
  proto::CouplingData::Builder inputs = in.initRoot<proto::CouplingData>();
  explicit DemRun(const Hybrids& h, const std::string& scene = kScene) {
    h.write(inputs);
    solver.setup({"scene.yaml", scene, "particles", "", inputs.asReader()}, out.initRoot<proto::CouplingData>());
  }
  proto::HybridForces::Reader advance(std::uint32_t steps, double dt) {
    wire::AdvanceRequest r;
    r.steps = steps;
    r.dt = dt;
    r.inputs = inputs.asReader();
    solver.advance(r, out.initRoot<proto::CouplingData>());
    return out.getRoot<proto::CouplingData>().asReader().getHybridForces()[0];
  }
};

/// Force on the particle with PD id `id`; DEM lists loaded particles only.
Vec3 forceOn(proto::HybridForces::Reader f, std::uint32_t id) {
  const auto ids = wire::view(f.getIds());
  const auto v = wire::view(f.getForces());
  for (std::size_t q = 0; q < ids.size(); ++q)
    if (ids[q] == id) return {v[3 * q], v[3 * q + 1], v[3 * q + 2]};
  return {0.0, 0.0, 0.0};
}

/// Force on Hybrids' particle k (id 10 + k).
Vec3 forceOf(proto::HybridForces::Reader f, std::uint32_t k) { return forceOn(f, 10 + k); }

TEST(HybridSpheresInDem, ReturnsContactAndWallForcesAveragedOverTheInterval) {
  const Hybrids h;
  const double dt = 1e-5;
  const std::uint32_t steps = 20;
  DemRun run(h);
  ASSERT_EQ(run.solver.hybrids().size(), 5u);
  const auto f = run.advance(steps, dt);
  // D touches nothing and is not listed; the others in the set's order.
  const std::vector<std::uint32_t> loaded{10, 11, 12, 14};
  const auto ids = wire::view(f.getIds());
  EXPECT_EQ(std::vector<std::uint32_t>(ids.begin(), ids.end()), loaded);
  EXPECT_EQ(f.getStiffness().size(), 0u);  // not asked for
  EXPECT_EQ(f.getPositions().size(), 0u);

  // The same interval one step at a time (each exchange sends the hybrid states
  // the driven motion reaches): the returned force must be the mean (impulse / interval).
  DemRun single(h);
  std::vector<Vec3> sum(5);
  for (std::uint32_t s = 0; s < steps; ++s) {
    Hybrids moved = h;
    for (std::size_t c = 0; c < moved.x.size(); ++c) moved.x[c] += s * dt * moved.v[c];
    moved.write(single.inputs);
    const auto g = single.advance(1, dt);
    for (std::size_t k = 0; k < 5; ++k) sum[k] += forceOf(g, k);
  }
  for (std::size_t k = 0; k < 5; ++k)
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(forceOf(f, k)[d], sum[k][d] / steps, 1e-12 * (1.0 + std::abs(sum[k][d])));

  const auto& p = run.solver.system().particles;
  const auto& idx = run.solver.hybrids().particleIndices();
  // Driven: C moved with its velocity over the sub-steps (and was not integrated).
  EXPECT_NEAR(p.x[idx[2]].z, -1e-3 * steps * dt, 1e-15);
  // D touches nothing: no force, although gravity acts in DEM (PD applies it).
  EXPECT_EQ(norm(forceOf(f, 3)), 0.0);
  // B overlaps A by 8 mm but is in A's family: only the wall pushes it (up, 0.5 mm overlap).
  const Vec3 fb = forceOf(f, 1);
  EXPECT_GT(fb.z, 0.0);
  EXPECT_NEAR(fb.x, 0.0, 1e-12);
  // A: the same wall force minus the free sphere's push (the sphere sits on it).
  EXPECT_LT(forceOf(f, 0).z, fb.z);
  // E: self-contact with C across the surface (1 mm overlap, beyond the horizon) pushes it up.
  EXPECT_GT(forceOf(f, 4).z, 0.0);
}

// The default skin is a fifth of the smallest radius, hybrid particles
// included once they arrive (their own spheres 5 x larger would give a skin
// listing hybrid pairs that never touch); a given skin stays.
TEST(HybridSpheresInDem, TheDefaultSkinTakesTheHybridRadiiIn) {
  std::string scene = kScene;
  const std::string sphere = "position: [0, 0, 0.0195], radius: 0.01,";
  scene.replace(scene.find(sphere), sphere.size(), "position: [1, 1, 1], radius: 0.05,");
  const Hybrids h;
  DemRun run(h, scene);
  EXPECT_DOUBLE_EQ(run.solver.system().neighbors.skin, 0.2 * 0.01);
  const std::string tolerance = "      overlap_tolerance: 0.2";
  scene.insert(scene.find(tolerance), "      skin: 0.004\n");
  DemRun given(h, scene);
  EXPECT_DOUBLE_EQ(given.solver.system().neighbors.skin, 0.004);
}

// A DEM side of only PD bodies (H5's all-PD pack): no spheres of its own, the
// hybrid particles meet the wall and each other; the skin defaults to a fifth
// of their smallest radius. Without `hybrid:` a scene without particles is
// refused, naming the key.
TEST(HybridSpheresInDem, ASceneOfOnlyHybridParticlesRuns) {
  std::string scene = kScene;
  const auto at = scene.find("      particles:\n");
  scene.erase(at, scene.find("      walls:") - at);
  const Hybrids h;
  DemRun run(h, scene);
  EXPECT_EQ(run.solver.system().particles.size(), 5u);
  EXPECT_DOUBLE_EQ(run.solver.system().neighbors.skin, 0.2 * 0.01);
  const auto f = run.advance(20, 1e-5);
  EXPECT_GT(forceOf(f, 4).z, 0.0);                 // E on C, across the surface
  EXPECT_NEAR(forceOf(f, 0).z, forceOf(f, 1).z, 1e-9);  // A and B: the wall alone
  EXPECT_GT(forceOf(f, 1).z, 0.0);

  std::string bare = scene;
  bare.erase(bare.find("      hybrid: {material: pd-surface}\n"), 37);
  try {
    DemRun refused(h, bare);
    FAIL() << "a scene without particles or hybrid: was accepted";
  } catch (const wire::SolverError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("particles"), std::string::npos) << what;
    EXPECT_NE(what.find("hybrid"), std::string::npos) << what;
    EXPECT_NE(what.find("scene.yaml:"), std::string::npos) << what;
  }
}

TEST(HybridSpheresInDem, BadMessagesAreRefused) {
  Hybrids h;
  DemRun run(h);
  Hybrids fewer = h;
  fewer.ids.pop_back();
  fewer.x.resize(12);
  fewer.v.resize(12);
  fewer.write(run.inputs);
  EXPECT_THROW(run.advance(1, 1e-5), wire::SolverError);
  Hybrids other = h;
  other.ids[0] = 99;
  other.write(run.inputs);
  EXPECT_THROW(run.advance(1, 1e-5), wire::SolverError);
  Hybrids nan = h;
  nan.x[0] = std::nan("");
  nan.write(run.inputs);
  EXPECT_THROW(run.advance(1, 1e-5), wire::SolverError);
  // States alone must match the set's size.
  fewer.write(run.inputs, false);
  EXPECT_THROW(run.advance(1, 1e-5), wire::SolverError);
  // A first message without the set leaves DEM nothing to drive.
  DemSolver solver;
  capnp::MallocMessageBuilder in, out;
  auto inputs = in.initRoot<proto::CouplingData>();
  solver.setup({"scene.yaml", kScene, "particles", "", inputs.asReader()}, out.initRoot<proto::CouplingData>());
  h.write(inputs, false);
  wire::AdvanceRequest r;
  r.steps = 1;
  r.dt = 1e-5;
  r.inputs = inputs.asReader();
  try {
    solver.advance(r, out.initRoot<proto::CouplingData>());
    FAIL() << "states without a set were accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("must carry the set"), std::string::npos) << e.what();
  }
}

// After the first exchange PD sends states alone, in the set's order: DEM
// must drive the same particles as with the full set (bitwise the same forces).
TEST(HybridSpheresInDem, StatesWithoutTheSetDriveTheSetsParticles) {
  const Hybrids h;
  DemRun full(h), states(h);
  for (std::uint32_t s = 0; s < 5; ++s) {
    Hybrids moved = h;
    for (std::size_t c = 0; c < moved.x.size(); ++c) moved.x[c] += 1e-5 * s * moved.v[c] + 1e-6 * s * (c % 3 == 0);
    moved.write(full.inputs);
    moved.write(states.inputs, false);
    const auto a = full.advance(3, 1e-5), b = states.advance(3, 1e-5);
    ASSERT_EQ(a.getIds().size(), b.getIds().size());
    for (std::uint32_t k = 0; k < 5; ++k)
      for (int d = 0; d < 3; ++d) EXPECT_EQ(forceOf(a, k)[d], forceOf(b, k)[d]) << "step " << s << " particle " << k;
  }
  const auto& pa = full.solver.system().particles;
  const auto& pb = states.solver.system().particles;
  for (std::size_t i = 0; i < pa.size(); ++i) EXPECT_EQ(pa.x[i].x, pb.x[i].x);
  EXPECT_GT(norm(forceOf(full.advance(1, 1e-5), 0)), 0.0);
}


// The stiffness sent with the forces (pd-dem-contact `forces: linearised`):
// a small move delta of a hybrid particle pressed by a sphere and a plane
// must change its force by -K delta to first order, normal and (sticking)
// tangential parts alike; a frictionless contact has no tangential stiffness.
// Measured: 3e-6 relative (second order in delta / overlap); leaving out the
// geometric stiffness of the sphere pair (F_n / |d|) gives 1.7e-3.
std::string stiffnessScene(double friction) {
  return R"(scene: {name: t}
solvers:
  - name: particles
    kind: dem
    params:
      contact: {normal: hertz, tangential: mindlin, damping: none}
      materials:
        - {name: grain, density: 1000, young: 1.0e7, poisson: 0.25, friction: )" +
         std::to_string(friction) + R"(}
        - {name: pd-surface, density: 1100, young: 2.0e7, poisson: 0.3, friction: )" +
         std::to_string(friction) + R"(}
      hybrid: {material: pd-surface}
      overlap_tolerance: 0.2
      particles:
        - sphere: {position: [0.003, 0.002, 0.0195], radius: 0.01, material: grain, driven: true}
      walls:
        - {type: plane, point: [0, 0, -0.0098], normal: [0, 0.1, 1], material: grain}
)";
}

class HybridStiffness : public ::testing::TestWithParam<double> {};

TEST_P(HybridStiffness, PredictsTheForceChangeOfASmallMove) {
  Hybrids h;
  h.ids = {7};
  h.x = {0, 0, 0};
  h.v = {0, 0, 0};
  h.wantStiffness = true;
  DemSolver solver;
  capnp::MallocMessageBuilder in, out;
  auto inputs = in.initRoot<proto::CouplingData>();
  h.write(inputs);
  const std::string scene = stiffnessScene(GetParam());
  solver.setup({"scene.yaml", scene, "particles", "", inputs.asReader()}, out.initRoot<proto::CouplingData>());
  const double dt = 1e-6;
  const auto step = [&](const Hybrids& state) {
    state.write(inputs);
    wire::AdvanceRequest r;
    r.steps = 1;
    r.dt = dt;
    r.inputs = inputs.asReader();
    solver.advance(r, out.initRoot<proto::CouplingData>());
    return out.getRoot<proto::CouplingData>().asReader().getHybridForces()[0];
  };
  const auto f0 = step(h);
  ASSERT_EQ(f0.getStiffness().size(), 6u);
  ASSERT_EQ(f0.getPositions().size(), 3u);
  const Vec3 force0 = forceOn(f0, 7);
  ASSERT_GT(force0.z, 0.0);
  const auto k = wire::view(f0.getStiffness());
  const double kk[6] = {k[0], k[1], k[2], k[3], k[4], k[5]};
  for (int d = 0; d < 3; ++d) EXPECT_EQ(wire::view(f0.getPositions())[d], h.x[d]);
  // Move by delta over one step (driven velocity delta / dt): the tangential
  // springs grow by the tangential part of delta, the overlaps by its normal part.
  const Vec3 delta{2e-8, -1.5e-8, 3e-8};
  Hybrids moved = h;
  moved.v = {delta.x / dt, delta.y / dt, delta.z / dt};
  const Vec3 change = forceOn(step(moved), 7) - force0;
  const Vec3 predicted{-(kk[0] * delta.x + kk[3] * delta.y + kk[4] * delta.z),
                       -(kk[3] * delta.x + kk[1] * delta.y + kk[5] * delta.z),
                       -(kk[4] * delta.x + kk[5] * delta.y + kk[2] * delta.z)};
  EXPECT_LT(norm(change - predicted), 1e-4 * norm(predicted)) << "change " << change.x << " " << change.y << " "
                                                                 << change.z;
}

INSTANTIATE_TEST_SUITE_P(StickingAndFrictionless, HybridStiffness, ::testing::Values(1.0, 0.0));

// ---- The hybrid watch (hybrid_watch.hpp, pddem.capnp) ----------------------

/// The watch fields of a reply, copied out (the reply's message is reused).
struct WatchReply {
  bool watchSet = false, sendAll = false;
  std::vector<std::uint32_t> watched;
  double margin = 0.0, interval = 0.0;
  std::uint64_t basis = 0;
  explicit WatchReply(proto::HybridForces::Reader f)
      : watchSet(f.getWatchSet()), sendAll(f.getSendAll()), margin(f.getWatchMargin()),
        interval(f.getWatchInterval()), basis(f.getWatchBasis()) {
    const auto w = wire::view(f.getWatched());
    watched.assign(w.begin(), w.end());
  }
};

std::string withWatchMargin(const std::string& margin) {
  std::string scene = kScene;
  const std::string key = "hybrid: {material: pd-surface}";
  scene.replace(scene.find(key), key.size(), "hybrid: {material: pd-surface, watch_margin: " + margin + "}");
  return scene;
}

// DEM lists the hybrids within r_i + r_j + skin + m of a partner or within
// r_i + skin + m of a plane, once it knows the time a state drifts over (from
// the second message on): A, B, C, E here (skin 2 mm, m = 4 x skin), not D
// in the air. A margin reaching the floor lists D too; margin 0 lists nothing.
TEST(HybridWatch, ListsTheHybridsWithinReachFromTheSecondMessageOn) {
  Hybrids h;
  h.serial = 1;
  DemRun run(h);
  const WatchReply first(run.advance(3, 1e-5));
  EXPECT_FALSE(first.watchSet);
  EXPECT_TRUE(first.sendAll);
  h.serial = 2;
  h.write(run.inputs, false);
  const WatchReply second(run.advance(3, 1e-5));
  ASSERT_TRUE(second.watchSet);
  EXPECT_EQ(second.watched, (std::vector<std::uint32_t>{0, 1, 2, 4}));
  EXPECT_EQ(second.basis, 2u);
  EXPECT_DOUBLE_EQ(second.margin, 4.0 * 0.2 * 0.01);
  EXPECT_DOUBLE_EQ(second.interval, 3e-5);
  EXPECT_FALSE(second.sendAll);

  DemRun wide(h, withWatchMargin("0.6"));  // D is 0.5095 m above the floor
  wide.advance(3, 1e-5);
  const WatchReply all(wide.advance(3, 1e-5));
  EXPECT_EQ(all.watched, (std::vector<std::uint32_t>{0, 1, 2, 3, 4}));
  DemRun off(h, withWatchMargin("0"));
  off.advance(3, 1e-5);
  const WatchReply none(off.advance(3, 1e-5));
  EXPECT_FALSE(none.watchSet);
  EXPECT_TRUE(none.sendAll);
  try {
    DemRun bad(h, withWatchMargin("-1"));
    FAIL() << "a negative watch margin was accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("watch_margin"), std::string::npos) << e.what();
  }
}

// The watch's point: DEM computes the same forces from the watched states
// alone as from all of them. Two runs over 30 exchanges, the hybrids moving
// (with their velocities, plus small jumps); one gets every state, the other
// the watched ones whenever it may (every tenth message full): every force
// and the free sphere's position agree bit for bit, and the parked particle
// D stays where its last full state drifted it.
TEST(HybridWatch, PartialStatesGiveTheForcesOfFullStates) {
  Hybrids h;
  h.v[9] = 1e-3;  // D drifts sideways
  DemRun full(h), part(h);
  std::vector<std::uint32_t> watched;
  std::uint64_t basis = 0;
  bool sendAll = true;
  int partials = 0;
  const auto& pd = part.solver.system().particles;
  const std::uint32_t iD = part.solver.hybrids().particleIndices()[3];
  for (std::uint32_t s = 0; s < 30; ++s) {
    Hybrids moved = h;
    for (std::size_t c = 0; c < moved.x.size(); ++c) moved.x[c] += 3e-5 * s * moved.v[c] + 2e-7 * s * (c % 3 == 0);
    moved.serial = s + 2;
    moved.write(full.inputs, false);
    const bool partial = !watched.empty() && !sendAll && s % 10 != 0;
    if (partial) moved.writePartial(part.inputs, watched, basis);
    else moved.write(part.inputs, false);
    const Vec3 dBefore = pd.x[iD];
    const auto a = full.advance(3, 1e-5);
    const auto b = part.advance(3, 1e-5);
    for (std::uint32_t k = 0; k < 5; ++k)
      for (int d = 0; d < 3; ++d) EXPECT_EQ(forceOf(a, k)[d], forceOf(b, k)[d]) << "exchange " << s << " particle " << k;
    if (partial) {
      ++partials;
      EXPECT_EQ(pd.x[iD].x, dBefore.x) << "the parked particle moved at exchange " << s;
    }
    const WatchReply w(b);
    sendAll = w.sendAll;
    if (w.watchSet) watched = w.watched, basis = w.basis;
  }
  EXPECT_GE(partials, 20);
  const auto& pa = full.solver.system().particles;
  EXPECT_EQ(pa.x[0].z, pd.x[0].z);  // the free sphere
  EXPECT_EQ(pa.v[0].z, pd.v[0].z);
}

TEST(HybridWatch, PartialStatesOutsideTheWatchSetAreRefused) {
  Hybrids h;
  auto refused = [](DemRun& run, const std::string& expected) {
    try {
      run.advance(3, 1e-5);
      ADD_FAILURE() << "accepted; expected a refusal naming '" << expected << "'";
    } catch (const wire::SolverError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  DemRun early(h);
  h.writePartial(early.inputs, {0, 1, 2, 4}, 1);
  refused(early, "before this DEM process listed any watch set");
  DemRun run(h);
  run.advance(3, 1e-5);
  h.serial = 2;
  h.write(run.inputs, false);
  ASSERT_TRUE(WatchReply(run.advance(3, 1e-5)).watchSet);
  h.writePartial(run.inputs, {0, 1, 2, 4}, 1);
  refused(run, "rest on the watch set of message 1, but this DEM process holds the one of message 2");
  h.writePartial(run.inputs, {0, 1, 2}, 2);
  refused(run, "lists 4 others");
}

// DEM keeps its own particles and planes within m/2 of where they were at the
// watch set: it asks for every state (sendAll) two moves ahead, and a run that
// keeps sending partial states anyway is stopped, naming the wall.
TEST(HybridWatch, AWallPassingHalfTheMarginAsksForEveryStateAndStopsAPartialRun) {
  std::string scene = withWatchMargin("0.001");
  scene += "        - {type: plane, name: lid, point: [0, 0, 1], normal: [0, 0, -1], velocity: [0, 0, -1], "
           "material: grain}\n";
  Hybrids h;
  DemRun run(h, scene);
  run.advance(3, 1e-5);
  h.serial = 2;
  h.write(run.inputs, false);
  const WatchReply w(run.advance(3, 1e-5));
  ASSERT_TRUE(w.watchSet);
  int askedAt = -1;
  for (int s = 0; s < 40; ++s) {
    h.writePartial(run.inputs, w.watched, w.basis);
    try {
      if (WatchReply(run.advance(3, 1e-5)).sendAll && askedAt < 0) askedAt = s;
    } catch (const wire::SolverError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("wall 'lid'"), std::string::npos) << what;
      EXPECT_NE(what.find("watch_margin"), std::string::npos) << what;
      // The lid moves 3e-5 m an exchange from 3e-5 m at the watch set: past 5e-4 m at the 16th.
      EXPECT_EQ(s, 15);
      EXPECT_GE(askedAt, 0);
      EXPECT_GE(s - askedAt, 2);
      return;
    }
  }
  FAIL() << "the lid passed half the watch margin unnoticed";
}

}  // namespace
}  // namespace cosim::dem
