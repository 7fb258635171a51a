#include "cosim/fem/coupling/surface_export.hpp"

#include <cmath>
#include <map>

#include "cosim/wire/arrays.hpp"

namespace cosim::fem {

SurfaceExport::SurfaceExport(std::string name, const Mesh& mesh, const std::vector<Quad>& faces)
    : name_(std::move(name)), faces_(faces) {
  if (faces.empty()) throw InputError("coupling surface '" + name_ + "' has no faces");
  (void)mesh;
  // Corner vertices: the distinct nodes of the face set, weight 1.
  std::map<Index, std::uint32_t> vertexOf;
  rowStart_.push_back(0);
  for (const Quad& q : faces)
    for (Index n : q)
      if (vertexOf.emplace(n, static_cast<std::uint32_t>(vertexOf.size())).second) {
        nodeIds_.push_back(n);
        nodeWeights_.push_back(1.0);
        rowStart_.push_back(static_cast<std::uint32_t>(nodeIds_.size()));
      }
  // Centre vertex of each quad: the bilinear interpolation at its centre,
  // i.e. weights 1/4 on its four nodes; four triangles around it keep the
  // outward orientation of the face.
  for (const Quad& q : faces) {
    const auto centre = static_cast<std::uint32_t>(rowStart_.size() - 1);
    for (Index n : q) {
      nodeIds_.push_back(n);
      nodeWeights_.push_back(0.25);
    }
    rowStart_.push_back(static_cast<std::uint32_t>(nodeIds_.size()));
    for (int k = 0; k < 4; ++k)
      triangles_.insert(triangles_.end(), {vertexOf[q[static_cast<std::size_t>(k)]],
                                           vertexOf[q[static_cast<std::size_t>((k + 1) % 4)]], centre});
  }
}

std::vector<double> SurfaceExport::interpolate(const std::vector<double>& nodal) const {
  std::vector<double> out(3 * numVertices(), 0.0);
  for (std::size_t v = 0; v < numVertices(); ++v)
    for (std::uint32_t k = rowStart_[v]; k < rowStart_[v + 1]; ++k)
      for (std::size_t d = 0; d < 3; ++d) out[3 * v + d] += nodeWeights_[k] * nodal[3 * nodeIds_[k] + d];
  return out;
}

void SurfaceExport::fillMesh(proto::TriangleMeshKinematics::Builder out, const Mesh& mesh,
                             const std::vector<double>& u, const std::vector<double>& v) const {
  std::vector<double> x(mesh.X);
  for (std::size_t d = 0; d < x.size(); ++d) x[d] += u[d];
  const auto pos = interpolate(x), vel = interpolate(v);
  out.setSurface(name_);
  auto copy = [](auto list, const auto& values) {
    for (unsigned i = 0; i < values.size(); ++i) list.set(i, values[i]);
  };
  copy(out.initPositions(static_cast<unsigned>(pos.size())), pos);
  copy(out.initVelocities(static_cast<unsigned>(vel.size())), vel);
  copy(out.initTriangles(static_cast<unsigned>(triangles_.size())), triangles_);
  copy(out.initRowStart(static_cast<unsigned>(rowStart_.size())), rowStart_);
  copy(out.initNodeIds(static_cast<unsigned>(nodeIds_.size())), nodeIds_);
  copy(out.initNodeWeights(static_cast<unsigned>(nodeWeights_.size())), nodeWeights_);
}

void SurfaceExport::fillQuadrature(proto::SurfaceQuadrature::Builder out, const Mesh& mesh,
                                   const std::vector<double>& u) const {
  const double g = 1.0 / std::sqrt(3.0);
  const double pts[4][2] = {{-g, -g}, {g, -g}, {g, g}, {-g, g}};
  const std::size_t n = 4 * faces_.size();
  out.setSurface(name_);
  out.setNodesPerPoint(4);
  auto positions = out.initPositions(static_cast<unsigned>(3 * n));
  auto weights = out.initWeights(static_cast<unsigned>(n));
  auto ids = out.initNodeIds(static_cast<unsigned>(4 * n));
  auto shapes = out.initShapeValues(static_cast<unsigned>(4 * n));
  unsigned p = 0;
  for (const Quad& q : faces_) {
    Eigen::Matrix<double, 4, 3> X;
    for (int a = 0; a < 4; ++a) {
      const Index node = q[static_cast<std::size_t>(a)];
      for (int i = 0; i < 3; ++i) X(a, i) = mesh.X[3 * node + static_cast<std::size_t>(i)] + u[3 * node + static_cast<std::size_t>(i)];
    }
    for (const auto& pt : pts) {
      const double s = pt[0], t = pt[1];
      const double N[4] = {0.25 * (1 - s) * (1 - t), 0.25 * (1 + s) * (1 - t), 0.25 * (1 + s) * (1 + t),
                           0.25 * (1 - s) * (1 + t)};
      const Vec3 dS = 0.25 * (-(1 - t) * X.row(0) + (1 - t) * X.row(1) + (1 + t) * X.row(2) - (1 + t) * X.row(3)).transpose();
      const Vec3 dT = 0.25 * (-(1 - s) * X.row(0) - (1 + s) * X.row(1) + (1 + s) * X.row(2) + (1 - s) * X.row(3)).transpose();
      Vec3 x = Vec3::Zero();
      for (int a = 0; a < 4; ++a) {
        x += N[a] * X.row(a).transpose();
        ids.set(4 * p + static_cast<unsigned>(a), q[static_cast<std::size_t>(a)]);
        shapes.set(4 * p + static_cast<unsigned>(a), N[a]);
      }
      for (unsigned i = 0; i < 3; ++i) positions.set(3 * p + i, x[static_cast<int>(i)]);
      weights.set(p, dS.cross(dT).norm());  // Gauss weight 1 x 1 times the area Jacobian
      ++p;
    }
  }
}

}  // namespace cosim::fem
