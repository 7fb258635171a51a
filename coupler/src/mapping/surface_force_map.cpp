#include "cosim/coupler/mapping/surface_force_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace cosim::coupler {

void SurfaceForceMap::map(const ContactsView& c, const SurfaceMeshView& mesh, const SurfaceQuadratureView* quadrature,
                          NodalForces& out) {
  const std::size_t n = c.triangleIds.size();
  if (c.barycentric.size() != 3 * n || c.points.size() != 3 * n || c.forces.size() != 3 * n)
    throw std::invalid_argument("contact list: " + std::to_string(n) + " contacts but " +
                                std::to_string(c.barycentric.size()) + " barycentric, " +
                                std::to_string(c.points.size()) + " point and " + std::to_string(c.forces.size()) +
                                " force values (3 per contact expected)");
  const bool smoothed = !kernel_.isDirac();
  if (smoothed && !quadrature)
    throw std::invalid_argument("the CG-enriched force map (kernel '" + kernel_.name() +
                                "') needs the surface quadrature points with every exchange (FEM params coupling.quadrature: true; "
                                "'setup' sends them once, which only wall_kinematics: smoothed can use)");
  if (smoothed && n > 0) binQuadrature(*quadrature);
  for (std::size_t k = 0; k < n; ++k) {
    if (smoothed) addSmoothedForm(k, c, *quadrature);
    else addPointForm(k, c, mesh);
  }
  collect(out);
}

// Cheng 2022 Eq. (16): f_i = sum_contacts psi_i(x_c) f_c, with psi_i(x_c) =
// sum_v b_v W_vi (barycentric weight of triangle vertex v times its
// vertex-to-node weight; the centre vertex of a quad carries 1/4 of each node).
void SurfaceForceMap::addPointForm(std::size_t k, const ContactsView& c, const SurfaceMeshView& mesh) {
  const std::uint32_t t = c.triangleIds[k];
  if (3 * static_cast<std::size_t>(t) + 2 >= mesh.triangles.size())
    throw std::invalid_argument("contact " + std::to_string(k) + " names triangle " + std::to_string(t) +
                                ", the surface has " + std::to_string(mesh.triangles.size() / 3));
  for (std::size_t v = 0; v < 3; ++v) {
    const std::uint32_t vertex = mesh.triangles[3 * t + v];
    if (static_cast<std::size_t>(vertex) + 1 >= mesh.rowStart.size())
      throw std::invalid_argument("triangle " + std::to_string(t) + " names vertex " + std::to_string(vertex) +
                                  " beyond the vertex-to-node weights");
    for (std::uint32_t e = mesh.rowStart[vertex]; e < mesh.rowStart[vertex + 1]; ++e)
      add(mesh.nodeIds[e], c.barycentric[3 * k + v] * mesh.nodeWeights[e], &c.forces[3 * k]);
  }
}

// Cheng 2022 Eqs. (14)-(15): the traction t(x) = sum_c f_c W(x - x_c) is
// integrated against psi_i by the surface quadrature. W is normalised over
// the quadrature points themselves (Sec. 5.1.2), so sum_i f_i = sum_c f_c
// exactly, also where the kernel's support overhangs the surface's edge.
void SurfaceForceMap::addSmoothedForm(std::size_t k, const ContactsView& c, const SurfaceQuadratureView& q) {
  const double total = gatherSupport(&c.points[3 * k], q);
  if (!(total > 0.0)) throw noSupport("contact " + std::to_string(k), &c.points[3 * k]);
  addSupport(total, q, &c.forces[3 * k]);
}

double SurfaceForceMap::gatherSupport(const double* x, const SurfaceQuadratureView& q) {
  supportPoints_.clear();
  support_.clear();
  double total = 0.0;
  std::int64_t lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((x[d] - width_ - lo_[d]) / width_)), 0, cells_[d] - 1);
    hi[d] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((x[d] + width_ - lo_[d]) / width_)), 0, cells_[d] - 1);
  }
  for (std::int64_t i = lo[0]; i <= hi[0]; ++i)
    for (std::int64_t j = lo[1]; j <= hi[1]; ++j)
      for (std::int64_t l = lo[2]; l <= hi[2]; ++l) {
        const auto cell = static_cast<std::size_t>((i * cells_[1] + j) * cells_[2] + l);
        for (std::uint32_t s = cellStart_[cell]; s < cellStart_[cell + 1]; ++s) {
          const std::uint32_t p = cellPoints_[s];
          const double* xq = &q.positions[3 * static_cast<std::size_t>(p)];
          const double r = std::hypot(xq[0] - x[0], xq[1] - x[1], xq[2] - x[2]);
          const double a = q.weights[p] * kernel_.value(r, width_);
          if (a <= 0.0) continue;
          supportPoints_.push_back(p);
          support_.push_back(a);
          total += a;
        }
      }
  return total;
}

void SurfaceForceMap::addSupport(double total, const SurfaceQuadratureView& q, const double* force) {
  const std::uint32_t npp = q.nodesPerPoint;
  for (std::size_t s = 0; s < supportPoints_.size(); ++s) {
    const std::size_t p = supportPoints_[s];
    for (std::uint32_t a = 0; a < npp; ++a)
      add(q.nodeIds[p * npp + a], support_[s] / total * q.shapeValues[p * npp + a], force);
  }
}

std::invalid_argument SurfaceForceMap::noSupport(const std::string& what, const double* x) const {
  // No quadrature point within c: the width is below the quadrature spacing.
  return std::invalid_argument(what + " at (" + std::to_string(x[0]) + ", " + std::to_string(x[1]) + ", " +
                               std::to_string(x[2]) + "): no surface quadrature point within the CG width c = " +
                               std::to_string(width_) + " m; use a larger width or kernel: dirac");
}

VertexNodeWeights SurfaceForceMap::weightsAt(std::span<const double> points, const SurfaceQuadratureView& q) {
  if (kernel_.isDirac()) throw std::invalid_argument("CG weights at points need a kernel with a width (c > 0)");
  binQuadrature(q);
  VertexNodeWeights rows;
  rows.rowStart.push_back(0);
  const double unit[3] = {1.0, 0.0, 0.0};
  NodalForces row;
  for (std::size_t v = 0; 3 * v + 2 < points.size(); ++v) {
    const double total = gatherSupport(&points[3 * v], q);
    if (!(total > 0.0)) throw noSupport("point " + std::to_string(v), &points[3 * v]);
    addSupport(total, q, unit);
    collect(row);
    rows.nodeIds.insert(rows.nodeIds.end(), row.ids.begin(), row.ids.end());
    for (std::size_t k = 0; k < row.ids.size(); ++k) rows.weights.push_back(row.forces[3 * k]);
    rows.rowStart.push_back(static_cast<std::uint32_t>(rows.nodeIds.size()));
  }
  return rows;
}

void SurfaceForceMap::binQuadrature(const SurfaceQuadratureView& q) {
  const std::size_t n = q.weights.size();
  if (q.positions.size() != 3 * n || q.nodeIds.size() != q.nodesPerPoint * n || q.shapeValues.size() != q.nodeIds.size())
    throw std::invalid_argument("surface quadrature: " + std::to_string(n) + " points but " +
                                std::to_string(q.positions.size()) + " coordinates, " + std::to_string(q.nodeIds.size()) +
                                " node ids and " + std::to_string(q.shapeValues.size()) + " shape values");
  double hi[3];
  for (int d = 0; d < 3; ++d) lo_[d] = hi[d] = n ? q.positions[static_cast<std::size_t>(d)] : 0.0;
  for (std::size_t p = 0; p < n; ++p)
    for (int d = 0; d < 3; ++d) {
      lo_[d] = std::min(lo_[d], q.positions[3 * p + static_cast<std::size_t>(d)]);
      hi[d] = std::max(hi[d], q.positions[3 * p + static_cast<std::size_t>(d)]);
    }
  std::size_t total = 1;
  for (int d = 0; d < 3; ++d) {
    // Cap the grid so a tiny width on a large surface cannot exhaust memory.
    cells_[d] = std::clamp<std::int64_t>(static_cast<std::int64_t>((hi[d] - lo_[d]) / width_) + 1, 1, 1024);
    total *= static_cast<std::size_t>(cells_[d]);
  }
  cellStart_.assign(total + 1, 0);
  std::vector<std::size_t> cellOf(n);
  for (std::size_t p = 0; p < n; ++p) {
    std::int64_t idx[3];
    for (int d = 0; d < 3; ++d)
      idx[d] = std::clamp<std::int64_t>(static_cast<std::int64_t>((q.positions[3 * p + static_cast<std::size_t>(d)] - lo_[d]) / width_),
                                        0, cells_[d] - 1);
    cellOf[p] = static_cast<std::size_t>((idx[0] * cells_[1] + idx[1]) * cells_[2] + idx[2]);
    ++cellStart_[cellOf[p] + 1];
  }
  for (std::size_t cell = 0; cell < total; ++cell) cellStart_[cell + 1] += cellStart_[cell];
  cellPoints_.resize(n);
  std::vector<std::uint32_t> fill(cellStart_.begin(), cellStart_.end() - 1);
  for (std::size_t p = 0; p < n; ++p) cellPoints_[fill[cellOf[p]]++] = static_cast<std::uint32_t>(p);
}

void SurfaceForceMap::add(std::uint32_t node, double weight, const double* force) {
  if (node >= isTouched_.size()) {
    isTouched_.resize(static_cast<std::size_t>(node) + 1, 0);
    accumulated_.resize(3 * isTouched_.size(), 0.0);
  }
  if (!isTouched_[node]) {
    isTouched_[node] = 1;
    touched_.push_back(node);
  }
  for (std::size_t d = 0; d < 3; ++d) accumulated_[3 * node + d] += weight * force[d];
}

void SurfaceForceMap::collect(NodalForces& out) {
  std::sort(touched_.begin(), touched_.end());
  out.ids.assign(touched_.begin(), touched_.end());
  out.forces.resize(3 * touched_.size());
  for (std::size_t k = 0; k < touched_.size(); ++k)
    for (std::size_t d = 0; d < 3; ++d) {
      out.forces[3 * k + d] = accumulated_[3 * touched_[k] + d];
      accumulated_[3 * touched_[k] + d] = 0.0;
    }
  for (std::uint32_t node : touched_) isTouched_[node] = 0;
  touched_.clear();
}

}  // namespace cosim::coupler
