#include "cosim/fem/solver/fem_solver.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <optional>
#include <sstream>

#include "cosim/fem/coupling/surface_export.hpp"
#include "cosim/fem/material/external_stress.hpp"
#include "cosim/fem/mesh/gmsh_reader.hpp"
#include "cosim/fem/coupling/volume_zone.hpp"
#include "cosim/fem/solver/scene_params.hpp"
#include "cosim/fem/solver/snapshot_writer.hpp"
#include "cosim/util/host_memory.hpp"
#include "cosim/wire/arrays.hpp"
#include "cosim/wire/coupling_forces.hpp"
#include "cosim/wire/weight_profile.hpp"

namespace cosim::fem {

using wire::SolverError;
using Code = proto::Error::Code;

namespace {

constexpr std::uint64_t kCheckpointMagic = 0x33504b4320454546ULL;  // "FEE CKP3": + u at the split step's start (GMH)

YAML::Node findParams(const wire::SetupContext& context, std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(context.sceneYaml);
  } catch (const YAML::Exception& e) {
    throw InputError(context.sceneFile + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  const YAML::Node solvers = root.IsMap() ? root["solvers"] : YAML::Node();
  if (!solvers || !solvers.IsSequence()) throw InputError(context.sceneFile + ": no 'solvers' list");
  for (std::size_t i = 0; i < solvers.size(); ++i) {
    if (!solvers[i].IsMap()) continue;  // the coupler names a malformed entry
    const YAML::Node name = solvers[i]["name"];
    if (name && (name.IsMap() || name.IsSequence()))
      throw InputError(context.sceneFile + ":" + std::to_string(name.Mark().line + 1) + ": solvers[" + std::to_string(i) +
                       "].name: expected a name, got a " + (name.IsMap() ? "map" : "list"));
    if (name && name.IsScalar() && name.Scalar() == context.instance) {
      path = "solvers[" + std::to_string(i) + "].params";
      const YAML::Node params = solvers[i]["params"];
      if (!params)
        throw InputError(context.sceneFile + ":" + std::to_string(solvers[i].Mark().line + 1) + ": solver '" +
                         context.instance + "' has no params section");
      return params;
    }
  }
  throw InputError(context.sceneFile + ": no solver named '" + context.instance + "'");
}

/// Runs make(): an InputError from a library check (an integrator's options,
/// the mass scale) is reported at the scene section that gave the values, so
/// the message names the file, line and key path.
template <typename Make>
auto atSection(ParamMap& section, Make make) {
  try {
    return make();
  } catch (const InputError& e) {
    section.fail(section.node(), section.path() + ": " + e.what());
  }
}

/// A lower bound of a model's memory: per node its state and two sparse
/// matrix rows of a 27-node stencil (stiffness and mass), per hexahedron its
/// quadrature points' geometry and material states. Checked before a box
/// mesh is allocated, so a mistyped division count is refused, not a bad_alloc.
double meshBytes(double nodes, double elements) {
  constexpr double kBytesPerNode = 4096.0, kBytesPerElement = 4096.0;
  return nodes * kBytesPerNode + elements * kBytesPerElement;
}

/// A relative Gmsh file resolves against the scene's directory (`baseDir`), then as given.
Mesh readMesh(ParamMap p, const std::string& baseDir) {
  if (p.has("gmsh")) {
    const std::filesystem::path file = wire::resolveScenePath(p.text("gmsh"), baseDir);
    p.finish();
    try {
      return readGmsh(file.string());
    } catch (const InputError& e) {
      p.fail(p.get("gmsh"), e.what());
    }
  }
  if (!p.has("box")) p.fail(p.node(), p.path() + " needs 'box' or 'gmsh'");
  ParamMap b = p.map("box");
  const Vec3 lo = b.vec3("min"), hi = b.vec3("max");
  const Vec3 n = b.vec3("divisions");
  std::array<int, 3> div{};
  double nodes = 1.0;
  for (int d = 0; d < 3; ++d) {
    if (n[d] < 1 || n[d] != std::floor(n[d])) b.fail(b.get("divisions"), b.path() + ".divisions must be positive integers");
    if (!(hi[d] > lo[d])) b.fail(b.get("max"), b.path() + ".max must exceed min in every direction");
    nodes *= n[d] + 1.0;
  }
  // Node numbers are 32-bit (Index); checked before any cast or allocation.
  if (nodes > static_cast<double>(std::numeric_limits<Index>::max())) {
    std::ostringstream m;
    m << b.path() << ".divisions give " << nodes << " nodes, more than the " << std::numeric_limits<Index>::max()
      << " one mesh can number";
    b.fail(b.get("divisions"), m.str());
  }
  const double bytes = meshBytes(nodes, n[0] * n[1] * n[2]), memory = util::availableMemoryBytes();
  if (bytes > memory) {
    std::ostringstream m;
    m << b.path() << ".divisions give " << nodes << " nodes and " << n[0] * n[1] * n[2] << " hexahedra, about "
      << bytes / 1e9 << " GB for the model: more than the " << memory / 1e9 << " GB of memory available; use fewer divisions";
    b.fail(b.get("divisions"), m.str());
  }
  for (int d = 0; d < 3; ++d) div[static_cast<std::size_t>(d)] = static_cast<int>(n[d]);
  b.finish();
  p.finish();
  return makeBoxMesh(lo, hi, div);
}

int directionIndex(const std::string& s) {
  if (s == "x") return 0;
  if (s == "y") return 1;
  if (s == "z") return 2;
  return -1;
}

/// The keys that only the one-point element reads are refused for any other one.
void requireOnePoint(ParamMap& p, const std::string& key, const std::string& formulation) {
  if (formulation != "one-point")
    p.fail(p.get(key), p.path() + "." + key + " applies to formulation one-point only (formulation is " + formulation + ")");
}

/// `hourglass: 0.05` (stiffness type, the old form) or
/// `hourglass: {type: stiffness | viscous, coefficient: 0.05}`.
void readHourglass(ParamMap& p, FormulationOptions& fo) {
  YAML::Node h = p.get("hourglass");
  if (!h.IsMap()) {
    fo.hourglassCoefficient = p.number("hourglass");
    if (fo.hourglassCoefficient < 0.0) p.fail(h, p.path() + ".hourglass must be >= 0");
    return;
  }
  ParamMap hm(h, p.file(), p.path() + ".hourglass");
  const std::string type = hm.text("type", "stiffness");
  if (type != "stiffness" && type != "viscous") hm.fail(hm.get("type"), hm.path() + ".type must be stiffness or viscous");
  fo.hourglassType = type == "viscous" ? FormulationOptions::Hourglass::viscous : FormulationOptions::Hourglass::stiffness;
  fo.hourglassCoefficient = hm.number("coefficient", fo.hourglassCoefficient);
  if (fo.hourglassCoefficient < 0.0) hm.fail(hm.get("coefficient"), hm.path() + ".coefficient must be >= 0");
  hm.finish();
}

/// Every key of FormulationOptions: `hourglass` and `stiffness_damping: beta`
/// (Rayleigh C = beta K as an element viscosity, docs/fem.md), one-point only.
FormulationOptions readFormulationOptions(ParamMap& p, const std::string& formulation) {
  FormulationOptions fo;
  if (p.has("hourglass")) {
    readHourglass(p, fo);
    requireOnePoint(p, "hourglass", formulation);
  }
  if (p.has("stiffness_damping")) {
    fo.stiffnessDamping = p.number("stiffness_damping");
    if (!(fo.stiffnessDamping >= 0.0))
      p.fail(p.get("stiffness_damping"), p.path() + ".stiffness_damping must be >= 0 (Rayleigh beta, s)");
    requireOnePoint(p, "stiffness_damping", formulation);
  }
  return fo;
}

/// `boundary[i].dofs`: a non-empty list of x, y, z; all three when absent.
std::vector<int> readDofs(ParamMap& b) {
  if (!b.has("dofs")) return {0, 1, 2};
  const std::string key = b.path() + ".dofs";
  const std::vector<std::string> names = b.names("dofs", "x, y, z");
  if (names.empty()) b.fail(b.get("dofs"), key + ": expected a non-empty list of x, y, z, got an empty list");
  std::vector<int> dirs;
  for (const std::string& name : names) {
    const int k = directionIndex(name);
    if (k < 0) b.fail(b.get("dofs"), key + " entries must be x, y or z, not '" + name + "'");
    dirs.push_back(k);
  }
  return dirs;
}

/// kind, value, ramp (>= 0) and frequency (>= 0, a sine instead of the ramp)
/// of a boundary entry.
Prescribed readPrescription(ParamMap& b) {
  const std::string key = b.path();
  const std::string kind = b.text("kind", "displacement");
  if (kind != "displacement" && kind != "velocity") b.fail(b.get("kind"), key + ".kind must be displacement or velocity");
  Prescribed pr;
  pr.kind = kind == "velocity" ? Prescribed::Kind::velocity : Prescribed::Kind::displacement;
  pr.amplitude = b.number("value", 0.0);
  pr.ramp = b.number("ramp", 0.0);
  if (pr.ramp < 0.0) b.fail(b.get("ramp"), key + ".ramp must be >= 0 (s)");
  // frequency: a sinusoidal time function (cyclic loading, Liu 2016 Sec. 3.3) instead of the ramp.
  pr.frequency = b.number("frequency", 0.0);
  if (pr.frequency < 0.0) b.fail(b.get("frequency"), key + ".frequency must be >= 0 (Hz)");
  if (pr.frequency > 0.0 && b.has("ramp"))
    b.fail(b.get("ramp"), key + ".ramp cannot be combined with frequency (the sine starts from zero displacement)");
  return pr;
}

/// The largest speed a prescription reaches: value for a velocity, value x
/// 2 pi frequency for a sine displacement, value / ramp for a ramped one.
double peakVelocity(const Prescribed& p) {
  if (p.kind == Prescribed::Kind::velocity) return p.amplitude;
  if (p.frequency > 0.0) return p.amplitude * 2.0 * std::numbers::pi * p.frequency;
  return p.ramp > 0.0 ? p.amplitude / p.ramp : 0.0;
}

/// The diagonal of the mesh's bounding box.
double meshSize(const Mesh& mesh) {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (std::size_t n = 0; n < mesh.numNodes(); ++n) {
    lo = lo.cwiseMin(mesh.node(static_cast<Index>(n)));
    hi = hi.cwiseMax(mesh.node(static_cast<Index>(n)));
  }
  return (hi - lo).norm();
}

/// Why moving the given dofs by u (the rest held) breaks the strain energy, or
/// empty: a non-finite energy, or an element or material failure under a
/// displacement over a million times the mesh size (a smaller one may just
/// invert an element when applied alone: no verdict).
std::string strainProblem(const Model& model, const std::vector<Index>& nodes, const std::vector<int>& dirs, double u) {
  std::vector<double> x(model.numDofs(), 0.0), f;
  for (Index n : nodes)
    for (int d : dirs) x[3 * static_cast<std::size_t>(n) + static_cast<std::size_t>(d)] = u;
  ElementEnergy e;
  try {
    model.internalForce(x, f, e);
  } catch (const SolveError& ex) {
    return std::abs(u) > 1e6 * meshSize(model.mesh()) ? std::string("the model cannot take it (") + ex.what() + ")" : "";
  } catch (const InputError&) {
    return {};
  }
  return std::isfinite(e.strain) && std::isfinite(e.hourglass) ? "" : "it gives a non-finite strain energy";
}

std::string show(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

/// Refuses a prescription beyond double range before it turns into NaN:
/// value x 2 pi frequency, value / ramp, and the kinetic and strain energy of
/// the entry's nodes moved at its peak velocity and by its value.
void checkPrescribedRange(const Model& model, ParamMap& b, const std::vector<Index>& nodes,
                          const std::vector<int>& dirs, const Prescribed& p) {
  const std::string key = b.path();
  const double omega = 2.0 * std::numbers::pi * p.frequency;
  if (!std::isfinite(omega) || !std::isfinite(p.amplitude * omega))
    b.fail(b.get("frequency"), key + ".frequency: value x 2 pi frequency is not finite (value " + show(p.amplitude) +
                                   ", frequency " + show(p.frequency) + " Hz)");
  const double v = peakVelocity(p);
  if (!std::isfinite(v)) b.fail(b.get("ramp"), key + ".ramp: value / ramp is not a finite velocity");
  double kinetic = 0.0;
  for (Index n : nodes) kinetic += 0.5 * model.lumpedMass()[n] * v * v * static_cast<double>(dirs.size());
  if (!std::isfinite(kinetic))
    b.fail(b.get("value"), key + ".value: the prescribed velocity of " + show(v) + " m/s gives a non-finite kinetic energy");
  if (p.kind != Prescribed::Kind::displacement || p.amplitude == 0.0) return;
  if (const std::string why = strainProblem(model, nodes, dirs, p.amplitude); !why.empty())
    b.fail(b.get("value"), key + ".value: a prescribed displacement of " + show(p.amplitude) + " m: " + why);
}

/// `arlequin:` (Cheng 2022 Eq. 25), validated even when the coupler's profile wins.
std::optional<WeightProfile> readArlequin(ParamMap& p) {
  if (!p.has("arlequin")) return std::nullopt;
  ParamMap a = p.map("arlequin");
  WeightProfile profile;
  profile.kind = a.text("kind", "half-cosine");
  profile.axis = directionIndex(a.text("axis"));
  if (profile.axis < 0) a.fail(a.get("axis"), a.path() + ".axis must be x, y or z");
  profile.start = a.number("start");
  profile.end = a.number("end");
  profile.low = a.number("w_min", 0.0);
  profile.high = a.number("w_max", 1.0);
  const std::string where = a.text("fem_weights", "points");
  if (where != "points" && where != "nodes") a.fail(a.get("fem_weights"), a.path() + ".fem_weights must be points or nodes");
  profile.nodalFem = where == "nodes";
  a.finish();
  if (const std::string why = profile.problem(); !why.empty()) a.fail(a.node(), a.path() + ": weight profile: " + why);
  return profile;
}

}  // namespace

FemSolver::FemSolver() = default;
FemSolver::~FemSolver() = default;

wire::SolverInfo FemSolver::info() const {
  wire::SolverInfo i;
  i.kind = "fem";
  i.version = "0.1.0";
  i.capabilities = wire::baseCapabilities();
  for (const char* c : {"surface-export", "nodal-forces", "volume-zones", "critical-dt", "energies"})
    i.capabilities.emplace_back(c);
  return i;
}

void FemSolver::setup(const wire::SetupContext& context, proto::CouplingData::Builder outputs) {
  try {
    std::string path;
    YAML::Node params = findParams(context, path);
    ParamMap p(params, context.sceneFile, path);
    Mesh mesh = readMesh(p.map("mesh"), context.baseDir());
    // Named node/face sets by box: nodes in the box, boundary faces with all nodes in it.
    if (p.has("sets")) {
      YAML::Node sets = p.get("sets");
      if (!sets.IsMap()) p.fail(sets, path + ".sets must be a map of name: {box: {min, max}}");
      for (const auto& kv : sets) {
        const std::string name = p.keyName(kv.first, path + ".sets");
        ParamMap s(kv.second, context.sceneFile, path + ".sets." + name);
        ParamMap box = s.map("box");
        const Vec3 lo = box.vec3("min"), hi = box.vec3("max");
        box.finish();
        s.finish();
        mesh.nodeSets[name] = mesh.nodesInBox(lo, hi);
        mesh.faceSets[name] = mesh.boundaryFacesInBox(lo, hi);
        if (mesh.nodeSets[name].empty()) s.fail(kv.second, "set '" + name + "' contains no nodes");
      }
    }
    ParamMap mat = p.map("material");
    const std::string matName = mat.text("model", "st-venant-kirchhoff");
    MaterialParams mp{mat.number("E"), mat.number("nu"), mat.number("density")};
    // GMH cells' frame (external material only): Liu's corotational one or spatial.
    std::optional<CellFrame> cellFrame;
    if (mat.has("frame")) {
      const std::string f = mat.text("frame");
      if (matName != "external") mat.fail(mat.get("frame"), path + ".material.frame applies to model: external only");
      if (f != "corotational" && f != "spatial")
        mat.fail(mat.get("frame"), path + ".material.frame must be corotational or spatial, not '" + f + "'");
      cellFrame = f == "spatial" ? CellFrame::Spatial : CellFrame::Corotational;
    }
    mat.finish();
    const std::string formName = p.text("formulation", "full");
    const FormulationOptions fo = readFormulationOptions(p, formName);
    std::unique_ptr<Material> material;
    std::unique_ptr<ElementFormulation> formulation;
    atSection(p, [&] {
      material = MaterialRegistry::instance().create(matName, mp);
      formulation = FormulationRegistry::instance().create(formName);
      model_ = std::make_unique<Model>(std::move(mesh), std::move(material), std::move(formulation), fo);
    });
    if (p.has("boundary")) readBoundary(p);
    if (p.has("periodic")) readPeriodic(p);
    // Loads.
    if (p.has("loads")) {
      YAML::Node list = p.get("loads");
      if (!list.IsSequence()) p.fail(list, path + ".loads must be a list");
      for (std::size_t i = 0; i < list.size(); ++i) {
        const std::string key = path + ".loads[" + std::to_string(i) + "]";
        ParamMap l(list[i], context.sceneFile, key);
        const std::string set = l.text("set");
        try {
          if (l.has("traction")) {
            model_->addTraction(model_->mesh().faceSet(set, key + ".set"), l.vec3("traction"));
          } else if (l.has("pressure")) {
            model_->addPressure(model_->mesh().faceSet(set, key + ".set"), l.number("pressure"));
          } else if (l.has("nodal_force")) {
            const Vec3 f = l.vec3("nodal_force");
            for (Index n : model_->mesh().nodeSet(set, key + ".set"))
              for (int d = 0; d < 3; ++d) model_->referenceLoad()[3 * n + static_cast<std::size_t>(d)] += f[d];
          } else {
            l.fail(list[i], key + " needs 'traction' or 'pressure' (face set) or 'nodal_force' (node set)");
          }
        } catch (const InputError& e) {
          if (std::string(e.what()).find(context.sceneFile) == 0) throw;
          l.fail(l.get("set"), e.what());
        }
        l.finish();
      }
    }
    if (p.has("body_force")) model_->addBodyForce(p.vec3("body_force"));
    initialVelocity_ = InitialVelocity{};
    if (p.has("initial_velocity")) {
      ParamMap iv = p.map("initial_velocity");
      if (iv.has("velocity")) initialVelocity_.v0 = iv.vec3("velocity");
      if (iv.has("origin")) initialVelocity_.origin = iv.vec3("origin");
      if (iv.has("gradient")) {
        ParamMap g = iv.map("gradient");  // row i: the gradient of v_i
        const char* rows[3] = {"x", "y", "z"};
        for (int i = 0; i < 3; ++i)
          if (g.has(rows[i])) initialVelocity_.gradient.row(i) = g.vec3(rows[i]).transpose();
        g.finish();
      }
      iv.finish();
    }
    const double loadRamp = p.number("load_ramp", 0.0);
    if (loadRamp < 0.0) p.fail(p.get("load_ramp"), path + ".load_ramp must be >= 0 (s)");
    model_->setLoadRamp(loadRamp);
    // Integrator.
    ParamMap in = p.map("integrator");
    integratorType_ = in.text("type");
    force_ = in.flag("force", false);
    NewtonOptions newton;
    const bool relaxation = integratorType_ == "dynamic-relaxation";
    newton.tolerance = in.number("tolerance", relaxation ? relaxation_.tolerance : newton.tolerance);
    newton.maxIterations = in.integer("max_iterations", relaxation ? relaxation_.maxIterations : newton.maxIterations);
    if (!(newton.tolerance > 0.0)) in.fail(in.get("tolerance"), in.path() + ".tolerance must be > 0");
    if (newton.maxIterations <= 0) in.fail(in.get("max_iterations"), in.path() + ".max_iterations must be > 0");
    relaxation_.tolerance = newton.tolerance;
    relaxation_.maxIterations = newton.maxIterations;
    newton.linearSolver = in.text("linear_solver", newton.linearSolver);
    newton.tangentReuse = static_cast<int>(in.integer("tangent_reuse", 0));
    if (newton.tangentReuse < 0) in.fail(in.get("tangent_reuse"), in.path() + ".tangent_reuse must be >= 0");
    if (const auto& names = linearSolverNames();
        std::find(names.begin(), names.end(), newton.linearSolver) == names.end())
      in.fail(in.get("linear_solver"), in.path() + ".linear_solver must be direct, cholmod, ldlt, profile or cg");
    if (integratorType_ == "newmark") {
      NewmarkOptions o;
      o.gamma = in.number("gamma", o.gamma);
      // Without beta, the unconditionally stable beta = (gamma + 1/2)^2 / 4 with the
      // most high-frequency dissipation for that gamma (Hughes, The Finite Element Method, 1987, Ch. 9): 1/4
      // for the trapezoidal rule. gamma > 1/2 damps the modes the step cannot
      // resolve; the scheme is then first order, its error in a resolved mode
      // of order (gamma - 1/2) omega dt.
      o.beta = in.number("beta", 0.25 * (o.gamma + 0.5) * (o.gamma + 0.5));
      const std::string mass = in.text("mass", "consistent");
      if (mass != "consistent" && mass != "lumped") in.fail(in.get("mass"), in.path() + ".mass must be consistent or lumped");
      o.lumpedMass = mass == "lumped";
      o.linear = in.flag("linear", false);
      o.newton = newton;
      integrator_ = atSection(in, [&] { return makeNewmark(*model_, o); });
    } else if (integratorType_ == "central-difference") {
      CentralDifferenceOptions o;
      o.damping = in.number("damping", 0.0);
      const double massScale = in.number("mass_scaling", 1.0);
      integrator_ = atSection(in, [&] {
        model_->setMassScale(massScale);
        return makeCentralDifference(*model_, o);
      });
    } else if (integratorType_ == "static" || relaxation) {
      staticNewton_ = newton;
      if (!relaxation) staticLinear_ = in.flag("linear", false);
      if (relaxation) {
        const double massScale = in.number("mass_scaling", 1.0);
        atSection(in, [&] { model_->setMassScale(massScale); });
      }
    } else {
      in.fail(in.get("type"), in.path() + ".type must be newmark, central-difference, static or dynamic-relaxation");
    }
    if (model_->formulation().hasViscousForce() && integratorType_ != "central-difference")
      in.fail(in.get("type"), in.path() + ".type is " + integratorType_ +
                                  ", but viscous element forces (hourglass type viscous, stiffness_damping) need central-difference");
    in.finish();
    // Arlequin weighting 1 - w (Cheng 2022 Eq. 25): a profile sent by the
    // coupler at setup wins over one in the params.
    const std::optional<WeightProfile> own = readArlequin(p);
    bool haveProfile = own.has_value();
    WeightProfile profile = own.value_or(WeightProfile{});
    if (context.inputs.hasWeightProfiles() && context.inputs.getWeightProfiles().size() > 0) {
      profile = wire::read(context.inputs.getWeightProfiles()[0]);
      haveProfile = true;
    }
    if (haveProfile) {
      try {
        model_->setArlequinWeight(profile);
      } catch (const InputError& e) {
        p.fail(p.node(), path + ".arlequin: " + e.what());
      }
    }
    // Coupling exports: named face sets as triangle meshes (+ quadrature points).
    surfaces_.clear();
    zones_.clear();
    if (p.has("coupling")) {
      ParamMap cp = p.map("coupling");
      const std::vector<std::string> names = cp.has("surfaces") ? cp.names("surfaces", "face set names") : std::vector<std::string>{};
      if (cp.has("zones")) {
        YAML::Node zl = cp.get("zones");
        if (!zl.IsMap()) cp.fail(zl, cp.path() + ".zones must be a map of name: {box: {min, max}}");
        for (const auto& kv : zl) {
          const std::string zname = cp.keyName(kv.first, cp.path() + ".zones");
          ParamMap z(kv.second, context.sceneFile, cp.path() + ".zones." + zname);
          ParamMap box = z.map("box");
          const Vec3 lo = box.vec3("min"), hi = box.vec3("max");
          box.finish();
          z.finish();
          try {
            zones_.emplace_back(zname, model_->mesh(), lo, hi);
          } catch (const InputError& e) {
            z.fail(kv.second, e.what());
          }
        }
      }
      for (std::size_t i = 0; i < names.size(); ++i) {
        try {
          surfaces_.emplace_back(names[i], model_->mesh(), model_->mesh().faceSet(names[i], cp.path() + ".surfaces"));
        } catch (const InputError& e) {
          cp.fail(cp.get("surfaces")[i], e.what());
        }
      }
      // The quadrature of the CG-enriched force map: every exchange (true), or
      // only with the setup outputs (setup: the smoothed wall reads it once).
      const std::string quadrature = cp.text("quadrature", "false");
      if (quadrature != "true" && quadrature != "false" && quadrature != "setup")
        cp.fail(cp.node(), cp.path() + ".quadrature must be true, false or setup, got '" + quadrature + "'");
      surfaceQuadrature_ = quadrature == "true" ? QuadratureExport::EveryExchange
                           : quadrature == "setup" ? QuadratureExport::SetupOnly
                                                   : QuadratureExport::None;
      cp.finish();
    }
    if (p.has("output")) {
      ParamMap o = p.map("output");
      outputEvery_ = o.integer("every", 0);
      const std::string file = o.text("file", context.instance + ".h5");
      o.finish();
      if (outputEvery_ < 0) o.fail(o.node(), o.path() + ".every must be >= 0");
      if (outputEvery_ > 0) {
        const std::filesystem::path dir = context.runDir.empty() ? std::filesystem::path(".") : std::filesystem::path(context.runDir);
        try {
          snapshots_ = std::make_unique<SnapshotWriter>(dir / file, *model_, context.resuming);
        } catch (const std::runtime_error& e) {  // the HDF5 file cannot be created there
          o.fail(o.node(), o.path() + ".file: " + e.what());
        }
      }
    }
    p.finish();
    // GMH: an external material takes its stresses from unit-cell results.
    external_ = dynamic_cast<ExternalStressMaterial*>(&model_->material());
    if (external_ && cellFrame) external_->setFrame(*cellFrame);
    state_ = State{};
    state_.resize(model_->numDofs());
    const auto& X = model_->mesh().X;
    for (std::size_t n = 0; 3 * n < X.size(); ++n) {
      const Vec3 v = initialVelocity_.v0 +
                     initialVelocity_.gradient * (Vec3(X[3 * n], X[3 * n + 1], X[3 * n + 2]) - initialVelocity_.origin);
      for (int d = 0; d < 3; ++d) state_.v[3 * n + static_cast<std::size_t>(d)] = v[d];
    }
    if (external_) pointF_ = pointDeformationGradients();
    if (integrator_) integrator_->initialise(state_);
    if (snapshots_ && !context.resuming) snapshots_->write(*model_, state_);
    fillCouplingOutputs(outputs, true);
  } catch (const InputError& e) {
    throw SolverError(Code::BAD_INPUT, e.what());
  } catch (const SolveError& e) {  // the initial state the params give cannot be evaluated
    throw SolverError(Code::SOLVER_FAILURE, context.sceneFile + ": solver '" + context.instance + "': " + e.what());
  }
}

void FemSolver::readBoundary(ParamMap& p) {
  YAML::Node list = p.get("boundary");
  if (!list.IsSequence()) p.fail(list, p.path() + ".boundary must be a list");
  for (std::size_t i = 0; i < list.size(); ++i) {
    ParamMap b(list[i], p.file(), p.path() + ".boundary[" + std::to_string(i) + "]");
    const std::string set = b.text("set");
    std::vector<Index> nodes;
    try {
      nodes = model_->mesh().nodeSet(set, b.path() + ".set");
    } catch (const InputError& e) {
      b.fail(b.get("set"), e.what());
    }
    const std::vector<int> dirs = readDofs(b);
    const Prescribed pr = readPrescription(b);
    b.finish();
    checkPrescribedRange(*model_, b, nodes, dirs, pr);
    for (Index n : nodes)
      for (int d : dirs) model_->prescribe(n, d, pr.kind, pr.amplitude, pr.ramp, pr.frequency);
  }
}

void FemSolver::readPeriodic(ParamMap& p) {
  YAML::Node list = p.get("periodic");
  if (!list.IsSequence()) p.fail(list, p.path() + ".periodic must be a list");
  const Mesh& mesh = model_->mesh();
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (std::size_t n = 0; n < mesh.numNodes(); ++n) {
    lo = lo.cwiseMin(mesh.node(static_cast<Index>(n)));
    hi = hi.cwiseMax(mesh.node(static_cast<Index>(n)));
  }
  for (std::size_t i = 0; i < list.size(); ++i) {
    ParamMap e(list[i], p.file(), p.path() + ".periodic[" + std::to_string(i) + "]");
    const double tol = e.number("tolerance", 1e-8 * (hi - lo).norm());
    if (!(tol > 0.0)) e.fail(e.get("tolerance"), e.path() + ".tolerance must be > 0 (a length)");
    std::vector<Index> minNodes, maxNodes;
    Vec3 offset = Vec3::Zero();
    if (e.has("axis")) {  // the two faces of the bounding box normal to the axis
      const int axis = directionIndex(e.text("axis"));
      if (axis < 0) e.fail(e.get("axis"), e.path() + ".axis must be x, y or z");
      offset[axis] = hi[axis] - lo[axis];
      for (std::size_t n = 0; n < mesh.numNodes(); ++n) {
        const double x = mesh.X[3 * n + static_cast<std::size_t>(axis)];
        if (x <= lo[axis] + tol) minNodes.push_back(static_cast<Index>(n));
        if (x >= hi[axis] - tol) maxNodes.push_back(static_cast<Index>(n));
      }
      if (e.has("offset")) offset = e.vec3("offset");
    } else if (e.has("min") && e.has("max")) {  // named node sets, offset required
      try {
        minNodes = mesh.nodeSet(e.text("min"), e.path() + ".min");
        maxNodes = mesh.nodeSet(e.text("max"), e.path() + ".max");
      } catch (const InputError& ex) {
        e.fail(e.node(), ex.what());
      }
      offset = e.vec3("offset");
    } else {
      e.fail(e.node(), e.path() + " needs 'axis' (x, y or z) or the node sets 'min' and 'max' with an 'offset'");
    }
    const Vec3 jump = e.has("jump") ? e.vec3("jump") : Vec3::Zero();
    const std::string kind = e.text("kind", "displacement");
    if (kind != "displacement" && kind != "velocity") e.fail(e.get("kind"), e.path() + ".kind must be displacement or velocity");
    const double ramp = e.number("ramp", 0.0);
    if (ramp < 0.0) e.fail(e.get("ramp"), e.path() + ".ramp must be >= 0 (s)");
    e.finish();
    try {
      model_->tie(matchPeriodicNodes(mesh, minNodes, maxNodes, offset, tol), jump,
                  kind == "velocity" ? Prescribed::Kind::velocity : Prescribed::Kind::displacement, ramp);
    } catch (const InputError& ex) {
      e.fail(e.node(), e.path() + ": " + ex.what());
    }
  }
}

void FemSolver::applyCouplingForces(proto::CouplingData::Reader inputs) {
  auto& f = model_->couplingForce();
  std::fill(f.begin(), f.end(), 0.0);
  wire::forEachCouplingForce(inputs.getForces(), proto::CouplingForces::Target::NODES, model_->numNodes(), "node",
                             [&f](std::uint32_t id, const double* force) {
                               for (std::size_t d = 0; d < 3; ++d) f[3 * id + d] += force[d];
                             });
}

void FemSolver::fillCouplingOutputs(proto::CouplingData::Builder outputs, bool atSetup) const {
  if (!zones_.empty()) {
    auto arrays = outputs.initArrays(static_cast<unsigned>(zones_.size() * VolumeZone::kArrays));
    for (unsigned i = 0; i < zones_.size(); ++i)
      zones_[i].fill(arrays, i * VolumeZone::kArrays, model_->mesh(), state_.u, state_.v, model_->lumpedMass());
  }
  if (surfaces_.empty()) return;
  auto meshes = outputs.initMeshes(static_cast<unsigned>(surfaces_.size()));
  for (unsigned i = 0; i < surfaces_.size(); ++i) surfaces_[i].fillMesh(meshes[i], model_->mesh(), state_.u, state_.v);
  if (surfaceQuadrature_ == QuadratureExport::None || (surfaceQuadrature_ == QuadratureExport::SetupOnly && !atSetup))
    return;
  auto quads = outputs.initQuadratures(static_cast<unsigned>(surfaces_.size()));
  for (unsigned i = 0; i < surfaces_.size(); ++i) surfaces_[i].fillQuadrature(quads[i], model_->mesh(), state_.u);
}

void FemSolver::advance(const wire::AdvanceRequest& request, proto::CouplingData::Builder outputs) {
  if (!model_) throw SolverError(Code::UNEXPECTED, "advance before setup");
  const double crit = criticalDt();
  if (crit > 0.0 && request.dt > crit && !force_)
    throw SolverError(Code::BAD_INPUT, "advance: dt = " + std::to_string(request.dt) +
                                           " s exceeds the critical step " + std::to_string(crit) +
                                           " s of the explicit FEM (set integrator.force: true to run anyway)");
  applyCouplingForces(request.inputs);
  applyUnitCellResults(request.inputs);
  try {
    if (external_) {
      // GMH (Liu 2016 Fig. 3): the stresses just received belong to the
      // predicted positions: finish that step, then predict the next one and
      // send its corotational strain increments. One step per exchange.
      if (request.steps != 1)
        throw SolverError(Code::BAD_INPUT, "advance: the external (GMH) material exchanges every step; got steps = " +
                                               std::to_string(request.steps));
      if (!integrator_) throw SolverError(Code::BAD_INPUT, "the external (GMH) material needs integrator.type: central-difference");
      if (pendingDt_ > 0.0) integrator_->correct(state_, pendingDt_);
      integrator_->predict(state_, request.dt);
      pendingDt_ = request.dt;
      if (snapshots_ && outputEvery_ > 0 && state_.step % static_cast<std::uint64_t>(outputEvery_) == 0)
        snapshots_->write(*model_, state_);
    }
    for (std::uint32_t s = 0; s < request.steps && !external_; ++s) {
      if (integrator_) {
        integrator_->step(state_, request.dt);
      } else {
        state_.time += request.dt;
        if (integratorType_ == "dynamic-relaxation")
          relaxStatic(*model_, state_, relaxation_);
        else if (staticLinear_)
          solveLinearStatic(*model_, state_, staticNewton_.linearSolver);
        else
          solveStatic(*model_, state_, staticNewton_);
        ++state_.step;
      }
      if (snapshots_ && outputEvery_ > 0 && state_.step % static_cast<std::uint64_t>(outputEvery_) == 0)
        snapshots_->write(*model_, state_);
    }
  } catch (const SolveError& e) {
    throw SolverError(Code::SOLVER_FAILURE, e.what());
  }
  fillCouplingOutputs(outputs, false);
  if (external_) fillUnitCellJobs(outputs, request.dt * request.steps);
}

std::vector<double> FemSolver::pointDeformationGradients() const {
  const int np = model_->formulation().pointsPerElement();
  std::vector<double> out(9 * model_->mesh().numElements() * static_cast<std::size_t>(np));
  std::vector<MaterialPointState> pts(static_cast<std::size_t>(np));
  // F does not depend on the stress: evaluate the kinematics only.
  for (std::size_t e = 0; e < model_->mesh().numElements(); ++e) {
    model_->formulation().pointStates(e, model_->gather(e, state_.u), pts.data());
    for (int q = 0; q < np; ++q) {
      const std::size_t p = e * static_cast<std::size_t>(np) + static_cast<std::size_t>(q);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) out[9 * p + static_cast<std::size_t>(3 * i + j)] = pts[static_cast<std::size_t>(q)].F(i, j);
    }
  }
  return out;
}

void FemSolver::applyUnitCellResults(proto::CouplingData::Reader inputs) {
  if (!inputs.hasUnitCellResults()) return;
  for (auto results : inputs.getUnitCellResults()) {
    if (!external_) throw SolverError(Code::BAD_INPUT, "unit-cell results received but the material is not 'external'");
    const auto ids = wire::view(results.getCellIds());
    const auto stresses = wire::view(results.getStresses());
    if (stresses.size() != 9 * ids.size())
      throw SolverError(Code::BAD_INPUT, "unit-cell results: " + std::to_string(stresses.size()) + " stress values for " +
                                             std::to_string(ids.size()) + " cells (need 9 each)");
    for (std::size_t k = 0; k < ids.size(); ++k) {
      for (std::size_t c = 0; c < 9; ++c)
        if (!std::isfinite(stresses[9 * k + c]))
          throw SolverError(Code::BAD_INPUT, "unit-cell results: non-finite stress for cell " + std::to_string(ids[k]));
      try {
        external_->setCellStress(ids[k], stresses.data() + 9 * k);
      } catch (const InputError& e) {
        throw SolverError(Code::BAD_INPUT, std::string("unit-cell results: ") + e.what());
      }
    }
  }
}

void FemSolver::fillUnitCellJobs(proto::CouplingData::Builder outputs, double dt) {
  // The strain increment of every point over the exchange interval, in its
  // cell's frame: corotational from the midstep gradient (Liu 2016 Eqs.
  // 60-61) or the whole logarithmic one (frame: spatial).
  const std::vector<double> Fnew = pointDeformationGradients();
  const std::size_t np = Fnew.size() / 9;
  auto jobs = outputs.initUnitCellJobs(1)[0];
  jobs.setDt(dt);
  auto ids = jobs.initCellIds(static_cast<unsigned>(np));
  auto inc = jobs.initStrainIncrements(static_cast<unsigned>(9 * np));
  auto positions = wire::view(jobs.initPositions(static_cast<unsigned>(3 * np)));
  const int perElement = model_->formulation().pointsPerElement();
  for (std::size_t p = 0; p < np; ++p) {
    const Vec3 x = model_->materialPoint(p / static_cast<std::size_t>(perElement), static_cast<int>(p % static_cast<std::size_t>(perElement)));
    for (int d = 0; d < 3; ++d) positions[3 * p + static_cast<std::size_t>(d)] = x[d];
  }
  for (std::size_t p = 0; p < np; ++p) {
    const Mat3 F0 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(pointF_.data() + 9 * p);
    const Mat3 F1 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(Fnew.data() + 9 * p);
    Mat3 d;
    try {
      d = external_->cellIncrement(F0, F1);
    } catch (const InputError& e) {
      throw SolverError(Code::SOLVER_FAILURE, "material point " + std::to_string(p) + ": " + e.what());
    }
    ids.set(static_cast<unsigned>(p), static_cast<std::uint32_t>(p));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) inc.set(static_cast<unsigned>(9 * p + static_cast<std::size_t>(3 * i + j)), d(i, j));
  }
  pointF_ = Fnew;
}

void FemSolver::fields(const std::vector<std::string>& names, proto::CouplingData::Builder out) {
  if (!model_) throw SolverError(Code::UNEXPECTED, "fields before setup");
  std::vector<std::string> wanted = names;
  if (wanted.empty()) wanted = {"displacement", "velocity", "position"};
  std::vector<double> position(model_->mesh().X);
  for (std::size_t d = 0; d < position.size(); ++d) position[d] += state_.u[d];
  auto arrays = out.initArrays(static_cast<unsigned>(wanted.size()));
  for (unsigned i = 0; i < wanted.size(); ++i) {
    const std::string& n = wanted[i];
    if (n == "displacement") wire::addArray(arrays, i, n, 3, state_.u);
    else if (n == "velocity") wire::addArray(arrays, i, n, 3, state_.v);
    else if (n == "position") wire::addArray(arrays, i, n, 3, position);
    else throw SolverError(Code::BAD_INPUT, "fields: unknown field '" + n + "' (offered: displacement, velocity, position)");
  }
}

std::uint64_t FemSolver::checkpoint(const std::string& path) {
  if (!model_) throw SolverError(Code::UNEXPECTED, "checkpoint before setup");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw SolverError(Code::SOLVER_FAILURE, "checkpoint: cannot write " + path);
  auto put = [&](const void* p, std::size_t n) { out.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); };
  const std::uint64_t dofs = state_.u.size();
  put(&kCheckpointMagic, 8);
  put(&dofs, 8);
  put(&state_.time, 8);
  put(&state_.step, 8);
  put(&state_.externalWork, 8);
  put(&state_.viscousDissipated, 8);
  for (const auto* v : {&state_.u, &state_.v, &state_.a, &state_.fApplied, &state_.fViscous}) put(v->data(), 8 * v->size());
  if (external_) {  // GMH state: corotational stresses and F at the last exchange
    put(external_->stresses().data(), 8 * external_->stresses().size());
    put(pointF_.data(), 8 * pointF_.size());
    put(&pendingDt_, 8);
    const std::uint64_t started = state_.uStepStart.size();  // 0 before the first step
    put(&started, 8);
    put(state_.uStepStart.data(), 8 * started);
  }
  out.flush();
  if (!out) throw SolverError(Code::SOLVER_FAILURE, "checkpoint: write to " + path + " failed");
  return static_cast<std::uint64_t>(out.tellp());
}

void FemSolver::restore(const std::string& path) {
  if (!model_) throw SolverError(Code::UNEXPECTED, "restore before setup");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SolverError(Code::BAD_INPUT, "restore: cannot read " + path);
  auto get = [&](void* p, std::size_t n) {
    in.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    if (!in) throw SolverError(Code::BAD_INPUT, "restore: " + path + " is truncated");
  };
  std::uint64_t magic = 0, dofs = 0;
  get(&magic, 8);
  if ((magic & 0x00FFFFFFFFFFFFFFULL) == (kCheckpointMagic & 0x00FFFFFFFFFFFFFFULL) && magic != kCheckpointMagic)
    throw SolverError(Code::BAD_INPUT, "restore: " + path + " is an FEM checkpoint of another format version (" +
                                           std::string(1, static_cast<char>(magic >> 56)) + ", this build reads " +
                                           std::string(1, static_cast<char>(kCheckpointMagic >> 56)) + ")");
  if (magic != kCheckpointMagic) throw SolverError(Code::BAD_INPUT, "restore: " + path + " is not an FEM checkpoint");
  get(&dofs, 8);
  if (dofs != state_.u.size())
    throw SolverError(Code::BAD_INPUT, "restore: " + path + " holds " + std::to_string(dofs) + " dofs, the model has " +
                                           std::to_string(state_.u.size()));
  State s;
  s.resize(dofs);
  get(&s.time, 8);
  get(&s.step, 8);
  get(&s.externalWork, 8);
  get(&s.viscousDissipated, 8);
  for (auto* v : {&s.u, &s.v, &s.a, &s.fApplied, &s.fViscous}) get(v->data(), 8 * v->size());
  // The GMH state goes into copies too: a bad file leaves the solver as it was.
  std::vector<double> stresses, pointF;
  double pendingDt = 0.0;
  if (external_) {
    stresses.resize(external_->stresses().size());
    pointF.resize(pointF_.size());
    get(stresses.data(), 8 * stresses.size());
    get(pointF.data(), 8 * pointF.size());
    get(&pendingDt, 8);
    std::uint64_t started = 0;
    get(&started, 8);
    if (started != 0 && started != dofs)
      throw SolverError(Code::BAD_INPUT, "restore: " + path + " holds a split step of " + std::to_string(started) +
                                             " dofs, the model has " + std::to_string(dofs));
    // A step predicted (pendingDt > 0) is one whose start was kept, and only then.
    if (!(pendingDt >= 0.0) || (started == 0) != (pendingDt == 0.0))
      throw SolverError(Code::BAD_INPUT, "restore: " + path + " holds a pending step of " + show(pendingDt) +
                                             " s with a split step of " + std::to_string(started) + " dofs");
    s.uStepStart.resize(started);
    get(s.uStepStart.data(), 8 * started);
  }
  if (!std::isfinite(s.time) || !std::isfinite(s.externalWork) || !std::isfinite(pendingDt))
    throw SolverError(Code::BAD_INPUT, "restore: " + path + " holds a non-finite time, work or step");
  for (const auto* v : {&s.u, &s.v, &s.a})
    for (const double x : *v)
      if (!std::isfinite(x)) throw SolverError(Code::BAD_INPUT, "restore: " + path + " holds a non-finite displacement, velocity or acceleration");
  if (external_) {
    external_->stresses() = std::move(stresses);
    pointF_ = std::move(pointF);
    pendingDt_ = pendingDt;
  }
  state_ = std::move(s);
  if (snapshots_) snapshots_->resumeAt(state_.step);
}

double FemSolver::criticalDt() const { return integrator_ ? integrator_->criticalDt() : 0.0; }

wire::NamedValues FemSolver::energies() const {
  if (!model_) return {};
  Energies e;
  if (integrator_) {
    e = integrator_->energies(state_);
  } else {
    std::vector<double> f;
    ElementEnergy ee;
    model_->internalForce(state_.u, f, ee);
    e.strain = ee.strain;
    e.hourglass = ee.hourglass;
  }
  return {{"kinetic", e.kinetic},
          {"strain", e.strain},
          {"hourglass", e.hourglass},
          {"viscous_dissipated", e.viscousDissipated},
          {"external_work", e.externalWork}};
}

std::size_t FemSolver::outputWordsHint() const { return model_ ? 10 * model_->numDofs() + 1024 : 1024; }

void FemSolver::writeSnapshot() {
  if (snapshots_) snapshots_->write(*model_, state_);
}

}  // namespace cosim::fem
