#include "cosim/fem/mesh/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace cosim::fem {

const int kHexFaces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                             {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

Mat83 Mesh::elementCoordinates(std::size_t e) const {
  Mat83 x;
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) x(a, i) = X[3 * elements[e][static_cast<std::size_t>(a)] + static_cast<std::size_t>(i)];
  return x;
}

const std::vector<Index>& Mesh::nodeSet(const std::string& name, const std::string& context) const {
  auto it = nodeSets.find(name);
  if (it == nodeSets.end())
    throw InputError((context.empty() ? "" : context + ": ") + "no node set named '" + name + "'");
  if (it->second.empty())
    throw InputError((context.empty() ? "" : context + ": ") + "node set '" + name + "' is empty");
  return it->second;
}

const std::vector<Quad>& Mesh::faceSet(const std::string& name, const std::string& context) const {
  auto it = faceSets.find(name);
  if (it == faceSets.end())
    throw InputError((context.empty() ? "" : context + ": ") + "no face set named '" + name + "'");
  if (it->second.empty())
    throw InputError((context.empty() ? "" : context + ": ") + "face set '" + name + "' is empty");
  return it->second;
}

std::vector<Index> Mesh::nodesInBox(const Vec3& lo, const Vec3& hi, double tol) const {
  std::vector<Index> out;
  for (Index n = 0; n < numNodes(); ++n) {
    const Vec3 x = node(n);
    if ((x.array() >= lo.array() - tol).all() && (x.array() <= hi.array() + tol).all()) out.push_back(n);
  }
  return out;
}

std::vector<Quad> Mesh::boundaryFaces() const {
  std::map<std::array<Index, 4>, std::pair<Quad, int>> faces;
  for (const Hex& h : elements) {
    for (const auto& f : kHexFaces) {
      Quad q{h[static_cast<std::size_t>(f[0])], h[static_cast<std::size_t>(f[1])],
             h[static_cast<std::size_t>(f[2])], h[static_cast<std::size_t>(f[3])]};
      std::array<Index, 4> key = q;
      std::sort(key.begin(), key.end());
      auto [it, inserted] = faces.try_emplace(key, q, 0);
      it->second.second += 1;
      (void)inserted;
    }
  }
  std::vector<Quad> out;
  for (const auto& entry : faces)
    if (entry.second.second == 1) out.push_back(entry.second.first);
  return out;
}

namespace {
std::vector<Quad> facesInBox(const Mesh& mesh, const std::vector<Quad>& faces, const Vec3& lo, const Vec3& hi,
                             double tol) {
  std::vector<Quad> out;
  for (const Quad& q : faces) {
    bool inside = true;
    for (Index n : q) {
      const Vec3 x = mesh.node(n);
      inside = inside && (x.array() >= lo.array() - tol).all() && (x.array() <= hi.array() + tol).all();
    }
    if (inside) out.push_back(q);
  }
  return out;
}
}  // namespace

std::vector<Quad> Mesh::boundaryFacesInBox(const Vec3& lo, const Vec3& hi, double tol) const {
  return facesInBox(*this, boundaryFaces(), lo, hi, tol);
}

void Mesh::validate() const {
  if (elements.empty()) throw InputError("mesh has no elements");
  std::vector<char> used(numNodes(), 0);
  for (std::size_t e = 0; e < elements.size(); ++e) {
    for (Index n : elements[e]) {
      if (n >= numNodes())
        throw InputError("element " + std::to_string(e) + " refers to node " + std::to_string(n) +
                         " but the mesh has " + std::to_string(numNodes()) + " nodes");
      used[n] = 1;
    }
    std::set<Index> distinct(elements[e].begin(), elements[e].end());
    if (distinct.size() != 8) throw InputError("element " + std::to_string(e) + " is degenerate (repeated node)");
  }
  for (std::size_t n = 0; n < X.size(); ++n)
    if (!std::isfinite(X[n])) throw InputError("node " + std::to_string(n / 3) + " has a non-finite coordinate");
  for (std::size_t n = 0; n < used.size(); ++n)
    if (!used[n]) throw InputError("node " + std::to_string(n) + " belongs to no element");
}

std::vector<std::pair<Index, Index>> matchPeriodicNodes(const Mesh& mesh, const std::vector<Index>& minNodes,
                                                        const std::vector<Index>& maxNodes, const Vec3& offset,
                                                        double tol) {
  // Sort the min-face nodes along the coordinate in which the face is widest,
  // then search a +-tol window: O(n log n) instead of all pairs.
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (Index n : minNodes) {
    lo = lo.cwiseMin(mesh.node(n));
    hi = hi.cwiseMax(mesh.node(n));
  }
  int key = 0;
  (hi - lo).maxCoeff(&key);
  std::vector<std::pair<double, Index>> sorted;
  sorted.reserve(minNodes.size());
  for (Index n : minNodes) sorted.emplace_back(mesh.node(n)[key], n);
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::pair<Index, Index>> pairs;
  pairs.reserve(maxNodes.size());
  for (Index s : maxNodes) {
    const Vec3 target = mesh.node(s) - offset;
    auto it = std::lower_bound(sorted.begin(), sorted.end(), std::make_pair(target[key] - tol, Index{0}));
    Index partner = s;
    for (; it != sorted.end() && it->first <= target[key] + tol; ++it)
      if ((mesh.node(it->second) - target).cwiseAbs().maxCoeff() <= tol) {
        partner = it->second;
        break;
      }
    if (partner == s) {
      std::ostringstream msg;
      msg << "periodic node " << s << " at (" << mesh.node(s).transpose() << ") has no partner at ("
          << target.transpose() << ") within " << tol;
      throw InputError(msg.str());
    }
    pairs.emplace_back(s, partner);
  }
  return pairs;
}

Mesh makeBoxMesh(const Vec3& lo, const Vec3& hi, const std::array<int, 3>& n) {
  for (int d = 0; d < 3; ++d) {
    if (n[static_cast<std::size_t>(d)] < 1) throw InputError("box mesh: divisions must be >= 1");
    if (!(hi[d] > lo[d])) throw InputError("box mesh: max must exceed min in every direction");
  }
  const std::size_t nx = static_cast<std::size_t>(n[0]), ny = static_cast<std::size_t>(n[1]),
                    nz = static_cast<std::size_t>(n[2]);
  Mesh mesh;
  auto id = [&](std::size_t i, std::size_t j, std::size_t k) {
    return static_cast<Index>(i + (nx + 1) * (j + (ny + 1) * k));
  };
  mesh.X.assign(3 * (nx + 1) * (ny + 1) * (nz + 1), 0.0);
  for (std::size_t k = 0; k <= nz; ++k)
    for (std::size_t j = 0; j <= ny; ++j)
      for (std::size_t i = 0; i <= nx; ++i) {
        const Index a = id(i, j, k);
        const double f[3] = {static_cast<double>(i) / static_cast<double>(nx),
                             static_cast<double>(j) / static_cast<double>(ny),
                             static_cast<double>(k) / static_cast<double>(nz)};
        for (int d = 0; d < 3; ++d) mesh.X[3 * a + static_cast<std::size_t>(d)] = lo[d] + f[d] * (hi[d] - lo[d]);
      }
  mesh.elements.assign(nx * ny * nz, Hex{});
  std::size_t e = 0;
  for (std::size_t k = 0; k < nz; ++k)
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i)
        mesh.elements[e++] = Hex{id(i, j, k),     id(i + 1, j, k),     id(i + 1, j + 1, k),     id(i, j + 1, k),
                                 id(i, j, k + 1), id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
  const char* names[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
  const double big = 1e300;
  const std::vector<Quad> boundary = mesh.boundaryFaces();
  for (int d = 0; d < 3; ++d) {
    for (int side = 0; side < 2; ++side) {
      Vec3 blo = Vec3::Constant(-big), bhi = Vec3::Constant(big);
      const double v = side == 0 ? lo[d] : hi[d];
      const double tol = 1e-9 * (hi[d] - lo[d]);
      blo[d] = v - tol;
      bhi[d] = v + tol;
      mesh.nodeSets[names[d][side]] = mesh.nodesInBox(blo, bhi, 0.0);
      mesh.faceSets[names[d][side]] = facesInBox(mesh, boundary, blo, bhi, 0.0);
    }
  }
  std::vector<Index> all(mesh.numNodes());
  for (Index a = 0; a < all.size(); ++a) all[a] = a;
  mesh.nodeSets["all"] = std::move(all);
  return mesh;
}

}  // namespace cosim::fem
