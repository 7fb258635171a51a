// surface: FEM-DEM surface coupling (Cheng 2022 Sec. 5.1, 5.3.1). FEM exports
// its coupling face set as moving triangles (four per quad face around an
// interpolated centre vertex) with vertex-to-node weights and surface
// quadrature points; DEM treats the triangles as a wall group with
// Modifications 1 and 2 (Alg. 1) and returns its contacts; this coupling maps
// the contact forces to nodal forces (Eq. 16 for c = 0, Eqs. 14-15 for c > 0)
// and hands them to FEM.
//
// Wall kinematics over a DEM interval of several steps:
//   extrapolated: DEM gets the surface at the last FEM state and moves it with
//                 the exported velocities (both solvers may advance at once);
//   interpolated: DEM gets the surface at the previous FEM state and the secant
//                 velocity to the new one, so it sweeps exactly from one FEM
//                 state to the next after FEM advanced first; with DEM first
//                 (order: fine-first) the wall lags one step, as in the
//                 published runs of Cheng 2022;
//   smoothed:     as extrapolated, but DEM feels the CG-smoothed surface and the
//                 forces return through the same weights, so the contact does
//                 equal work on both sides (SmoothedSurface; c > 0 only, the
//                 point form at c = 0).
// cg_points: the kernel of Eqs. 14-15 is integrated over the surface
// quadrature (the paper's text) or over the volume Gauss points of an FE
// coupling zone (`volume_zone`, the published runs' code).
#include <cmath>
#include <ostream>
#include <sstream>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/coupler/mapping/smoothed_surface.hpp"
#include "cosim/coupler/mapping/surface_force_map.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

std::map<std::string, double> readScales(config::MapReader& m) {
  std::map<std::string, double> scales;
  if (!m.has("length_scales")) return scales;
  const YAML::Node node = m.node("length_scales");
  if (!node.IsMap()) {
    m.error("length_scales", "expected a map of scale names to lengths in metres, e.g. {d: 0.2}");
    return scales;
  }
  config::MapReader s(node, m.keyPath("length_scales"), m.diagnostics());
  for (const auto& entry : node) {
    if (!entry.first.IsScalar()) continue;  // s.finish() reports it
    const auto name = entry.first.Scalar();
    if (auto v = s.optionalNumber(name, config::Range::positive())) scales[name] = *v;
  }
  s.finish();
  return scales;
}

class SurfaceCoupling final : public Coupling {
 public:
  SurfaceCoupling(const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers)
      : Coupling(name) {
    fem_ = requireSolverName(m, "fem", solvers);
    dem_ = requireSolverName(m, "dem", solvers);
    surface_ = m.requireString("surface");
    const std::string kernel = m.string("kernel", "dirac");
    if (!CgKernelRegistry::has(kernel))
      m.error("kernel", "unknown CG kernel '" + kernel + "' (known: " + CgKernelRegistry::namesJoined() + ")");
    else
      kernel_ = CgKernelRegistry::make(kernel);
    const auto scales = readScales(m);
    width_ = m.optionalLength("width", scales, config::Range::nonNegative()).value_or(0.0);
    if (kernel_ && !kernel_->isDirac() && !m.has("width"))
      m.error("kernel", "kernel '" + kernel + "' needs a CG width (width: 10d, 2.0 ...; 0 gives the point form)");
    // c = 0 is the point form for every kernel (the limit of Eqs. 14-15 is Eq. 16),
    // so a sweep over the width can start at 0.
    if (kernel_ && width_ == 0.0) kernel_ = CgKernelRegistry::make("dirac");
    if (kernel_ && kernel_->isDirac() && width_ > 0.0)
      m.error("width", "the dirac kernel has no width (c = 0); use kernel: lucy or gaussian for c > 0");
    const std::string kinematics = m.string("wall_kinematics", "extrapolated");
    if (kinematics != "extrapolated" && kinematics != "interpolated" && kinematics != "smoothed")
      m.error("wall_kinematics", "must be extrapolated, interpolated or smoothed, got '" + kinematics + "'");
    interpolated_ = kinematics == "interpolated";
    // At c = 0 the smoothed wall is the unsmoothed one (G_i -> psi_i).
    smoothed_ = kinematics == "smoothed" && width_ > 0.0;
    if (m.choice("cg_points", {"surface", "volume"}, "surface") == "volume") {
      volumeZone_ = m.requireString("volume_zone");
      if (width_ == 0.0) volumeZone_.clear();  // c = 0: the point form (Eq. 16) for either
    } else if (m.has("volume_zone")) {
      m.error("volume_zone", "only read with cg_points: volume");
    }
    if (kernel_) map_.emplace(*kernel_, width_);
    if (smoothed_) {
      dirac_ = CgKernelRegistry::make("dirac");
      pointMap_.emplace(*dirac_, 0.0);
    }
  }

  std::string kind() const override { return "surface"; }
  std::vector<std::string> participants() const override { return {fem_, dem_}; }
  std::vector<std::string> requiredCapabilities(const std::string& solver) const override {
    if (solver == dem_) return {"triangle-walls", "contact-list"};
    return {"surface-export", "nodal-forces"};
  }
  bool needsFemFirst() const { return interpolated_; }

  void describe(std::ostream& out) const override {
    out << fem_ << " surface '" << surface_ << "' <-> " << dem_ << " triangle wall; forces by "
        << (kernel_ && !kernel_->isDirac() ? kernel_->name() + " kernel, c = " + std::to_string(width_) + " m (Eqs. 14-15)"
                                           : std::string("point form (Eq. 16)"))
        << ", wall kinematics " << (interpolated_ ? "interpolated" : smoothed_ ? "smoothed (energy-consistent)" : "extrapolated")
        << (volumeZone_.empty() ? "" : ", CG over the Gauss points of zone " + volumeZone_);
  }

  void exchange(ExchangeContext& ctx) override {
    auto fem = ctx.outputs.find(fem_);
    auto dem = ctx.outputs.find(dem_);
    if (fem == ctx.outputs.end() || dem == ctx.outputs.end()) return;
    const auto mesh = findMesh(fem->second, ctx.exchange);
    const SurfaceMeshView mv = meshView(mesh);
    const auto qv = findQuadrature(fem->second);
    stageWall(mesh, mv, ctx);
    mapForces(dem->second, mv, qv, ctx);
  }

 private:
  static SurfaceMeshView meshView(proto::TriangleMeshKinematics::Reader mesh) {
    return {wire::view(mesh.getPositions()), wire::view(mesh.getTriangles()), wire::view(mesh.getRowStart()),
            wire::view(mesh.getNodeIds()), wire::view(mesh.getNodeWeights())};
  }

  proto::TriangleMeshKinematics::Reader findMesh(proto::CouplingData::Reader fem, std::uint64_t exchange) const {
    for (auto m : fem.getMeshes())
      if (m.getSurface() == surface_) return m;
    throw std::runtime_error("coupling '" + name() + "': solver '" + fem_ + "' exported no surface '" + surface_ +
                             "' at exchange " + std::to_string(exchange) +
                             " (list it under its params coupling.surfaces)");
  }

  std::optional<SurfaceQuadratureView> findQuadrature(proto::CouplingData::Reader fem) {
    if (!volumeZone_.empty()) return volumeQuadrature(fem);
    for (auto q : fem.getQuadratures())
      if (q.getSurface() == surface_)
        return SurfaceQuadratureView{wire::view(q.getPositions()), wire::view(q.getWeights()), q.getNodesPerPoint(),
                                     wire::view(q.getNodeIds()), wire::view(q.getShapeValues())};
    return std::nullopt;
  }

  /// The Gauss points of the FE zone `volume_zone` (fem_solver's VolumeZone
  /// arrays, in the current configuration) as the CG quadrature.
  SurfaceQuadratureView volumeQuadrature(proto::CouplingData::Reader fem) {
    const auto array = [&](const char* what) {
      proto::NamedArray::Reader a;
      if (!wire::findArray(fem.getArrays(), volumeZone_ + "/" + what, a))
        throw std::runtime_error("coupling '" + name() + "': solver '" + fem_ + "' sent no array '" + volumeZone_ + "/" +
                                 what + "' (declare the zone under its params.coupling.zones for cg_points: volume)");
      return wire::view(a.getValues());
    };
    const auto nodes = array("qp_nodes");
    volumeNodes_.resize(nodes.size());
    for (std::size_t k = 0; k < nodes.size(); ++k) volumeNodes_[k] = static_cast<std::uint32_t>(nodes[k]);
    return SurfaceQuadratureView{array("qp_positions"), array("qp_weights"), 8, volumeNodes_, array("qp_shapes")};
  }

  /// G_i(X_v) of the smoothed wall, from the undeformed surface.
  void setupReference(const std::map<std::string, proto::CouplingData::Reader>& outputs) override {
    if (!smoothed_) return;
    const auto fem = outputs.find(fem_);
    if (fem == outputs.end()) return;
    const auto mesh = findMesh(fem->second, 0);
    const auto qv = findQuadrature(fem->second);
    if (!qv)
      throw std::runtime_error("coupling '" + name() + "': wall_kinematics smoothed needs the surface quadrature of '" +
                               fem_ + "' at setup (params coupling.quadrature: setup or true)");
    try {
      smoothing_.emplace(*map_, meshView(mesh), *qv);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error("coupling '" + name() + "' at setup: " + e.what());
    }
  }

  void stageWall(proto::TriangleMeshKinematics::Reader mesh, const SurfaceMeshView& mv, ExchangeContext& ctx) {
    const auto x = wire::view(mesh.getPositions());
    InputAssembler::StagedMesh staged{surface_, x, wire::view(mesh.getVelocities()), wire::view(mesh.getTriangles())};
    if (smoothing_) {
      // Between two FEM replies the smoothed surface does not change.
      if (ctx.isNew(fem_) || smoothedX_.empty()) smoothing_->kinematics(mv, staged.velocities, smoothedX_, smoothedV_);
      staged.positions = smoothedX_;
      staged.velocities = smoothedV_;
    }
    if (interpolated_) {
      if (ctx.isNew(fem_) || start_.empty()) advanceSecant(x, ctx.time);
      staged.positions = start_;
      staged.velocities = secant_;
    }
    ctx.inputs[dem_].stageMesh(staged);
  }

  /// The surface moves from the previous FEM state to the new one at constant velocity.
  void advanceSecant(std::span<const double> x, double time) {
    const double interval = time - lastTime_;
    if (last_.size() != x.size() || !(interval > 0.0)) {
      start_.assign(x.begin(), x.end());
      secant_.assign(x.size(), 0.0);
    } else {
      start_ = last_;
      for (std::size_t k = 0; k < x.size(); ++k) secant_[k] = (x[k] - last_[k]) / interval;
    }
    last_.assign(x.begin(), x.end());
    lastTime_ = time;
  }

  void mapForces(proto::CouplingData::Reader dem, const SurfaceMeshView& mv,
                 const std::optional<SurfaceQuadratureView>& qv, ExchangeContext& ctx) {
    proto::ContactList::Reader contacts;
    bool found = false;
    for (auto c : dem.getContacts())
      if (c.getSurface() == surface_) contacts = c, found = true;
    if (!found) return;  // DEM has not seen the wall yet (setup outputs)
    const ContactsView cv{wire::view(contacts.getTriangleIds()), wire::view(contacts.getBarycentric()),
                          wire::view(contacts.getPoints()), wire::view(contacts.getForces())};
    // The smoothed map depends on the contacts only; the others also on where FEM's surface is.
    if (ctx.isNew(dem_) || (!smoothing_ && ctx.isNew(fem_)) || !mapped_) remap(cv, mv, qv, ctx);
    ctx.inputs[fem_].stageForces({surface_, proto::CouplingForces::Target::NODES, nodal_.ids, nodal_.forces});
    record(cv, ctx);
  }

  void remap(const ContactsView& cv, const SurfaceMeshView& mv, const std::optional<SurfaceQuadratureView>& qv,
             const ExchangeContext& ctx) {
    try {
      if (smoothing_) pointMap_->map(cv, smoothing_->withSmoothedWeights(mv), nullptr, nodal_);
      else map_->map(cv, mv, qv ? &*qv : nullptr, nodal_);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error("coupling '" + name() + "' at exchange " + std::to_string(ctx.exchange) + ": " + e.what());
    }
    mapped_ = true;
  }

  void record(const ContactsView& c, ExchangeContext& ctx) const {
    if (!ctx.series) return;
    double total[3] = {0, 0, 0}, mapped[3] = {0, 0, 0};
    for (std::size_t k = 0; k < c.forces.size(); ++k) total[k % 3] += c.forces[k];
    for (std::size_t k = 0; k < nodal_.forces.size(); ++k) mapped[k % 3] += nodal_.forces[k];
    ctx.series->append(name() + "/contact_force", std::span<const double>(total, 3));
    ctx.series->append(name() + "/nodal_force", std::span<const double>(mapped, 3));
    ctx.series->append(name() + "/contacts", static_cast<double>(c.triangleIds.size()));
  }

  std::string fem_, dem_, surface_, volumeZone_;
  std::vector<std::uint32_t> volumeNodes_;  // the zone's qp_nodes as ids
  std::unique_ptr<CgKernel> kernel_;
  double width_ = 0.0;
  bool interpolated_ = false, smoothed_ = false, mapped_ = false;
  std::optional<SurfaceForceMap> map_;
  std::unique_ptr<CgKernel> dirac_;          // smoothed: forces go back by Eq. 16 with G as weights
  std::optional<SurfaceForceMap> pointMap_;
  std::optional<SmoothedSurface> smoothing_;
  std::vector<double> smoothedX_, smoothedV_;
  NodalForces nodal_;
  std::vector<double> last_, start_, secant_;  // FEM surface last exported; where DEM starts; its velocity
  double lastTime_ = 0.0;
};

const bool registered = CouplingRegistry::add(
    "surface", [](const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<SurfaceCoupling>(name, m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
