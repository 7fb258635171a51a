// Reading the pd_solver's `params:` section. Every key is checked: an unknown
// or mistyped key is an error naming the file and line.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "cosim/pd/scene.hpp"

namespace cosim::pd {
namespace {

struct Reader {
  const std::string& file;

  [[noreturn]] void fail(const YAML::Node& node, const std::string& message) const {
    throw std::invalid_argument(file + ":" + std::to_string(node.Mark().line + 1) + ": " + message);
  }

  void allowOnly(const YAML::Node& map, const std::string& where, const std::set<std::string>& keys) const {
    if (!map.IsMap()) fail(map, where + " must be a map");
    for (const auto& kv : map) {
      const auto key = kv.first.as<std::string>();
      if (!keys.count(key)) fail(kv.first, "unknown key '" + key + "' in " + where);
    }
  }

  double number(const YAML::Node& node, const std::string& key) const {
    try {
      const double v = node.as<double>();
      if (!std::isfinite(v)) fail(node, "'" + key + "' must be finite");
      return v;
    } catch (const YAML::Exception&) {
      fail(node, "'" + key + "' must be a number");
    }
  }

  double positive(const YAML::Node& node, const std::string& key) const {
    const double v = number(node, key);
    if (!(v > 0.0)) fail(node, "'" + key + "' must be positive, got " + std::to_string(v));
    return v;
  }

  // A whole number in [1, max] (a count of steps, requests or iterations).
  std::uint64_t wholeNumber(const YAML::Node& node, const std::string& key, double max = 1e9) const {
    const double v = number(node, key);
    if (!(v >= 1.0 && v <= max && v == std::floor(v))) {
      std::ostringstream msg;
      msg << "'" << key << "' must be a whole number from 1 to " << static_cast<std::uint64_t>(max) << ", got " << node.as<std::string>();
      fail(node, msg.str());
    }
    return static_cast<std::uint64_t>(v);
  }

  bool flag(const YAML::Node& node, const std::string& key) const {
    try {
      return node.as<bool>();
    } catch (const YAML::Exception&) {
      fail(node, "'" + key + "' must be true or false");
    }
  }

  std::string text(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, "'" + key + "' must be a string");
    return node.as<std::string>();
  }

  Vec3 vec3(const YAML::Node& node, const std::string& key) const {
    if (!node.IsSequence() || node.size() != 3) fail(node, "'" + key + "' must be a list of 3 numbers");
    return {number(node[0], key), number(node[1], key), number(node[2], key)};
  }

  Selection selection(const YAML::Node& node, const std::vector<BodySpec>& bodies) const {
    allowOnly(node, "select", {"body", "min", "max"});
    Selection s;
    if (node["body"]) {
      s.body = text(node["body"], "body");
      if (std::none_of(bodies.begin(), bodies.end(), [&s](const BodySpec& b) { return b.name == s.body; }))
        fail(node["body"], "select names unknown body '" + s.body + "'");
    }
    if (node["min"] || node["max"]) {
      if (!node["min"] || !node["max"]) fail(node, "select needs both 'min' and 'max'");
      s.hasBox = true;
      s.min = vec3(node["min"], "min");
      s.max = vec3(node["max"], "max");
    }
    return s;
  }

  // Keys of one shape given to a body of another are refused, not ignored.
  void shapeKeysOnly(const YAML::Node& node, const std::string& where, const std::string& shape) const {
    static const std::map<std::string, std::set<std::string>> keys = {
        {"box", {"min", "max"}},
        {"sphere", {"center", "radius"}},
        {"cylinder", {"center", "radius", "length", "axis"}},
        {"points", {"file"}}};
    for (const auto* key : {"min", "max", "center", "radius", "length", "axis", "file"})
      if (node[key] && !keys.at(shape).count(key))
        fail(node[key], where + "'" + key + "' does not apply to shape " + shape);
  }

  // Refuses, before anything is allocated, a lattice too large for the
  // particle index or the memory, naming the key to change.
  void sizeFits(const YAML::Node& node, const std::string& where, const BodySpec& b) const {
    if (b.shape == Shape::Points) return;  // counted once the file is read
    std::string key;
    const auto why = bodySizeProblem(b, latticeParticleEstimate(b), key);
    if (!why.empty()) fail(node[key] ? node[key] : node, where + why);
  }

  void influence(const YAML::Node& node, const std::string& where, BodySpec& b) const {
    b.options.influence = text(node, "influence");
    if (b.model != "lps") fail(node, where + "'influence' applies to model lps only");
    try {
      influenceFunction(b.options.influence);
    } catch (const std::invalid_argument& e) {
      fail(node, where + e.what());
    }
  }

  BodySpec body(const YAML::Node& node, const std::string& baseDir) const {
    allowOnly(node, "body", {"name", "shape", "min", "max", "center", "radius", "length", "axis",
                             "file", "spacing", "horizon", "model", "influence", "surface_correction",
                             "critical_stretch", "micromodulus", "partial_volume", "material", "velocity"});
    BodySpec b;
    if (!node["name"]) fail(node, "body needs a 'name'");
    b.name = text(node["name"], "name");
    const auto where = "body '" + b.name + "': ";
    const std::string shape = node["shape"] ? text(node["shape"], "shape") : "box";
    if (shape == "box" || shape == "sphere" || shape == "cylinder" || shape == "points") shapeKeysOnly(node, where, shape);
    if (shape == "box") {
      b.shape = Shape::Box;
      if (!node["min"] || !node["max"]) fail(node, where + "box needs 'min' and 'max'");
      b.min = vec3(node["min"], "min");
      b.max = vec3(node["max"], "max");
      for (int a = 0; a < 3; ++a)
        if (!(b.max[a] > b.min[a])) fail(node["max"], where + "'max' must exceed 'min' in every direction");
    } else if (shape == "sphere" || shape == "cylinder") {
      b.shape = shape == "sphere" ? Shape::Sphere : Shape::Cylinder;
      if (!node["center"] || !node["radius"]) fail(node, where + shape + " needs 'center' and 'radius'");
      b.center = vec3(node["center"], "center");
      b.radius = positive(node["radius"], "radius");
      if (b.shape == Shape::Cylinder) {
        if (!node["length"]) fail(node, where + "cylinder needs 'length'");
        b.length = positive(node["length"], "length");
        const std::string axis = node["axis"] ? text(node["axis"], "axis") : "z";
        if (axis != "x" && axis != "y" && axis != "z") fail(node["axis"], where + "'axis' must be x, y or z");
        b.axis = axis[0] - 'x';
      }
    } else if (shape == "points") {
      b.shape = Shape::Points;
      if (!node["file"]) fail(node, where + "points body needs 'file'");
      std::filesystem::path p = text(node["file"], "file");
      if (p.is_relative() && !baseDir.empty()) p = std::filesystem::path(baseDir) / p;
      b.pointsFile = p.string();
    } else {
      fail(node["shape"], where + "unknown shape '" + shape + "' (box, sphere, cylinder, points)");
    }
    if (node["spacing"]) b.spacing = positive(node["spacing"], "spacing");
    else if (b.shape != Shape::Points) fail(node, where + "'spacing' is required");
    if (node["horizon"]) b.horizonFactor = positive(node["horizon"], "horizon");
    if (node["model"]) b.model = text(node["model"], "model");
    sizeFits(node, where, b);
    if (node["influence"]) influence(node["influence"], where, b);
    if (node["surface_correction"]) b.options.surfaceCorrection = flag(node["surface_correction"], "surface_correction");
    if (node["critical_stretch"]) {
      b.options.criticalStretch = positive(node["critical_stretch"], "critical_stretch");
      if (b.model != "pmb") fail(node["critical_stretch"], where + "critical_stretch needs model pmb");
    }
    if (node["micromodulus"]) {
      b.options.micromodulus = text(node["micromodulus"], "micromodulus");
      if (b.options.micromodulus != "continuum" && b.options.micromodulus != "discrete")
        fail(node["micromodulus"], where + "'micromodulus' must be continuum or discrete");
      if (b.model != "pmb") fail(node["micromodulus"], where + "'micromodulus' applies to model pmb only");
    }
    if (node["partial_volume"]) {
      const auto rule = text(node["partial_volume"], "partial_volume");
      if (rule != "centered" && rule != "truncated")
        fail(node["partial_volume"], where + "'partial_volume' must be centered or truncated");
      b.options.partialVolume = rule == "centered" ? PartialVolume::Centered : PartialVolume::Truncated;
    }
    if (!node["material"]) fail(node, where + "'material' is required");
    const auto m = node["material"];
    allowOnly(m, "material", {"E", "nu", "rho"});
    if (!m["E"] || !m["rho"]) fail(m, where + "material needs 'E' and 'rho'");
    b.material.youngsModulus = positive(m["E"], "E");
    b.material.density = positive(m["rho"], "rho");
    if (m["nu"]) {
      b.material.poissonRatio = number(m["nu"], "nu");
      if (!(b.material.poissonRatio > -1.0 && b.material.poissonRatio < 0.5))
        fail(m["nu"], where + "'nu' must lie in (-1, 0.5)");
    }
    // E near the largest double overflows K = E / (3 (1 - 2 nu)): the wave
    // speed is infinite, the critical step 0 would read as "no limit".
    if (const double c = b.material.cflWaveSpeed(); !(std::isfinite(c) && c > 0.0)) {
      std::ostringstream msg;
      msg << where << "material E, nu, rho give a bulk modulus of " << b.material.bulkModulus() << " Pa and a wave speed of "
          << c << " m/s: both must be finite and positive";
      fail(m["E"], msg.str());
    }
    if (b.model == "pmb" && std::abs(b.material.poissonRatio - 0.25) > 1e-12)
      fail(node, where + "bond-based model pmb requires nu = 0.25 (use lps for other values)");
    if (node["velocity"]) b.initialVelocity = vec3(node["velocity"], "velocity");
    return b;
  }
};

// "LINE: " of the entry an EntryError names, and its key path for a boundary
// or load (body messages name the body); no line for a config built in code.
std::string entryWhere(const PdConfig& c, const EntryError& e) {
  const auto i = e.index();
  const auto at = [i](const std::vector<int>& lines) { return i < lines.size() ? std::to_string(lines[i]) + ": " : " "; };
  switch (e.entry()) {
    case EntryError::Entry::Body:
      return at(c.bodyLines);
    case EntryError::Entry::Boundary:
      return at(c.boundaryLines) + "boundary[" + std::to_string(i) + "]: ";
    case EntryError::Entry::Load:
      return at(c.loadLines) + "loads[" + std::to_string(i) + "]: ";
  }
  return " ";
}

}  // namespace

PdConfig parsePdParams(const YAML::Node& params, const std::string& sceneFile, const std::string& baseDir) {
  Reader r{sceneFile};
  PdConfig c;
  r.allowOnly(params, "params", {"bodies", "boundary", "loads", "body_force", "integrator", "inputs",
                                 "force", "hybrid", "output", "quasi_static", "energy_tolerance", "critical_step",
                                 "work_ahead"});
  const auto bodies = params["bodies"];
  if (!bodies || !bodies.IsSequence() || bodies.size() == 0)
    r.fail(params, "'bodies' must be a non-empty list");
  for (const auto& b : bodies) {
    c.bodies.push_back(r.body(b, baseDir));
    c.bodyLines.push_back(b.Mark().line + 1);
  }
  if (const auto list = params["boundary"]) {
    if (!list.IsSequence()) r.fail(list, "'boundary' must be a list");
    for (const auto& n : list) {
      r.allowOnly(n, "boundary", {"select", "type", "velocity"});
      BoundaryCondition bc;
      if (!n["select"]) r.fail(n, "boundary needs 'select'");
      bc.where = r.selection(n["select"], c.bodies);
      const std::string type = n["type"] ? r.text(n["type"], "type") : "fixed";
      if (type == "fixed") bc.type = Constraint::Fixed;
      else if (type == "velocity") bc.type = Constraint::Velocity;
      else if (type == "normal") bc.type = Constraint::NormalOnly;
      else r.fail(n["type"], "unknown boundary type '" + type + "' (fixed, velocity, normal)");
      if (bc.type == Constraint::Velocity) {
        if (!n["velocity"]) r.fail(n, "velocity boundary needs 'velocity'");
        bc.velocity = r.vec3(n["velocity"], "velocity");
      } else if (n["velocity"]) {
        r.fail(n["velocity"], "'velocity' only applies to type velocity");
      }
      c.boundaries.push_back(bc);
      c.boundaryLines.push_back(n.Mark().line + 1);
    }
  }
  if (const auto list = params["loads"]) {
    if (!list.IsSequence()) r.fail(list, "'loads' must be a list");
    for (const auto& n : list) {
      r.allowOnly(n, "load", {"select", "force"});
      if (!n["select"] || !n["force"]) r.fail(n, "load needs 'select' and 'force'");
      AppliedLoad l;
      l.where = r.selection(n["select"], c.bodies);
      l.force = r.vec3(n["force"], "force");
      c.loads.push_back(l);
      c.loadLines.push_back(n.Mark().line + 1);
    }
  }
  if (const auto n = params["quasi_static"]) {
    r.allowOnly(n, "quasi_static", {"tolerance", "max_iterations"});
    c.quasiStatic = true;
    if (n["tolerance"]) c.relaxTolerance = r.positive(n["tolerance"], "tolerance");
    if (n["max_iterations"])
      c.relaxMaxIterations = static_cast<std::size_t>(r.wholeNumber(n["max_iterations"], "max_iterations"));
  }
  if (params["body_force"]) c.bodyForce = r.vec3(params["body_force"], "body_force");
  if (const auto n = params["integrator"]) {
    const auto v = r.text(n, "integrator");
    if (v != "verlet" && v != "staggered") r.fail(n, "'integrator' must be verlet or staggered");
    c.staggered = v == "staggered";
  }
  if (const auto n = params["inputs"]) {
    const auto v = r.text(n, "inputs");
    if (v != "hold" && v != "interpolate") r.fail(n, "'inputs' must be hold or interpolate");
    c.interpolate = v == "interpolate";
  }
  if (params["force"]) c.force = r.flag(params["force"], "force");
  if (params["work_ahead"]) c.workAhead = r.flag(params["work_ahead"], "work_ahead");
  if (const auto n = params["critical_step"]) {
    const auto v = r.text(n, "critical_step");
    if (v != "rule" && v != "measured") r.fail(n, "'critical_step' must be rule or measured");
    c.measuredCriticalStep = v == "measured";
  }
  if (const auto n = params["energy_tolerance"]) {
    c.energyTolerance = r.number(n, "energy_tolerance");
    if (!(c.energyTolerance >= 0.0)) r.fail(n, "'energy_tolerance' must be >= 0 (0 turns the check off)");
  }
  if (params["hybrid"]) c.hybrid = r.flag(params["hybrid"], "hybrid");
  if (const auto n = params["output"]) {
    r.allowOnly(n, "output", {"file", "every"});
    c.outputFile = n["file"] ? r.text(n["file"], "file") : "pd.h5";
    c.outputEvery = 1;
    if (n["every"]) c.outputEvery = r.wholeNumber(n["every"], "every");
  }
  return c;
}

void buildSystem(const PdConfig& c, PdSystem& system, const std::string& sceneFile) {
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    try {
      system.addBody(c.bodies[b]);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(sceneFile + ":" + std::to_string(c.bodyLines[b]) + ": " + e.what());
    }
  }
  for (const auto& bc : c.boundaries) system.addBoundaryCondition(bc);
  for (const auto& l : c.loads) system.addLoad(l);
  system.setBodyForce(c.bodyForce);
  try {
    system.finalise();
  } catch (const EntryError& e) {
    throw std::invalid_argument(sceneFile + ":" + entryWhere(c, e) + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(sceneFile + ": " + e.what());
  }
  if (c.measuredCriticalStep) system.measureCriticalSteps(kMeasuredStepSafety);
}

}  // namespace cosim::pd
