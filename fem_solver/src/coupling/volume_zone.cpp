#include "cosim/fem/coupling/volume_zone.hpp"

#include <algorithm>
#include <map>

#include "cosim/fem/fem/hex8.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::fem {

VolumeZone::VolumeZone(std::string name, const Mesh& mesh, const Vec3& lo, const Vec3& hi) : name_(std::move(name)) {
  std::map<std::pair<Index, Index>, double> M;
  for (std::size_t e = 0; e < mesh.numElements(); ++e) {
    const Mat83 X = mesh.elementCoordinates(e);
    const Vec3 c = X.colwise().mean().transpose();
    if (!((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all())) continue;
    elements_.push_back(e);
    for (int q = 0; q < 8; ++q) {
      const Vec3 xi = hex8::gaussPoint(q);
      const hex8::Shape N = hex8::shape(xi);
      const double w = (X.transpose() * hex8::shapeDerivatives(xi)).determinant();
      weights_.push_back(w);
      for (int a = 0; a < 8; ++a)
        for (int b = 0; b < 8; ++b)
          M[{mesh.elements[e][static_cast<std::size_t>(a)], mesh.elements[e][static_cast<std::size_t>(b)]}] +=
              N(a) * N(b) * w;
    }
    nodes_.insert(nodes_.end(), mesh.elements[e].begin(), mesh.elements[e].end());
  }
  if (elements_.empty()) throw InputError("coupling zone '" + name_ + "' contains no element centroid");
  std::sort(nodes_.begin(), nodes_.end());
  nodes_.erase(std::unique(nodes_.begin(), nodes_.end()), nodes_.end());
  for (const auto& [ij, v] : M) matrix_.insert(matrix_.end(), {static_cast<double>(ij.first), static_cast<double>(ij.second), v});
}

void VolumeZone::fill(capnp::List<proto::NamedArray>::Builder arrays, unsigned first, const Mesh& mesh,
                      const std::vector<double>& u, const std::vector<double>& v,
                      const std::vector<double>& lumpedMass) const {
  const std::size_t np = numPoints();
  std::vector<double> nodes(nodes_.begin(), nodes_.end()), pos(3 * np), ids(8 * np), shapes(8 * np);
  std::size_t p = 0;
  for (std::size_t e : elements_) {
    Mat83 x = mesh.elementCoordinates(e);
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) x(a, i) += u[3 * mesh.elements[e][static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)];
    for (int q = 0; q < 8; ++q, ++p) {
      const hex8::Shape N = hex8::shape(hex8::gaussPoint(q));
      const Vec3 xq = x.transpose() * N;
      for (int i = 0; i < 3; ++i) pos[3 * p + static_cast<std::size_t>(i)] = xq[i];
      for (int a = 0; a < 8; ++a) {
        ids[8 * p + static_cast<std::size_t>(a)] = mesh.elements[e][static_cast<std::size_t>(a)];
        shapes[8 * p + static_cast<std::size_t>(a)] = N(a);
      }
    }
  }
  std::vector<double> reference(3 * nodes_.size()), disp(3 * nodes_.size()), vel(3 * nodes_.size()),
      mass(nodes_.size()), connectivity(8 * elements_.size());
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const auto n = static_cast<std::size_t>(nodes_[k]);
    mass[k] = lumpedMass[n];
    for (std::size_t i = 0; i < 3; ++i) {
      reference[3 * k + i] = mesh.X[3 * n + i];
      disp[3 * k + i] = u[3 * n + i];
      vel[3 * k + i] = v[3 * n + i];
    }
  }
  for (std::size_t k = 0; k < elements_.size(); ++k)
    for (std::size_t a = 0; a < 8; ++a) connectivity[8 * k + a] = mesh.elements[elements_[k]][a];
  wire::addArray(arrays, first + 0, name_ + "/nodes", 1, nodes);
  wire::addArray(arrays, first + 1, name_ + "/qp_positions", 3, pos);
  wire::addArray(arrays, first + 2, name_ + "/qp_weights", 1, weights_);
  wire::addArray(arrays, first + 3, name_ + "/qp_nodes", 8, ids);
  wire::addArray(arrays, first + 4, name_ + "/qp_shapes", 8, shapes);
  wire::addArray(arrays, first + 5, name_ + "/matrix", 3, matrix_);
  wire::addArray(arrays, first + 6, name_ + "/node_positions", 3, reference);
  wire::addArray(arrays, first + 7, name_ + "/elements", 8, connectivity);
  wire::addArray(arrays, first + 8, name_ + "/displacement", 3, disp);
  wire::addArray(arrays, first + 9, name_ + "/velocity", 3, vel);
  wire::addArray(arrays, first + 10, name_ + "/masses", 1, mass);
}

}  // namespace cosim::fem
