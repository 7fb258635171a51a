// The DemSolver adapter: scene parsing, errors, fields, the critical step,
// checkpoint/restore bit for bit, HDF5/XDMF snapshots.
#include <capnp/message.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cosim/dem/io/checkpoint.hpp"
#include "cosim/dem/measure/measures.hpp"
#include "cosim/dem/solver/dem_solver.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::dem {
namespace {

namespace fs = std::filesystem;

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path tempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("cosim_dem_test_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

struct Harness {
  capnp::MallocMessageBuilder inMsg, outMsg;
  proto::CouplingData::Builder inputs = inMsg.initRoot<proto::CouplingData>();
  proto::CouplingData::Builder outputs() { return outMsg.initRoot<proto::CouplingData>(); }

  void setup(DemSolver& s, const std::string& yaml, const std::string& file = "scene.yaml", const std::string& dir = "",
             bool resuming = false) {
    wire::SetupContext c{file, yaml, "particles", dir, inputs.asReader(), resuming};
    s.setup(c, outputs());
  }
  void advance(DemSolver& s, std::uint32_t steps, double dt) {
    wire::AdvanceRequest r;
    r.steps = steps;
    r.dt = dt;
    r.inputs = inputs.asReader();
    s.advance(r, outputs());
  }
};

std::string scene(const std::string& params) {
  return "scene: {name: t}\nsolvers:\n  - name: particles\n    kind: dem\n    params:\n" + params;
}

// A small frictional pile: random loose packing falling onto a floor.
const std::string kPile = scene(R"(
      contact: {normal: hertz, tangential: mindlin, damping: restitution}
      gravity: [0, 0, -9.81]
      materials:
        - {name: sand, density: 2600, young: 5.0e7, poisson: 0.25, restitution: 0.6, friction: 0.5}
      particles:
        - random: {min: [0, 0, 0], max: [0.02, 0.02, 0.04], radius: [0.0008, 0.0012], count: 300, seed: 3,
                   material: sand}
      walls:
        - {type: plane, point: [0, 0, 0], normal: [0, 0, 1], material: sand}
        - {type: plane, point: [0, 0, 0], normal: [1, 0, 0.2], material: sand}
)");

std::string errorOf(const std::string& yaml) {
  DemSolver s;
  Harness h;
  try {
    h.setup(s, yaml, "bad.yaml");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(DemSolver, HertzCollisionSceneFromConfigs) {
  const fs::path file = fs::path(DEM_CONFIG_DIR) / "hertz_collision.yaml";
  const fs::path dir = tempDir("hertz");
  DemSolver s;
  Harness h;
  h.setup(s, readFile(file), file.string(), dir.string());
  EXPECT_GT(s.criticalDt(), 5e-8);
  h.advance(s, 4000, 5e-8);  // 200 us: the contact (59 us) is over
  const Particles& p = s.system().particles;
  const double e = (p.v[1].x - p.v[0].x) / 1.0;
  std::printf("config hertz_collision: restitution %.6f (requested 0.8)\n", e);
  EXPECT_NEAR(e, 0.8, 0.008);
  // Snapshots every 400 steps plus the initial one, with an XDMF sidecar.
  const io::H5File f = io::H5File::openReadOnly(dir / "hertz_collision.h5");
  EXPECT_TRUE(f.exists("/snapshots/4000/positions"));
  EXPECT_EQ(f.shape("/snapshots/4000/positions"), (std::vector<std::size_t>{2, 3}));
  const std::string xmf = readFile(dir / "hertz_collision.xmf");
  EXPECT_NE(xmf.find("TopologyType=\"Polyvertex\""), std::string::npos);
  EXPECT_NE(xmf.find("hertz_collision.h5:/snapshots/4000/positions"), std::string::npos);
  fs::remove_all(dir);
}

TEST(DemSolver, SettlingSceneParses) {
  const fs::path file = fs::path(DEM_CONFIG_DIR) / "settling.yaml";
  DemSolver s;
  Harness h;
  std::string yaml = readFile(file);
  yaml.replace(yaml.find("snapshots"), 9, "#snapshots");
  h.setup(s, yaml, file.string());
  EXPECT_EQ(s.system().particles.size(), 8000u);
  EXPECT_EQ(s.system().planes.size(), 5u);
  EXPECT_GE(s.criticalDt(), 5e-6);
  h.advance(s, 20, 5e-6);
}

TEST(DemSolver, CheckpointRestoreContinuesBitForBit) {
  const fs::path dir = tempDir("ckpt");
  DemSolver a;
  Harness h;
  h.setup(a, kPile);
  const double dt = 1e-5;
  h.advance(a, 12000, dt);  // the pile has landed: contacts with tangential history
  std::size_t withHistory = 0;
  for (const Vec3& sh : a.system().neighbors.shear) withHistory += norm2(sh) > 0;
  ASSERT_GT(withHistory, 20u);
  const std::uint64_t bytes = a.checkpoint((dir / "a.ckpt").string());
  EXPECT_GT(bytes, 1000u);
  h.advance(a, 2000, dt);

  DemSolver b;
  Harness hb;
  hb.setup(b, kPile);  // a fresh process: setup, then restore
  b.restore((dir / "a.ckpt").string());
  EXPECT_EQ(b.step(), 12000u);
  hb.advance(b, 2000, dt);
  const Particles& pa = a.system().particles;
  const Particles& pb = b.system().particles;
  ASSERT_EQ(pa.size(), pb.size());
  EXPECT_EQ(std::memcmp(pa.x.data(), pb.x.data(), pa.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(pa.v.data(), pb.v.data(), pa.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(pa.omega.data(), pb.omega.data(), pa.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(pa.q.data(), pb.q.data(), pa.size() * sizeof(Quat)), 0);
  ASSERT_EQ(a.system().neighbors.shear.size(), b.system().neighbors.shear.size());
  EXPECT_EQ(std::memcmp(a.system().neighbors.shear.data(), b.system().neighbors.shear.data(),
                        a.system().neighbors.shear.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(a.energies(), b.energies());
  std::printf("checkpoint %llu bytes; %zu contacts with history; 2000 steps after restore identical\n",
              static_cast<unsigned long long>(bytes), withHistory);
  // A corrupt file is refused with its name.
  std::ofstream((dir / "bad.ckpt").string()) << "not a checkpoint";
  try {
    b.restore((dir / "bad.ckpt").string());
    ADD_FAILURE() << "bad checkpoint accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.ckpt"), std::string::npos);
  }
  fs::remove_all(dir);
}

TEST(DemSolver, AResumedRunContinuesItsSnapshotFile) {
  // coupler run --resume: the solver keeps its snapshot file, drops what came
  // after the checkpoint and writes it again, the same bits, series and sidecar.
  const fs::path dir = tempDir("resume");
  const std::string yaml = kPile + "      snapshots: {every: 1000, file: pile.h5}\n";
  const double dt = 1e-5;
  std::string wholeXmf;
  {
    DemSolver a;
    Harness h;
    h.setup(a, yaml, "scene.yaml", dir.string());
    for (int k = 0; k < 4; ++k) h.advance(a, 500, dt);
    a.checkpoint((dir / "a.ckpt").string());
    for (int k = 0; k < 4; ++k) h.advance(a, 500, dt);
  }
  fs::copy_file(dir / "pile.h5", dir / "whole.h5");
  wholeXmf = readFile(dir / "pile.xmf");
  {
    DemSolver b;
    Harness h;
    h.setup(b, yaml, "scene.yaml", dir.string(), true);
    b.restore((dir / "a.ckpt").string());
    EXPECT_EQ(io::H5File::openReadOnly(dir / "pile.h5").readArray("/series/step").size(), 3u);  // steps 0, 1000, 2000
    for (int k = 0; k < 4; ++k) h.advance(b, 500, dt);
  }
  auto whole = io::H5File::openReadOnly(dir / "whole.h5");
  auto resumed = io::H5File::openReadOnly(dir / "pile.h5");
  EXPECT_EQ(resumed.children("/snapshots"), whole.children("/snapshots"));
  EXPECT_EQ(whole.children("/snapshots").size(), 5u);
  for (const std::string& step : whole.children("/snapshots"))
    for (const std::string array : {"positions", "velocities", "contacts/pair_forces"}) {
      const auto x = whole.readArray("/snapshots/" + step + "/" + array);
      const auto y = resumed.readArray("/snapshots/" + step + "/" + array);
      ASSERT_EQ(x.size(), y.size()) << step << " " << array;
      if (x.empty()) continue;  // a snapshot without contacts: memcmp may not see null pointers
      EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)), 0) << step << " " << array;
    }
  for (const std::string series : {"step", "time", "kinetic", "coordination"})
    EXPECT_EQ(whole.readArray("/series/" + series), resumed.readArray("/series/" + series)) << series;
  EXPECT_EQ(readFile(dir / "pile.xmf"), wholeXmf);
  fs::remove_all(dir);
}

TEST(DemSolver, FieldsAndEnergies) {
  DemSolver s;
  Harness h;
  h.setup(s, kPile);
  h.advance(s, 10, 1e-5);
  capnp::MallocMessageBuilder m;
  auto out = m.initRoot<proto::CouplingData>();
  s.fields({"positions", "radii", "energies"}, out);
  ASSERT_EQ(out.getArrays().size(), 3u);
  EXPECT_EQ(out.getArrays()[0].getValues().size(), 900u);
  EXPECT_EQ(out.getArrays()[1].getValues().size(), 300u);
  EXPECT_THROW(s.fields({"temperature"}, out), wire::SolverError);
  capnp::MallocMessageBuilder all;
  s.fields({}, all.initRoot<proto::CouplingData>());
  const auto e = s.energies();
  EXPECT_EQ(e.front().first, "kinetic");
  EXPECT_GT(e.front().second, 0.0);
}

// The critical step reuses a particle's step for the next one when mass,
// weight, radius and material repeat (the hybrid particles of a PD body); a
// smaller sphere after two equal ones must still set it, whatever the order.
TEST(DemSolver, CriticalStepIsTheSmallestWhateverTheParticleOrder) {
  const auto stepOf = [](const std::string& particles) {
    DemSolver s;
    Harness h;
    h.setup(s, scene(R"(
      contact: {normal: hertz, tangential: none, damping: none}
      materials: [{name: m, density: 2500, young: 5.0e7, poisson: 0.25}]
      particles:
)" + particles));
    return s.criticalDt();
  };
  const std::string big1 = "        - sphere: {position: [0, 0, 0], radius: 0.01, velocity: [1, 0, 0]}\n";
  const std::string big2 = "        - sphere: {position: [0.05, 0, 0], radius: 0.01}\n";
  const std::string small = "        - sphere: {position: [0.1, 0, 0], radius: 0.004}\n";
  const double smallFirst = stepOf(small + big1 + big2), smallLast = stepOf(big1 + big2 + small);
  EXPECT_GT(smallFirst, 0.0);
  EXPECT_EQ(smallLast, smallFirst);
  EXPECT_LT(smallFirst, stepOf(big1 + big2));
}

TEST(DemSolver, CriticalStepRefusedUnlessForced) {
  const std::string base = scene(R"(
      contact: {normal: linear, tangential: none, damping: none}
      materials: [{name: m, density: 1000, kn: 1000}]
      particles:
        - sphere: {position: [0, 0, 0], radius: 0.01}
        - sphere: {position: [0.021, 0, 0], radius: 0.01}
)");
  DemSolver s;
  Harness h;
  h.setup(s, base);
  // Linear law: sqrt(m*/k) with m* = m/2.
  const double m = 4.0 / 3.0 * 3.141592653589793 * 1e-6 * 1000;
  EXPECT_NEAR(s.criticalDt(), std::sqrt(0.5 * m / 1000), 1e-12);
  try {
    h.advance(s, 1, 10 * s.criticalDt());
    ADD_FAILURE() << "dt above the critical step accepted";
  } catch (const wire::SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("critical step"), std::string::npos) << e.what();
  }
  const std::string err = errorOf(base + "      dt: 1.0\n");
  EXPECT_NE(err.find("params.dt"), std::string::npos) << err;
  DemSolver forced;
  Harness hf;
  hf.setup(forced, base + "      dt: 1.0\n      force: true\n");
  hf.advance(forced, 1, 1e-3);
}

TEST(DemSolver, BadInputNamesFileKeyLineParticle) {
  // Unknown key, with its line.
  std::string e = errorOf(scene("      gravty: [0, 0, -9.81]\n      particles: [{sphere: {position: [0,0,0], radius: 1}}]\n"));
  EXPECT_NE(e.find("bad.yaml:6"), std::string::npos) << e;
  EXPECT_NE(e.find("gravty"), std::string::npos) << e;
  // Non-positive radius and density.
  e = errorOf(scene("      particles: [{sphere: {position: [0,0,0], radius: -1}}]\n"));
  EXPECT_NE(e.find("radius"), std::string::npos) << e;
  EXPECT_NE(e.find("bad.yaml:6"), std::string::npos) << e;
  e = errorOf(scene("      materials: [{name: a, density: 0}]\n      particles: [{sphere: {position: [0,0,0], radius: 1}}]\n"));
  EXPECT_NE(e.find("density"), std::string::npos) << e;
  // Overlapping particles name both.
  e = errorOf(scene("      particles:\n        - sphere: {position: [0,0,0], radius: 1}\n"
                    "        - sphere: {position: [1.5,0,0], radius: 1}\n"));
  EXPECT_NE(e.find("particles 0 and 1 overlap"), std::string::npos) << e;
  // Unknown contact law.
  e = errorOf(scene("      contact: {normal: hooke}\n      particles: [{sphere: {position: [0,0,0], radius: 1}}]\n"));
  EXPECT_NE(e.find("hooke"), std::string::npos) << e;
  EXPECT_NE(e.find("bad.yaml:6"), std::string::npos) << e;
  // NaN in a particle file names the file and line; radius <= 0 names the line.
  const fs::path dir = tempDir("files");
  std::ofstream(dir / "nan.csv") << "x,y,z,r\n0,0,0,0.1\n1,nan,0,0.1\n";
  e = errorOf(scene("      particles: [{file: {path: " + (dir / "nan.csv").string() + "}}]\n"));
  EXPECT_NE(e.find("nan.csv:3"), std::string::npos) << e;
  std::ofstream(dir / "neg.csv") << "0 0 0 0.1\n1 0 0 -0.1\n";
  e = errorOf(scene("      particles: [{file: {path: " + (dir / "neg.csv").string() + "}}]\n"));
  EXPECT_NE(e.find("neg.csv:2"), std::string::npos) << e;
  EXPECT_NE(e.find("radius"), std::string::npos) << e;
  // A mistyped number on the first line is an error, not a header line that vanishes.
  std::ofstream(dir / "typo.csv") << "0 0 0 O.1\n1 0 0 0.1\n";
  e = errorOf(scene("      particles: [{file: {path: " + (dir / "typo.csv").string() + "}}]\n"));
  EXPECT_NE(e.find("typo.csv:1: column 4: 'O.1' is not a number"), std::string::npos) << e;
  // A radius whose mass overflows names the line and says so.
  std::ofstream(dir / "huge.csv") << "0 0 0 1e300\n";
  e = errorOf(scene("      particles: [{file: {path: " + (dir / "huge.csv").string() + "}}]\n"));
  EXPECT_NE(e.find("huge.csv:1: a particle of radius 1e+300 m"), std::string::npos) << e;
  // An HDF5 /positions stored 3 x N (the right count, the wrong layout) is refused.
  {
    auto f = io::H5File::create(dir / "transposed.h5");
    const std::vector<double> x{0, 1, 0, 0, 0, 0}, r{0.1, 0.1};
    f.writeArray("/positions", x, 2);
    f.writeArray("/radii", r, 1);
  }
  e = errorOf(scene("      particles: [{file: {path: " + (dir / "transposed.h5").string() + "}}]\n"));
  EXPECT_NE(e.find("transposed.h5: /positions has shape (3 x 2), need 2 x 3"), std::string::npos) << e;
  // A good CSV file and an HDF5 file load.
  std::ofstream(dir / "ok.csv") << "# x y z r vx vy vz\n0 0 0 0.1 1 0 0\n1 0 0 0.1 0 0 0\n";
  {
    auto f = io::H5File::create(dir / "ok.h5");
    const std::vector<double> x{0, 5, 0, 1, 5, 0, 2, 5, 0}, r{0.1, 0.2, 0.3};
    f.writeArray("/positions", x, 3);
    f.writeArray("/radii", r, 1);
  }
  DemSolver s;
  Harness h;
  h.setup(s, scene("      particles:\n        - file: {path: " + (dir / "ok.csv").string() + "}\n" +
                   "        - file: {path: " + (dir / "ok.h5").string() + "}\n"));
  EXPECT_EQ(s.system().particles.size(), 5u);
  EXPECT_EQ(s.system().particles.v[0].x, 1.0);
  EXPECT_EQ(s.system().particles.radius[4], 0.3);
  // A relative particle file resolves against the scene's directory (sceneDir):
  // with --set the scene text comes from the run directory, the file does not.
  {
    DemSolver r;
    Harness hr;
    wire::SetupContext c{(dir / "run" / "scene.effective.yaml").string(),
                         scene("      particles: [{file: {path: ok.csv}}]\n"), "particles", "", hr.inputs.asReader(),
                         false, dir.string()};
    r.setup(c, hr.outputs());
    EXPECT_EQ(r.system().particles.size(), 2u);
  }
  // A missing solver entry.
  DemSolver t;
  Harness ht;
  wire::SetupContext c{"x.yaml", scene("      particles: []\n"), "nobody", "", ht.inputs.asReader()};
  EXPECT_THROW(t.setup(c, ht.outputs()), wire::SolverError);
  fs::remove_all(dir);
}

TEST(DemSolver, PeriodicCellFromScene) {
  const std::string yaml = scene(R"(
      contact: {normal: linear, tangential: none, damping: none}
      materials: [{name: m, density: 1000, kn: 10000}]
      particles:
        - lattice: {origin: [0.01, 0.01, 0.01], spacing: 0.0199, counts: [3, 3, 3], radius: 0.01}
      periodic: {cell: [[0.0597, 0, 0], [0, 0.0597, 0], [0, 0, 0.0597]], velocity_gradient: [[0, 1, 0], [0, 0, 0], [0, 0, 0]]}
      mass_damping: 0.0
      overlap_tolerance: 0.02
)");
  DemSolver s;
  Harness h;
  h.setup(s, yaml);
  EXPECT_TRUE(s.system().cell.enabled);
  EXPECT_NEAR(s.system().cell.volume(), 0.0597 * 0.0597 * 0.0597, 1e-15);
  // 27 spheres, each touching its 6 lattice neighbours across the periodic faces too.
  EXPECT_NEAR(coordinationNumber(s.system()), 6.0, 1e-12);
  h.advance(s, 100, 1e-4);
  EXPECT_NEAR(s.system().cell.h[1], 0.0597 * 100 * 1e-4, 1e-12);  // sheared: H_xy = gamma L
  capnp::MallocMessageBuilder m;
  auto out = m.initRoot<proto::CouplingData>();
  s.fields({"stress", "porosity", "unbalanced_force_index"}, out);
  ASSERT_EQ(out.getArrays()[0].getValues().size(), 9u);
  EXPECT_LT(out.getArrays()[0].getValues()[0], 0.0);  // compressed lattice
  EXPECT_NEAR(out.getArrays()[1].getValues()[0], 1.0 - 27 * 4.18879e-6 / std::pow(0.0597, 3), 1e-4);
  const std::string bad = errorOf(scene("      particles: [{sphere: {position: [0,0,0], radius: 0.001}}]\n"
                                        "      periodic: {cell: [[1, 0, 0], [0, 1, 0]]}\n"));
  EXPECT_NE(bad.find("periodic.cell"), std::string::npos) << bad;
}

}  // namespace
}  // namespace cosim::dem

// params.drives (Cheng 2022 Table 4, loading (b)): the left end of a bonded
// chain follows v(t) = a (cos(omega t) - 1) for one cycle and is then held.
// It ends displaced by the pulse's integral, -a 2 pi / omega; the drive's work
// is external work, and it equals the energy the undamped chain holds.
namespace cosim::dem {
namespace {

TEST(DemSolver, CosinePulseDriveMovesItsZoneAndCountsItsWork) {
  const double a = 0.05, omega = 1950.0, period = 2.0 * 3.14159265358979323846 / omega;
  const std::string yaml = scene(R"(
      contact: {normal: linear, tangential: none, damping: none}
      materials:
        - {name: grain, density: 2500, young: 1.0e8, poisson: 0.0, kn: 4.0e7}
      particles:
        - lattice: {origin: [0.2, 0.2, 0.2], spacing: 0.4, counts: [1, 40, 1], radius: 0.2, material: grain}
      bonds: {stiffness: 4.0e7, neighbours: 1.01}
      zones:
        - {name: left, box: {min: [-1, -1, -1], max: [1, 0.4, 1]}}
      drives:
        - {zone: left, velocity: {kind: cosine-pulse, amplitude: [0, 0.05, 0], omega: 1950, cycles: 1}}
)");
  Harness h;
  DemSolver s;
  h.setup(s, yaml);
  const Vec3 start = s.system().particles.x[0];
  const double dt = 1.0e-5;  // t_c / 100 of one bond
  const auto steps = static_cast<std::uint32_t>(std::ceil(period / dt)) + 1000;
  h.advance(s, steps, dt);
  const Particles& p = s.system().particles;
  EXPECT_NEAR(p.x[0][1] - start[1], -a * period, 1e-6 * a * period);  // the pulse's integral
  EXPECT_DOUBLE_EQ(p.x[0][0], start[0]);
  EXPECT_EQ(p.v[0][1], 0.0);  // held after the pulse
  EXPECT_NE(p.driven[1], 1);   // only the zone is driven
  double stored = 0.0, work = 0.0, driveWork = -1.0;
  for (const auto& [name, value] : s.energies()) {
    if (name == "kinetic" || name == "elastic") stored += value;
    if (name == "external_work") work = value;
    if (name == "drive_work") driveWork = value;
  }
  EXPECT_EQ(driveWork, work);  // no other external force here
  std::printf("[drive] work %.6e J, stored %.6e J, relative gap %.2e\n", work, stored, (work - stored) / work);
  EXPECT_GT(work, 0.0);
  EXPECT_NEAR(stored, work, 1e-3 * work);
  // An unknown history kind, a key of another kind and a missing zone are named.
  auto refused = [&](const std::string& from, const std::string& to, const std::string& message) {
    std::string bad = yaml;
    bad.replace(bad.find(from), from.size(), to);
    Harness hb;
    DemSolver b;
    try {
      hb.setup(b, bad, "drive.yaml");
      ADD_FAILURE() << "accepted: " << to;
    } catch (const wire::SolverError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  refused("cosine-pulse", "sine-pulse", "drive.yaml:16: params.drives[0].velocity: unknown velocity history 'sine-pulse'");
  refused("cycles: 1", "cycles: 1, value: [0, 0, 0]", "params.drives[0].velocity: unknown key 'value'");
  refused("{zone: left,", "{zone: right,", "params.drives[0].zone: no zone named 'right' in params.zones");
}

}  // namespace
}  // namespace cosim::dem

// Prescribed motion does work: a driven sphere (params.particles driven:
// true) knocks a free one away under gravity. What holding it on its path
// takes, -(f + m g) . v dt over the steps, is external work (drive_work), and
// it balances the stored energy (kinetic + elastic + potential) of both.
// A step far above the critical one breaks that balance: the solver stops
// with the numbers instead of running on to a blown-up state.
namespace cosim::dem {
namespace {

double balanceGap(const DemSolver& s, double& work, double& driveWork) {
  double stored = 0.0;
  for (const auto& [name, value] : s.energies()) {
    if (name == "kinetic" || name == "elastic" || name == "potential" || name == "dissipated") stored += value;
    if (name == "external_work") work = value;
    if (name == "drive_work") driveWork = value;
  }
  return stored;
}

const std::string kKnock = scene(R"(
      contact: {normal: hertz, tangential: none, damping: none}
      gravity: [0, 0, -9.81]
      materials:
        - {name: glass, density: 2500, young: 1.0e8, poisson: 0.25}
      particles:
        - sphere: {position: [-0.03, 0, 0], radius: 0.01, velocity: [1.0, 0, -0.05], driven: true}
        - sphere: {position: [0, 0, 0], radius: 0.01}
)");

TEST(DemSolver, DrivenSphereWorkBalancesTheEnergyItPutsIn) {
  Harness h;
  DemSolver s;
  h.setup(s, kKnock);
  double work = 0.0, driveWork = 0.0;
  const double start = balanceGap(s, work, driveWork);
  h.advance(s, 30000, 1.0e-6);  // contact from t = 10 ms, apart again by 30 ms
  work = driveWork = 0.0;
  const double stored = balanceGap(s, work, driveWork);
  const Particles& p = s.system().particles;
  EXPECT_GT(p.v[1][0], 1.5);   // knocked away (about 2 m/s off a sphere that cannot yield)
  EXPECT_EQ(driveWork, work);  // the only external work here
  std::printf("[driven] work %.6e J, stored energy change %.6e J, relative gap %.2e\n", work, stored - start,
              (stored - start - work) / work);
  EXPECT_NEAR(stored - start, work, 1e-4 * std::abs(work));
}

TEST(DemSolver, ABrokenEnergyBalanceStopsTheRunWithTheNumbers) {
  const std::string head = R"(
      contact: {normal: hertz, tangential: none, damping: none}
      force: true
      materials:
        - {name: glass, density: 2500, young: 1.0e8, poisson: 0.25}
      particles:
        - sphere: {position: [0, 0, 0], radius: 0.01, velocity: [1.0, 0, 0]}
        - sphere: {position: [0.0205, 0, 0], radius: 0.01}
)";
  auto run = [&](const std::string& extra) {
    Harness h;
    DemSolver s;
    h.setup(s, scene(head + extra));
    const double dt = 40.0 * criticalTimeStep(s.system());
    for (int k = 0; k < 200; ++k) {
      h.advance(s, 1, dt);
      s.energies();
    }
    return norm(s.system().particles.v[1]);
  };
  try {
    run("");
    ADD_FAILURE() << "a step 40 times the critical one ran on";
  } catch (const wire::SolverError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("energy balance broken"), std::string::npos) << what;
    EXPECT_NE(what.find("params.energy_tolerance"), std::string::npos) << what;
    EXPECT_NE(what.find("critical step now"), std::string::npos) << what;
  }
  // Turned off, the same run goes on (and gains energy).
  EXPECT_GT(run("      energy_tolerance: 0\n"), 1.0);
  EXPECT_NE(errorOf(scene(head + "      energy_tolerance: -1\n")).find("energy_tolerance"), std::string::npos);
}

// A sphere squeezed by a servo lid: with the gain at half the stable one the
// lid settles on its target load; with a gain whose loop gain G dt k passes 1
// (it overshoots every step) the run stops at that step, naming the wall, the
// key and the gain that would do, instead of ringing on at the step rate.
TEST(DemSolver, AServoWallTooFastForItsContactsStopsTheRun) {
  auto squeeze = [](double gain, int steps) {
    const std::string yaml = scene(R"(
      contact: {normal: hertz, tangential: none, damping: restitution}
      materials: [{name: glass, density: 2500, young: 1.0e8, poisson: 0.25, restitution: 0.5}]
      particles: [{sphere: {position: [0, 0, 0.01], radius: 0.01}}]
      walls:
        - {type: plane, point: [0, 0, 0], normal: [0, 0, 1]}
        - {type: plane, name: lid, point: [0, 0, 0.02], normal: [0, 0, -1], mode: servo, stress: 1.0e5,
           area: 1.0e-4, gain: )" + std::to_string(gain) + "}\n");
    Harness h;
    DemSolver s;
    h.setup(s, yaml);
    for (int k = 0; k < steps; ++k) h.advance(s, 1, 1e-5);
    return s.system().planes[1];
  };
  // Target 10 N. The servo is a dashpot of 1 / G = 100 N s/m against the
  // sphere's contacts (overdamped); its loop gain G dt S_n at the target is 0.02.
  const PlaneWall lid = squeeze(0.01, 5000);
  std::printf("servo lid: load %.6f N (target 10 N), loop gain %.3f\n", -dot(lid.force, lid.normal),
              lid.servoLoopGain(1e-5));
  EXPECT_NEAR(-dot(lid.force, lid.normal), 10.0, 1e-3);
  // S_n = 3 F / (2 overlap) for Hertz: the stiffness the servo saw is the law's tangent.
  const double overlap = (0.02 - lid.point.z) / 2.0;  // the sphere pressed alike by floor and lid
  EXPECT_NEAR(lid.stiffness, 1.5 * 10.0 / overlap, 1e-3 * lid.stiffness);
  try {
    squeeze(3.0, 100);
    ADD_FAILURE() << "a servo with loop gain above 1 ran on";
  } catch (const wire::SolverError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("servo wall 'lid' is unstable: params.walls gain 3 m/(N s)"), std::string::npos) << what;
    EXPECT_NE(what.find("use gain <="), std::string::npos) << what;
  }
}

// Params that name a material, a sphere and a wall around the text under test.
const std::string kGlass = "      materials: [{name: glass, density: 2500, young: 7.0e10, poisson: 0.3, friction: 0.3}]\n";
const std::string kOneSphere = "      particles: [{sphere: {position: [0, 0, 0.0101], radius: 0.01}}]\n";

// Gravity of 1e308 m/s^2 is finite, so setup takes it; the first advance runs
// into the floor and non-finite positions, and the message names gravity among the causes.
TEST(DemSolver, ANonFiniteStateNamesTheGravityItRanUnder) {
  Harness h;
  DemSolver s;
  h.setup(s, scene("      gravity: [0, 0, -1.0e308]\n      walls: [{type: plane, normal: [0, 0, 1]}]\n" + kOneSphere));
  try {
    h.advance(s, 10, 1e-5);
    ADD_FAILURE() << "a sphere under 1e308 m/s^2 ran on";
  } catch (const wire::SolverError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("particle 0 has a non-finite"), std::string::npos) << what;
    EXPECT_NE(what.find("params.gravity [0, 0, -1e+308] m/s^2 too large"), std::string::npos) << what;
  }
}

// Each bad value is refused with its file, line and key path, and the message says what is wrong.
void expectRefused(const std::string& params, const std::string& expected) {
  const std::string e = errorOf(scene(params));
  EXPECT_NE(e.find(expected), std::string::npos) << "expected '" << expected << "' in: " << e;
  EXPECT_EQ(e.rfind("bad.yaml", 0), 0u) << e;
}

TEST(DemSolver, PackingsBeyondMemoryOrBoxAreRefusedBeforeAllocating) {
  const auto start = std::chrono::steady_clock::now();
  expectRefused(kGlass + "      particles:\n        - lattice: {spacing: 0.0024, counts: [100000, 100000, 100000], radius: 0.001}\n",
                "bad.yaml:8: params.particles[0].lattice.counts: [100000, 100000, 100000] cubic cells make 1e+15 particles");
  expectRefused(kGlass + "      particles:\n        - lattice: {spacing: 0.0024, counts: [2000000, 2000, 1000], radius: 0.001, kind: fcc}\n",
                "params.particles[0].lattice.counts: [2000000, 2000, 1000] fcc cells make 1.6e+13 particles");
  const std::string random = kGlass + "      particles:\n        - random: {min: [0, 0, 0], max: [0.02, 0.02, 0.02], radius: 0.001, ";
  expectRefused(random + "count: 100000}\n", "bad.yaml:8: params.particles[0].random.count: 100000 spheres need");
  expectRefused(random + "count: 1000000000000}\n",
                "params.particles[0].random.count: 1000000000000 spheres make 1e+12 particles");
  // Each is refused up front, not after minutes of allocating or placing.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10.0);
}

TEST(DemSolver, LargePeriodicCellsGetACappedGridAndWideCellsTheirWidth) {
  for (const std::string cell : {"[[1000, 0, 0], [0, 1000, 0], [0, 0, 1000]]", "[[1e6, 0, 0], [0, 1e6, 0], [0, 0, 1e6]]",
                                 "[[1e200, 0, 0], [0, 1, 0], [0, 0, 1]]"}) {
    DemSolver s;
    Harness h;
    h.setup(s, scene(kGlass + "      particles:\n"
                              "        - sphere: {position: [0.02, 0.5, 0.5], radius: 0.005, velocity: [0.5, 0, 0]}\n"
                              "        - sphere: {position: [0.03, 0.5, 0.5], radius: 0.005, velocity: [-0.5, 0, 0]}\n"
                              "      periodic: {cell: " + cell + "}\n"));
    h.advance(s, 1, 1e-7);
    EXPECT_EQ(s.system().neighbors.pairs(), 1u) << cell;
  }
  // |c x a| overflows for the 1e200 m cell: its widths still come out right.
  PeriodicCell wide;
  wide.h = {1e200, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_EQ(wide.width(0), 1e200);
  EXPECT_EQ(wide.width(1), 1.0);
  EXPECT_EQ(wide.width(2), 1.0);
  expectRefused(kGlass + "      particles:\n"
                         "        - sphere: {position: [0.02, 0.025, 0.025], radius: 0.005}\n"
                         "      periodic: {cell: [[0.005, 0, 0], [0, 0.05, 0], [0, 0, 0.05]]}\n",
                "bad.yaml:9: params.periodic.cell: the cell is 0.005 m wide across face pair 0");
  expectRefused(kGlass + kOneSphere + "      periodic: {cell: [[1e200, 0, 0], [0, 1e200, 0], [0, 0, 1e200]]}\n",
                "params.periodic.cell: the cell's volume overflows double range");
  // Mesh contacts are not searched across images: refused, not silently missed.
  expectRefused(kGlass + "      particles: [{sphere: {position: [0.5, 0.5, 0.5], radius: 0.01}}]\n"
                         "      walls: [{type: mesh, name: floor, vertices: [[0, 0, 0], [1, 0, 0], [1, 1, 0]], "
                         "triangles: [[0, 1, 2]]}]\n"
                         "      periodic: {cell: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}\n",
                "params.walls: mesh wall 'floor' in a periodic cell");
}

TEST(DemSolver, PlaneWallNormalsOfAnyScaleAndStartOverlaps) {
  for (const std::string n : {"[0, 0, 1e200]", "[0, 0, 1e308]", "[0, 0, 1e-320]", "[0, 0, 3]"}) {
    DemSolver s;
    Harness h;
    h.setup(s, scene(kGlass + kOneSphere + "      walls: [{type: plane, name: floor, point: [0, 0, 0], normal: " + n + "}]\n"));
    EXPECT_DOUBLE_EQ(s.system().planes[0].normal.z, 1.0) << n;
  }
  const std::string wall = "      walls: [{type: plane, name: floor, normal: [0, 0, 1], ";
  expectRefused(kGlass + kOneSphere + "      walls: [{type: plane, normal: [0, 0, 0]}]\n",
                "bad.yaml:8: params.walls[0].normal: must be non-zero");
  // A sphere reaching into the wall, or wholly behind it, would start with a blast.
  expectRefused(kGlass + kOneSphere + wall + "point: [0, 0, 0.015]}]\n",
                "particle 0 overlaps plane wall 'floor' by 0.0149 m at start (its centre lies behind the wall)");
  expectRefused(kGlass + kOneSphere + wall + "point: [0, 0, 0.0002]}]\n",
                "particle 0 overlaps plane wall 'floor' by 0.0001 m at start (tolerance 0.0001 m, params.overlap_tolerance)");
  DemSolver s;
  Harness h;
  h.setup(s, scene(kGlass + kOneSphere + wall + "point: [0, 0, 0.0002]}]\n      overlap_tolerance: 0.02\n"));
}

TEST(DemSolver, SilentlyIgnoredParamsAreRefused) {
  const std::string linear = "      contact: {normal: hertz, tangential: linear}\n";
  expectRefused(linear + kGlass + kOneSphere,
                "params.materials: material 'glass' needs kt > 0 for the linear tangential law");
  DemSolver s;
  Harness h;
  h.setup(s, scene(linear + "      materials: [{name: glass, friction: 0.3, kt: 1000}]\n" + kOneSphere));
  expectRefused("      materials: [{name: glass, kt: -1}]\n" + kOneSphere,
                "bad.yaml:6: params.materials[0].kt: spring constants must be >= 0");
  expectRefused("      materials: [{name: glass}, {name: glass, density: 1}]\n" + kOneSphere,
                "bad.yaml:6: params.materials[1].name: material 'glass' is declared twice");
  expectRefused(kOneSphere + "      snapshots: {file: x.h5}\n",
                "bad.yaml:7: params.snapshots.every: snapshots.file is set but every is missing");
  expectRefused(kOneSphere + "      snapshots: {file: x.h5, every: 0}\n",
                "params.snapshots.every: snapshots.file is set but every is 0");
  const std::string wall = "      walls: [{type: plane, normal: [0, 0, 1], ";
  expectRefused(kOneSphere + wall + "stress: 1e5, gain: 1}]\n",
                "bad.yaml:7: params.walls[0].stress: only a servo wall (mode: servo) takes stress; this wall is fixed");
  expectRefused(kOneSphere + wall + "velocity: [0, 0, 1], gain: 1}]\n",
                "params.walls[0].gain: only a servo wall (mode: servo) takes gain; this wall is velocity");
  expectRefused(kOneSphere + wall + "mode: servo, stress: 1e5, area: 0.01, gain: 1e-4, velocity: [0, 0, 1]}]\n",
                "params.walls[0].velocity: a servo wall moves by its stress control; it takes no velocity");
  expectRefused(kOneSphere + wall + "mode: fixed, velocity: [0, 0, 1]}]\n",
                "params.walls[0].velocity: a fixed wall (mode: fixed) does not move");
}

TEST(DemSolver, ListElementsOfTheWrongTypeNameTheirKey) {
  const std::string mesh = "      walls: [{type: mesh, vertices: [[-1, -1, 0], [1, -1, 0], [1, 1, 0]], triangles: [[0, 1, ";
  expectRefused(kOneSphere + mesh + "-1]]}]\n", "bad.yaml:7: params.walls[0].triangles[0][2]: -1 is out of range [0, 4294967295]");
  expectRefused(kOneSphere + mesh + "99999999999]]}]\n", "params.walls[0].triangles[0][2]: 99999999999 is out of range");
  expectRefused(kOneSphere + mesh + "2.5]]}]\n", "params.walls[0].triangles[0][2]: expected an integer, got '2.5'");
  expectRefused(kOneSphere + mesh + "a]]}]\n", "params.walls[0].triangles[0][2]: expected an integer, got 'a'");
  const std::string lattice = "      particles: [{lattice: {spacing: 0.0024, radius: 0.001, counts: ";
  expectRefused(lattice + "[a, 2, 2]}}]\n", "bad.yaml:6: params.particles[0].lattice.counts[0]: expected an integer, got 'a'");
  expectRefused(lattice + "[1e12, 1, 1]}}]\n", "params.particles[0].lattice.counts[0]: expected an integer, got '1e12'");
  expectRefused(lattice + "[2, 2.5, 2]}}]\n", "params.particles[0].lattice.counts[1]: expected an integer, got '2.5'");
  expectRefused(lattice + "[2, 2, [2]]}}]\n", "params.particles[0].lattice.counts[2]: expected an integer, got a list");
  expectRefused(lattice + "[2, 0, 2]}}]\n", "params.particles[0].lattice.counts[1]: 0 is out of range [1, ");
  const std::string random = "      particles: [{random: {min: [0, 0, 0], max: [0.02, 0.02, 0.02], count: 10, radius: ";
  expectRefused(random + "[a, 0.001]}}]\n", "bad.yaml:6: params.particles[0].random.radius[0]: expected a number, got 'a'");
  expectRefused(random + "[0.001, .inf]}}]\n", "params.particles[0].random.radius[1]: must be finite, got '.inf'");
  const std::string drive = kOneSphere + "      zones: [{name: all}]\n      drives: [{zone: all, velocity: {kind: ";
  expectRefused(drive + "{a: 1}, value: [0, 0, 0]}}]\n", "bad.yaml:8: params.drives[0].velocity.kind: expected a string, got a map");
  expectRefused(drive + "[constant], value: [0, 0, 0]}}]\n", "params.drives[0].velocity.kind: expected a string, got a list");
}

TEST(DemSolver, BondStiffnessBoundsTheCriticalStep) {
  const std::string bonded = kGlass + R"(      particles:
        - lattice: {spacing: 0.002, counts: [2, 1, 1], radius: 0.001}
        - sphere: {position: [0.004, 0, 0], radius: 0.001, velocity: [1, 0, 0]}
      bonds: {stiffness: 1.0e12}
)";
  DemSolver s;
  Harness h;
  h.setup(s, scene(bonded));
  // The middle sphere has two bonds: sqrt(m / (2 k 2)).
  const double m = s.system().particles.mass[1];
  EXPECT_DOUBLE_EQ(s.criticalDt(), std::sqrt(m / (4.0e12)));
  const std::string e = errorOf(scene(bonded + "      dt: 5.0e-8\n"));
  EXPECT_NE(e.find("params.dt: dt = 5e-08 s is above the critical step"), std::string::npos) << e;
  EXPECT_NE(e.find("set by the bonds: params.bonds.stiffness 1e+12 N/m"), std::string::npos) << e;
}

}  // namespace
}  // namespace cosim::dem
