#include "cosim/dem/solver/scene_params.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>

#include "cosim/dem/packing/packing.hpp"
#include "cosim/dem/solver/yaml_section.hpp"
#include "cosim/util/host_memory.hpp"
#include "cosim/wire/solver.hpp"

namespace cosim::dem {
namespace {

std::uint16_t materialOf(const YamlSection& s, const DemSystem& system) {
  const std::string name = s.text("material", system.materials[0].name);
  try {
    return system.materials.find(name);
  } catch (const std::invalid_argument&) {
    s.fail("material", "unknown material '" + name + "'");
  }
}

void readMaterials(const YamlSection& params, DemSystem& system) {
  const YAML::Node list = params.node("materials");
  if (!list) {
    system.materials.add(Material{});
    return;
  }
  if (!list.IsSequence() || list.size() == 0) params.fail("materials", "expected a non-empty list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YamlSection m(list[i], params.file(), params.path() + ".materials[" + std::to_string(i) + "]",
                        {"name", "density", "young", "poisson", "restitution", "friction", "kn", "kt"});
    Material mat;
    mat.name = m.text("name", "material" + std::to_string(i));
    for (const Material& other : system.materials.all())
      if (other.name == mat.name) m.fail("name", "material '" + mat.name + "' is declared twice");
    mat.density = m.positive("density", mat.density);
    mat.young = m.positive("young", mat.young);
    mat.poisson = m.number("poisson", mat.poisson);
    if (mat.poisson <= -1.0 || mat.poisson >= 0.5) m.fail("poisson", "must lie in (-1, 0.5)");
    mat.restitution = m.number("restitution", mat.restitution);
    if (!(mat.restitution > 0.0 && mat.restitution <= 1.0)) m.fail("restitution", "must lie in (0, 1]");
    mat.friction = m.number("friction", mat.friction);
    if (mat.friction < 0.0) m.fail("friction", "must be >= 0");
    mat.kn = m.number("kn", mat.kn);
    mat.kt = m.number("kt", mat.kt);
    if (mat.kn < 0.0) m.fail("kn", "spring constants must be >= 0");
    if (mat.kt < 0.0) m.fail("kt", "spring constants must be >= 0");
    system.materials.add(mat);
  }
}

void addSpheres(const SphereSet& set, std::uint16_t material, const Vec3& velocity, DemSystem& system,
                const YamlSection& where) {
  const double density = system.materials[material].density;
  for (std::size_t i = 0; i < set.radii.size(); ++i) {
    if (!(set.radii[i] > 0.0) || !std::isfinite(set.radii[i]))
      throw SceneError(set.origin[i] + ": particle radius must be positive, got " + std::to_string(set.radii[i]) +
                       " (" + where.path() + ")");
    const std::size_t p = system.particles.add(set.centres[i], set.radii[i], density, material);
    if (!std::isfinite(system.particles.inertia[p])) {
      std::ostringstream m;
      m << set.origin[i] << ": a particle of radius " << set.radii[i] << " m and density " << density
        << " kg/m^3 has a mass or moment of inertia beyond double range (" << where.path() << ")";
      throw SceneError(m.str());
    }
    system.particles.v[p] = set.velocities[i] + velocity;
  }
}

// The most particles one solver takes: what the machine's memory holds at
// about 1 KB each (particle state, neighbour rows, packing scratch), and what
// the 32-bit particle indices reach. Checked before a packing allocates.
std::size_t maxParticles() {
  const double memory = util::availableMemoryBytes();
  return static_cast<std::size_t>(std::min(memory / 1024.0, static_cast<double>(std::numeric_limits<std::int32_t>::max())));
}

void requireRoomFor(double count, const DemSystem& system, const YamlSection& s, const std::string& key,
                    const std::string& what) {
  const double before = static_cast<double>(system.particles.size());
  if (count + before <= static_cast<double>(maxParticles())) return;
  std::ostringstream m;
  m << what << " make " << count << " particles";
  if (before > 0.0) m << " (" << count + before << " with those before)";
  m << ": more than the " << maxParticles() << " this machine holds (about 1 KB of memory each, at most 2^31)";
  s.fail(key, m.str());
}

void readLattice(const YamlSection& s, DemSystem& system) {
  const YAML::Node c = s.node("counts");
  if (!c || !c.IsSequence() || c.size() != 3) s.fail("counts", "expected [nx, ny, nz]");
  std::array<int, 3> counts{};
  double total = 1.0;
  std::string shown;
  for (std::size_t d = 0; d < 3; ++d) {
    const std::string at = s.where(c[d]) + ": " + s.path() + ".counts[" + std::to_string(d) + "]";
    const long n = toInteger(c[d], at, 1, std::numeric_limits<long>::max());
    total *= static_cast<double>(n);
    counts[d] = static_cast<int>(std::min<long>(n, std::numeric_limits<int>::max()));  // checked below
    shown += (d == 0 ? "[" : ", ") + std::to_string(n);
  }
  const double spacing = s.positive("spacing");
  const double radius = s.positive("radius");
  const std::string kind = s.text("kind", "cubic");
  if (kind != "cubic" && kind != "fcc") s.fail("kind", "unknown lattice kind '" + kind + "' (known: cubic, fcc)");
  requireRoomFor(kind == "fcc" ? 4.0 * total : total, system, s, "counts", shown + "] " + kind + " cells");
  SphereSet set = latticePacking(s.vec3("origin", {}), spacing, counts, radius, kind);
  // Optional random displacement (fraction of the half gap) to break the lattice's symmetry.
  const double jitter = s.number("jitter", 0.0);
  if (jitter < 0.0 || jitter > 1.0) s.fail("jitter", "must lie in [0, 1]");
  if (jitter > 0.0) {
    const double gap = 0.5 * (spacing * (kind == "fcc" ? std::sqrt(0.5) : 1.0) - 2.0 * radius);
    if (gap <= 0.0) s.fail("jitter", "the lattice has no gap to jitter in");
    std::mt19937_64 rng(static_cast<std::uint64_t>(s.integer("seed", 1)));
    std::uniform_real_distribution<double> u(-jitter * gap / std::sqrt(3.0), jitter * gap / std::sqrt(3.0));
    for (Vec3& centre : set.centres) centre += Vec3{u(rng), u(rng), u(rng)};
  }
  addSpheres(set, materialOf(s, system), s.vec3("velocity", {}), system, s);
}

// Random sequential addition jams near a solid fraction of 0.38 (0.6 is
// beyond any random packing); the attempts are capped so that a packing that
// does not fit stops within seconds.
constexpr double kPackableFraction = 0.6;

void requirePackable(const YamlSection& s, long count, double rmin, double rmax, const Vec3& size) {
  const double box = size.x * size.y * size.z;
  // Mean r^3 of radii uniform in [rmin, rmax]: (rmax^4 - rmin^4) / (4 (rmax - rmin)).
  const double meanR3 = rmax > rmin ? (std::pow(rmax, 4) - std::pow(rmin, 4)) / (4.0 * (rmax - rmin)) : rmin * rmin * rmin;
  const double solid = static_cast<double>(count) * 4.0 / 3.0 * std::numbers::pi * meanR3;
  if (solid <= kPackableFraction * box) return;
  std::ostringstream m;
  m << count << " spheres need " << solid << " m^3 of solid, " << solid / box << " x the box's " << box
    << " m^3; no random packing fills more than " << kPackableFraction << " of it: lower count or enlarge the box";
  s.fail("count", m.str());
}

void readRandom(const YamlSection& s, DemSystem& system) {
  const YAML::Node r = s.node("radius");
  double rmin = 0.0, rmax = 0.0;
  if (r && r.IsSequence() && r.size() == 2) {
    rmin = toNumber(r[0], s.where(r[0]) + ": " + s.path() + ".radius[0]");
    rmax = toNumber(r[1], s.where(r[1]) + ": " + s.path() + ".radius[1]");
  } else {
    rmin = rmax = s.positive("radius");
  }
  if (!(rmin > 0.0) || rmax < rmin) s.fail("radius", "need 0 < rmin <= rmax");
  const long count = s.integer("count", 0);
  if (count < 1) s.fail("count", "must be >= 1");
  requireRoomFor(static_cast<double>(count), system, s, "count", std::to_string(count) + " spheres");
  const Vec3 lo = s.vec3("min"), hi = s.vec3("max");
  for (int d = 0; d < 3; ++d)
    if (hi[d] - lo[d] < 2 * rmax) s.fail("max", "box smaller than one sphere along axis " + std::to_string(d));
  requirePackable(s, count, rmin, rmax, hi - lo);
  const auto n = static_cast<std::size_t>(count);
  const SphereSet set = randomPacking(lo, hi, rmin, rmax, n, static_cast<std::uint64_t>(s.integer("seed", 1)),
                                      std::min(1000 * n + 1000, 10'000'000 + 50 * n));
  if (set.radii.size() < n)
    s.fail("count", "only " + std::to_string(set.radii.size()) + " of " + std::to_string(count) +
                        " spheres fit in the box without overlap; lower count or enlarge the box");
  addSpheres(set, materialOf(s, system), s.vec3("velocity", {}), system, s);
}

void readParticles(const YamlSection& params, DemSystem& system, const std::string& baseDir) {
  // A DEM side of only PD bodies (their hybrid surface particles meet each
  // other here, Hartmann Sec. 3) has no spheres of its own.
  const bool hybridOnly = params.has("hybrid");
  const YAML::Node list = params.node("particles");
  if (!list && hybridOnly) return;
  if (!list) params.fail("particles", "a dem solver needs particles (or hybrid: {material: ...} to take PD's surface particles)");
  if (!list.IsSequence()) params.fail("particles", "expected a list of sources (lattice, random, file, sphere)");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = params.path() + ".particles[" + std::to_string(i) + "]";
    const YamlSection src(list[i], params.file(), path, {"lattice", "random", "file", "sphere"});
    if (list[i].size() != 1) throw SceneError(src.where(list[i]) + ": " + path + ": give exactly one source kind");
    if (src.has("lattice")) {
      readLattice(src.child("lattice", {"origin", "spacing", "counts", "radius", "kind", "material", "velocity", "jitter", "seed"}),
                  system);
    } else if (src.has("random")) {
      readRandom(src.child("random", {"min", "max", "radius", "count", "seed", "material", "velocity"}), system);
    } else if (src.has("file")) {
      const YamlSection s = src.child("file", {"path", "material", "velocity"});
      const std::string file = wire::resolveScenePath(s.text("path"), baseDir);
      try {
        addSpheres(readSphereFile(file), materialOf(s, system), s.vec3("velocity", {}), system, s);
      } catch (const SceneError&) {
        throw;
      } catch (const std::exception& e) {
        throw SceneError(s.where("path") + ": " + s.path() + ".path: " + e.what());
      }
    } else {
      const YamlSection s =
          src.child("sphere", {"position", "radius", "velocity", "angular_velocity", "material", "driven"});
      SphereSet one;
      one.centres.push_back(s.vec3("position"));
      one.radii.push_back(s.positive("radius"));
      one.velocities.push_back(s.vec3("velocity", {}));
      one.origin.push_back(s.where("position"));
      addSpheres(one, materialOf(s, system), {}, system, s);
      system.particles.omega.back() = s.vec3("angular_velocity", {});
      // driven: true = moves with its velocity, not integrated (an indenter).
      system.particles.driven.back() = s.flag("driven", false) ? 1 : 0;
    }
  }
  if (system.particles.size() == 0 && !hybridOnly) params.fail("particles", "no particles were created");
}

// The unit normal of a plane wall, scaled first so that |n| neither
// overflows nor underflows (for a normal n, the same bits as n / |n|).
Vec3 unitNormal(const YamlSection& s) {
  const Vec3 n = powerOfTwoScaled(s.vec3("normal"));
  if (!(norm(n) > 0.0)) s.fail("normal", "must be non-zero");
  return (1.0 / norm(n)) * n;
}

// mode: fixed | velocity | servo, each with only its own keys.
void readWallMotion(const YamlSection& s, PlaneWall& w) {
  w.velocity = s.vec3("velocity", {});
  const std::string mode = s.text("mode", norm(w.velocity) > 0.0 ? "velocity" : "fixed");
  if (mode != "fixed" && mode != "velocity" && mode != "servo")
    s.fail("mode", "unknown wall mode '" + mode + "' (known: fixed, velocity, servo)");
  if (mode != "servo")
    for (const char* key : {"stress", "area", "gain"})
      if (s.has(key)) s.fail(key, "only a servo wall (mode: servo) takes " + std::string(key) + "; this wall is " + mode);
  if (mode == "fixed" && norm(w.velocity) > 0.0)
    s.fail("velocity", "a fixed wall (mode: fixed) does not move; drop velocity or use mode: velocity");
  if (mode == "fixed") w.mode = PlaneWall::Mode::fixed;
  if (mode == "velocity") w.mode = PlaneWall::Mode::velocity;
  if (mode != "servo") return;
  if (s.has("velocity")) s.fail("velocity", "a servo wall moves by its stress control; it takes no velocity");
  w.mode = PlaneWall::Mode::servo;
  w.servoStress = s.number("stress");
  w.servoArea = s.positive("area");
  w.servoGain = s.positive("gain");
}

void readWalls(const YamlSection& params, DemSystem& system) {
  const YAML::Node list = params.node("walls");
  if (!list) return;
  if (!list.IsSequence()) params.fail("walls", "expected a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = params.path() + ".walls[" + std::to_string(i) + "]";
    const YamlSection probe(list[i], params.file(), path,
                            {"type", "name", "point", "normal", "velocity", "mode", "stress", "area", "gain",
                             "material", "vertices", "triangles"});
    const std::string type = probe.text("type", "plane");
    if (type == "plane") {
      const YamlSection s(list[i], params.file(), path,
                          {"type", "name", "point", "normal", "velocity", "mode", "stress", "area", "gain", "material"});
      PlaneWall w;
      w.name = s.text("name", "wall" + std::to_string(i));
      w.point = s.vec3("point", {});
      w.normal = unitNormal(s);
      readWallMotion(s, w);
      w.material = materialOf(s, system);
      system.planes.push_back(w);
    } else if (type == "mesh") {
      const YamlSection s(list[i], params.file(), path, {"type", "name", "vertices", "triangles", "velocity", "material"});
      TriangleWallGroup g;
      g.name = s.text("name", "mesh" + std::to_string(i));
      const YAML::Node v = s.node("vertices"), t = s.node("triangles");
      if (!v || !v.IsSequence()) s.fail("vertices", "expected a list of [x, y, z]");
      if (!t || !t.IsSequence()) s.fail("triangles", "expected a list of [a, b, c]");
      for (std::size_t k = 0; k < v.size(); ++k)
        g.vertices.push_back(toVec3(v[k], s.where(v[k]) + ": " + path + ".vertices[" + std::to_string(k) + "]"));
      const Vec3 vel = s.vec3("velocity", {});
      g.velocities.assign(g.vertices.size(), vel);
      for (std::size_t k = 0; k < t.size(); ++k) {
        if (!t[k].IsSequence() || t[k].size() != 3)
          throw SceneError(s.where(t[k]) + ": " + path + ".triangles[" + std::to_string(k) + "]: expected [a, b, c]");
        std::array<std::uint32_t, 3> tri{};
        for (std::size_t c = 0; c < 3; ++c)
          tri[c] = static_cast<std::uint32_t>(
              toInteger(t[k][c], s.where(t[k][c]) + ": " + path + ".triangles[" + std::to_string(k) + "][" +
                                     std::to_string(c) + "]",
                        0, std::numeric_limits<std::uint32_t>::max()));
        g.triangles.push_back(tri);
      }
      g.material = materialOf(s, system);
      try {
        g.validate();
      } catch (const std::invalid_argument& e) {
        throw SceneError(s.where("triangles") + ": " + path + ": " + e.what());
      }
      system.meshes.push_back(std::move(g));
    } else {
      probe.fail("type", "unknown wall type '" + type + "' (known: plane, mesh)");
    }
  }
}

void readZones(const YamlSection& params, RunSettings& settings) {
  const YAML::Node list = params.node("zones");
  if (!list) return;
  if (!list.IsSequence()) params.fail("zones", "expected a list of {name, box}");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = params.path() + ".zones[" + std::to_string(i) + "]";
    const YamlSection z(list[i], params.file(), path, {"name", "box"});
    ExportZone zone;
    zone.name = z.text("name");
    for (const auto& other : settings.zones)
      if (other.name == zone.name) z.fail("name", "zone '" + zone.name + "' is declared twice");
    if (z.has("box")) {
      const YamlSection box = z.child("box", {"min", "max"});
      zone.boxed = true;
      zone.lo = box.vec3("min");
      zone.hi = box.vec3("max");
      for (int d = 0; d < 3; ++d)
        if (!(zone.lo[d] < zone.hi[d])) box.fail("max", "must exceed min in every component");
    }
    settings.zones.push_back(zone);
  }
}

void readDrives(const YamlSection& params, RunSettings& settings) {
  const YAML::Node list = params.node("drives");
  if (!list) return;
  if (!list.IsSequence()) params.fail("drives", "expected a list of {zone, velocity}");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = params.path() + ".drives[" + std::to_string(i) + "]";
    const YamlSection d(list[i], params.file(), path, {"zone", "velocity"});
    DriveSpec spec;
    spec.zone = d.text("zone");
    if (std::none_of(settings.zones.begin(), settings.zones.end(),
                     [&spec](const ExportZone& z) { return z.name == spec.zone; }))
      d.fail("zone", "no zone named '" + spec.zone + "' in params.zones");
    for (const auto& other : settings.drives)
      if (other.zone == spec.zone) d.fail("zone", "zone '" + spec.zone + "' is driven twice");
    const YAML::Node v = d.node("velocity");
    if (!v || !v.IsMap() || !v["kind"])
      d.fail("velocity", "expected a map with kind: " + VelocityHistoryRegistry::namesJoined());
    const std::string kind = toText(v["kind"], d.where(v["kind"]) + ": " + path + ".velocity.kind");
    if (!VelocityHistoryRegistry::has(kind))
      d.fail("velocity", "unknown velocity history '" + kind + "' (known: " + VelocityHistoryRegistry::namesJoined() + ")");
    spec.history = VelocityHistoryRegistry::make(kind, d);
    settings.drives.push_back(spec);
  }
}

// The cell must be finite and at least twice the contact cut-off 2 r_max + skin
// wide (each pair meets one image); the neighbour list checks it again as the cell deforms.
void checkCellSize(const YamlSection& per, const DemSystem& system) {
  if (!std::isfinite(system.cell.volume()))
    per.fail("cell", "the cell's volume overflows double range: cell vectors too long");
  double rmax = 0.0;
  for (double r : system.particles.radius) rmax = std::max(rmax, r);
  const double cutoff = 2.0 * rmax + system.neighbors.skin;
  for (int d = 0; d < 3; ++d)
    if (const double w = system.cell.width(d); !(w >= 2.0 * cutoff)) {
      std::ostringstream m;
      m << "the cell is " << w << " m wide across face pair " << d << " (vectors " << "abc"[(d + 1) % 3] << ", "
        << "abc"[(d + 2) % 3] << "), less than twice the contact cut-off 2 r_max + skin = " << cutoff << " m";
      per.fail("cell", m.str());
    }
}

}  // namespace

YAML::Node findSolverParams(const std::string& sceneYaml, const std::string& sceneFile, const std::string& instance) {
  YAML::Node root;
  try {
    root = YAML::Load(sceneYaml);
  } catch (const YAML::ParserException& e) {
    throw SceneError(sceneFile + ":" + std::to_string(e.mark.line + 1) + ": YAML: " + e.msg);
  }
  const YAML::Node solvers = root.IsMap() ? root["solvers"] : YAML::Node();
  if (!solvers || !solvers.IsSequence()) throw SceneError(sceneFile + ": no 'solvers:' list");
  for (const auto& s : solvers)
    if (s.IsMap() && s["name"] && s["name"].IsScalar() && s["name"].Scalar() == instance) {
      if (s["kind"] && !(s["kind"].IsScalar() && s["kind"].Scalar() == "dem"))
        throw SceneError(sceneFile + ":" + std::to_string(s["kind"].Mark().line + 1) + ": solver '" + instance +
                         "' has kind '" + (s["kind"].IsScalar() ? s["kind"].Scalar() : "(not a name)") + "', not dem");
      YAML::Node params = s["params"];
      if (!params) throw SceneError(sceneFile + ":" + std::to_string(s.Mark().line + 1) + ": solver '" + instance +
                                    "' has no params: section");
      if (!params.IsMap())
        throw SceneError(sceneFile + ":" + std::to_string(params.Mark().line + 1) + ": solver '" + instance +
                         "': params: expected a map of the dem solver's parameters");
      return params;
    }
  throw SceneError(sceneFile + ": no solver named '" + instance + "' in solvers:");
}

void configure(const YAML::Node& node, const std::string& sceneFile, DemSystem& system, RunSettings& settings,
               const std::string& baseDir) {
  const YamlSection params(node, sceneFile, "params",
                           {"contact", "integrator", "gravity", "skin", "dt", "force", "overlap_tolerance", "energy_tolerance",
                            "materials", "particles", "walls", "snapshots", "periodic", "mass_damping", "bonds",
                            "zones", "drives", "hybrid"});
  const YamlSection contact = params.child("contact", {"normal", "tangential", "damping"});
  const std::string normal = contact.text("normal", "hertz"), tangential = contact.text("tangential", "mindlin"),
                    damping = contact.text("damping", "restitution");
  if (!NormalLawRegistry::has(normal)) contact.fail("normal", "unknown normal contact law '" + normal + "'");
  if (!TangentialLawRegistry::has(tangential))
    contact.fail("tangential", "unknown tangential contact law '" + tangential + "'");
  if (!DampingLawRegistry::has(damping)) contact.fail("damping", "unknown damping law '" + damping + "'");
  system.setContactLaw(normal, tangential, damping);
  const std::string integrator = params.text("integrator", "velocity-verlet");
  if (!IntegratorRegistry::has(integrator))
    params.fail("integrator", "unknown integrator '" + integrator + "' (known: velocity-verlet, leapfrog)");
  system.setIntegrator(integrator);
  system.gravity = params.vec3("gravity", {});
  readMaterials(params, system);
  if (normal == "linear")
    for (const Material& m : system.materials.all())
      if (!(m.kn > 0.0)) params.fail("materials", "material '" + m.name + "' needs kn > 0 for the linear law");
  if (tangential == "linear")
    for (const Material& m : system.materials.all())
      if (!(m.kt > 0.0))
        params.fail("materials", "material '" + m.name + "' needs kt > 0 for the linear tangential law "
                                 "(params.contact.tangential: linear; tangential: none has no tangential spring)");
  readParticles(params, system, baseDir.empty() ? std::filesystem::path(sceneFile).parent_path().string() : baseDir);
  readWalls(params, system);
  double rmin = std::numeric_limits<double>::max();
  for (double r : system.particles.radius) rmin = std::min(rmin, r);
  // Without spheres of its own the default waits for the hybrid particles' radii (DemSolver).
  system.neighbors.skin = params.positive("skin", system.particles.size() > 0 ? kDefaultSkinPerRadius * rmin : 0.0);
  settings.skinGiven = params.has("skin");
  settings.dt = params.positive("dt", 0.0);
  settings.force = params.flag("force", false);
  settings.overlapTolerance = params.number("overlap_tolerance", 0.01);
  if (settings.overlapTolerance < 0.0) params.fail("overlap_tolerance", "must be >= 0");
  settings.energyTolerance = params.number("energy_tolerance", 0.5);
  if (!(settings.energyTolerance >= 0.0)) params.fail("energy_tolerance", "must be >= 0 (0 turns the check off)");
  system.massDamping = params.number("mass_damping", 0.0);
  if (system.massDamping < 0.0) params.fail("mass_damping", "must be >= 0");
  if (params.has("periodic")) {
    // periodic: {cell: [[ax, ay, az], [bx, by, bz], [cx, cy, cz]], velocity_gradient: [[...], [...], [...]]}
    const YamlSection per = params.child("periodic", {"cell", "velocity_gradient"});
    auto matrix = [&per](const std::string& key, bool columns) {
      const YAML::Node n = per.node(key);
      if (!n || !n.IsSequence() || n.size() != 3) per.fail(key, "expected three rows of three numbers");
      Mat3 m{};
      for (std::size_t r = 0; r < 3; ++r) {
        const Vec3 row = toVec3(n[r], per.where(n[r]) + ": " + per.path() + "." + key);
        for (int c = 0; c < 3; ++c)
          m[columns ? static_cast<std::size_t>(3 * c) + r : 3 * r + static_cast<std::size_t>(c)] = row[c];
      }
      return m;
    };
    system.cell.enabled = true;
    system.cell.h = matrix("cell", true);  // rows of the YAML are the cell vectors a, b, c
    if (!(system.cell.volume() > 0.0)) per.fail("cell", "cell vectors must be right-handed with positive volume");
    checkCellSize(per, system);
    if (per.has("velocity_gradient")) system.cell.velocityGradient = matrix("velocity_gradient", false);
    if (!system.meshes.empty())
      params.fail("walls", "mesh wall '" + system.meshes.front().name +
                               "' in a periodic cell: triangle-mesh contacts are not searched across the cell's "
                               "images (use plane walls, or drop params.periodic)");
  }
  if (params.has("bonds")) {
    // bonds: {stiffness: k, neighbours: 1.01}: bond every pair closer than 1.01 (r_i + r_j).
    const YamlSection b = params.child("bonds", {"stiffness", "neighbours"});
    system.bonds.stiffness = b.positive("stiffness");
    const double factor = b.number("neighbours", 1.01);
    if (factor < 1.0 || factor > 2.0) b.fail("neighbours", "must lie in [1, 2] (times r_i + r_j)");
    std::size_t bonded = 0;
    try {
      bonded = system.bonds.bondNeighbours(system.particles, system.cell, factor);
    } catch (const std::invalid_argument& e) {  // the bond search reaches farther than the cell allows
      b.fail("neighbours", e.what());
    }
    if (bonded == 0) b.fail("neighbours", "no particle pairs are close enough to bond");
  }
  const YamlSection snap = params.child("snapshots", {"every", "file"});
  settings.snapshotEvery = snap.integer("every", 0);
  if (settings.snapshotEvery < 0) snap.fail("every", "must be >= 0");
  settings.snapshotFile = snap.text("file", "");
  if (snap.has("file") && settings.snapshotEvery == 0)
    snap.fail("every", "snapshots.file is set but every is " + std::string(snap.has("every") ? "0" : "missing") +
                           ": give every: N (a snapshot every N steps) or drop the snapshots section");
  readZones(params, settings);
  readDrives(params, settings);
  // hybrid: {material: name}: the material of hybrid PD particles (Hartmann Sec. 3);
  // they meet DEM spheres, walls and each other through the scene's contact law.
  // watch_margin: the hybrid watch's margin in m (hybrid_watch.hpp; 0 = every
  // state every exchange; default kWatchMarginPerSkin x the Verlet skin).
  const YamlSection hybrid = params.child("hybrid", {"material", "watch_margin"});
  settings.hybridMaterial = materialOf(hybrid, system);
  if (hybrid.has("watch_margin")) {
    settings.hybridWatchMargin = hybrid.number("watch_margin");
    if (!(settings.hybridWatchMargin >= 0.0) || !std::isfinite(settings.hybridWatchMargin))
      hybrid.fail("watch_margin", "must be a finite distance >= 0 (0 = send every hybrid state)");
  }
}

void checkParticles(const DemSystem& system, double overlapTolerance, const std::string& context) {
  const Particles& p = system.particles;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (const std::string defect = p.defectOf(i); !defect.empty())
      throw SceneError(context + ": particle " + std::to_string(p.id[i]) + ": " + defect);
  // Initial overlaps beyond the tolerance would start the run with a blast.
  if (const auto o = excessOverlap(system, overlapTolerance))
    throw SceneError(context + ": particles " + std::to_string(p.id[o->i]) + " and " + std::to_string(p.id[o->j]) +
                     " overlap by " + std::to_string(o->overlap) + " m at start (tolerance " +
                     std::to_string(o->allowed) + " m, params.overlap_tolerance)");
  checkPlaneOverlaps(system, overlapTolerance, context);
}

void checkPlaneOverlaps(const DemSystem& system, double overlapTolerance, const std::string& context) {
  const Particles& p = system.particles;
  for (const PlaneWall& w : system.planes)
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double overlap = p.radius[i] - w.distance(p.x[i]), allowed = overlapTolerance * p.radius[i];
      if (!(overlap > allowed)) continue;
      std::ostringstream m;
      m << context << ": particle " << p.id[i] << " overlaps plane wall '" << w.name << "' by " << overlap
        << " m at start" << (overlap > p.radius[i] ? " (its centre lies behind the wall)" : "") << " (tolerance "
        << allowed << " m, params.overlap_tolerance)";
      throw SceneError(m.str());
    }
}

std::optional<ExcessOverlap> excessOverlap(const DemSystem& system, double overlapTolerance,
                                           const std::function<bool(std::uint32_t, std::uint32_t)>& considered) {
  const Particles& p = system.particles;
  const NeighborList& nl = system.neighbors;
  for (std::uint32_t i = 0; i + 1 < nl.rowStart.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      if (considered && !considered(i, j)) continue;
      const double overlap = p.radius[i] + p.radius[j] - norm(system.pairVector(i, k));
      const double allowed = overlapTolerance * std::min(p.radius[i], p.radius[j]);
      if (overlap > allowed) return ExcessOverlap{i, j, overlap, allowed};
    }
  return std::nullopt;
}

}  // namespace cosim::dem
