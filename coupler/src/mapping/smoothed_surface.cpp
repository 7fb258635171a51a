#include "cosim/coupler/mapping/smoothed_surface.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace cosim::coupler {
namespace {
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
}

SmoothedSurface::SmoothedSurface(SurfaceForceMap& cgMap, const SurfaceMeshView& reference,
                                 const SurfaceQuadratureView& quadrature)
    : reference_(reference.positions.begin(), reference.positions.end()),
      g_(cgMap.weightsAt(reference.positions, quadrature)) {
  // A corner vertex carries its node with weight 1; its motion is the node's.
  const std::size_t vertices = reference.rowStart.empty() ? 0 : reference.rowStart.size() - 1;
  for (std::size_t v = 0; v < vertices; ++v) {
    const std::uint32_t e = reference.rowStart[v];
    if (reference.rowStart[v + 1] != e + 1 || std::abs(reference.nodeWeights[e] - 1.0) > 1e-12) continue;
    const std::uint32_t node = reference.nodeIds[e];
    if (node >= nodeVertex_.size()) nodeVertex_.resize(static_cast<std::size_t>(node) + 1, kNone);
    nodeVertex_[node] = static_cast<std::uint32_t>(v);
  }
  source_.reserve(g_.nodeIds.size());
  for (std::uint32_t node : g_.nodeIds) {
    if (node >= nodeVertex_.size() || nodeVertex_[node] == kNone)
      throw std::invalid_argument("the smoothed wall needs a surface vertex on every node; node " + std::to_string(node) +
                                  " has none (the surface export is not four triangles per quad around a centre)");
    source_.push_back(nodeVertex_[node]);
  }
}

void SmoothedSurface::kinematics(const SurfaceMeshView& mesh, std::span<const double> velocities,
                                 std::vector<double>& positions, std::vector<double>& smoothedVelocities) const {
  if (mesh.positions.size() != reference_.size() || velocities.size() != reference_.size())
    throw std::invalid_argument("the coupling surface changed its vertex count from " +
                                std::to_string(reference_.size() / 3) + " to " + std::to_string(mesh.positions.size() / 3));
  // Runs every exchange: each node's displacement is formed once, not once
  // per row that reads it (a row holds every node within c).
  displacement_.resize(reference_.size());
  for (std::size_t k = 0; k < reference_.size(); ++k) displacement_[k] = mesh.positions[k] - reference_[k];
  positions.resize(reference_.size());
  smoothedVelocities.resize(reference_.size());
  const double* du = displacement_.data();
  const double* vn = velocities.data();
  for (std::size_t v = 0; v + 1 < g_.rowStart.size(); ++v) {
    double x0 = 0.0, x1 = 0.0, x2 = 0.0, v0 = 0.0, v1 = 0.0, v2 = 0.0;
    for (std::uint32_t e = g_.rowStart[v]; e < g_.rowStart[v + 1]; ++e) {
      const std::size_t at = 3 * static_cast<std::size_t>(source_[e]);
      const double w = g_.weights[e];
      x0 += w * du[at], x1 += w * du[at + 1], x2 += w * du[at + 2];
      v0 += w * vn[at], v1 += w * vn[at + 1], v2 += w * vn[at + 2];
    }
    positions[3 * v] = reference_[3 * v] + x0;
    positions[3 * v + 1] = reference_[3 * v + 1] + x1;
    positions[3 * v + 2] = reference_[3 * v + 2] + x2;
    smoothedVelocities[3 * v] = v0, smoothedVelocities[3 * v + 1] = v1, smoothedVelocities[3 * v + 2] = v2;
  }
}

SurfaceMeshView SmoothedSurface::withSmoothedWeights(const SurfaceMeshView& mesh) const {
  SurfaceMeshView view = mesh;
  view.rowStart = g_.rowStart;
  view.nodeIds = g_.nodeIds;
  view.nodeWeights = g_.weights;
  return view;
}

}  // namespace cosim::coupler
