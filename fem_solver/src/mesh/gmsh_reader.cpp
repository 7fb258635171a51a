#include "cosim/fem/mesh/gmsh_reader.hpp"

#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>

#include "cosim/util/stream_size.hpp"

namespace cosim::fem {
namespace {

class LineReader {
 public:
  // Every counted item takes at least one line: the file's size bounds the counts.
  LineReader(std::istream& in, std::string name)
      : in_(in), name_(std::move(name)), bytes_(util::bytesLeft(in, std::uint64_t{1} << 40)) {}
  bool next(std::string& line) {
    while (std::getline(in_, line)) {
      ++number_;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") != std::string::npos) return true;
    }
    return false;
  }
  std::istringstream fields() {
    std::string line;
    if (!next(line)) fail("unexpected end of file");
    return std::istringstream(line);
  }
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(name_ + ":" + std::to_string(number_) + ": " + message);
  }
  /// A count of items that follow: not negative, and no more than the file can hold.
  std::size_t count(std::istringstream& s, const char* what) {
    const auto n = read<long long>(s, what);
    if (n < 0 || static_cast<unsigned long long>(n) > bytes_)
      fail(std::string(what) + " " + std::to_string(n) + " is negative or more than the file holds");
    return static_cast<std::size_t>(n);
  }
  template <class T>
  T read(std::istringstream& s, const char* what) {
    T v{};
    if (!(s >> v)) fail(std::string("expected ") + what);
    return v;
  }

 private:
  std::istream& in_;
  std::string name_;
  int number_ = 0;
  std::uint64_t bytes_;
};

struct EntityKey {
  int dim, tag;
  bool operator<(const EntityKey& o) const { return dim != o.dim ? dim < o.dim : tag < o.tag; }
};

}  // namespace

Mesh readGmsh(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the mesh file");
  return readGmsh(in, path);
}

Mesh readGmsh(std::istream& in, const std::string& name) {
  LineReader r(in, name);
  std::map<std::pair<int, int>, std::string> physicalNames;  // (dim, tag) -> name
  std::map<EntityKey, std::vector<int>> entityPhysicals;
  std::unordered_map<std::size_t, Index> nodeIndex;  // gmsh tag -> index
  Mesh mesh;
  std::map<EntityKey, std::vector<std::vector<Index>>> entityElements;  // lower-dimensional elements
  std::map<EntityKey, std::vector<std::size_t>> entityHexes;
  bool sawFormat = false, sawNodes = false, sawElements = false;
  std::string line;
  while (r.next(line)) {
    if (line == "$MeshFormat") {
      auto s = r.fields();
      const std::string version = r.read<std::string>(s, "version");
      const int binary = r.read<int>(s, "file type");
      if (version != "4.1") r.fail("Gmsh format " + version + " is not supported (need 4.1)");
      if (binary != 0) r.fail("binary Gmsh files are not supported (save as ASCII)");
      sawFormat = true;
    } else if (line == "$PhysicalNames") {
      auto s = r.fields();
      const std::size_t n = r.count(s, "number of physical names");
      for (std::size_t i = 0; i < n; ++i) {
        auto f = r.fields();
        const int dim = r.read<int>(f, "dimension"), tag = r.read<int>(f, "physical tag");
        std::string rest;
        std::getline(f, rest);
        const auto a = rest.find('"'), b = rest.rfind('"');
        if (a == std::string::npos || b == a) r.fail("physical name must be quoted");
        physicalNames[{dim, tag}] = rest.substr(a + 1, b - a - 1);
      }
    } else if (line == "$Entities") {
      auto s = r.fields();
      std::size_t counts[4];
      for (std::size_t& c : counts) c = r.count(s, "entity count");
      for (int dim = 0; dim < 4; ++dim)
        for (std::size_t i = 0; i < counts[dim]; ++i) {
          auto f = r.fields();
          const int tag = r.read<int>(f, "entity tag");
          for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) r.read<double>(f, "coordinate");
          const int np = r.read<int>(f, "number of physical tags");
          auto& phys = entityPhysicals[{dim, tag}];
          for (int k = 0; k < np; ++k) phys.push_back(std::abs(r.read<int>(f, "physical tag")));
        }
    } else if (line == "$Nodes") {
      auto s = r.fields();
      const std::size_t blocks = r.count(s, "number of entity blocks");
      const std::size_t total = r.count(s, "number of nodes");
      mesh.X.reserve(3 * total);
      for (std::size_t b = 0; b < blocks; ++b) {
        auto h = r.fields();
        r.read<int>(h, "entity dimension");
        r.read<int>(h, "entity tag");
        if (r.read<int>(h, "parametric flag") != 0) r.fail("parametric nodes are not supported");
        const std::size_t n = r.count(h, "nodes in block");
        std::vector<std::size_t> tags(n);
        for (auto& t : tags) {
          auto f = r.fields();
          t = r.read<std::size_t>(f, "node tag");
        }
        for (std::size_t t : tags) {
          auto f = r.fields();
          if (!nodeIndex.emplace(t, static_cast<Index>(mesh.numNodes())).second)
            r.fail("node " + std::to_string(t) + " defined twice");
          for (int k = 0; k < 3; ++k) mesh.X.push_back(r.read<double>(f, "node coordinate"));
        }
      }
      sawNodes = true;
    } else if (line == "$Elements") {
      if (!sawNodes) r.fail("$Elements before $Nodes");
      auto s = r.fields();
      const std::size_t blocks = r.count(s, "number of entity blocks");
      r.count(s, "number of elements");
      for (std::size_t b = 0; b < blocks; ++b) {
        auto h = r.fields();
        const int dim = r.read<int>(h, "entity dimension");
        const int tag = r.read<int>(h, "entity tag");
        const int type = r.read<int>(h, "element type");
        const std::size_t n = r.count(h, "elements in block");
        const std::map<int, int> nodesOf = {{15, 1}, {1, 2}, {2, 3}, {3, 4}, {5, 8}};
        auto it = nodesOf.find(type);
        if (it == nodesOf.end())
          r.fail("element type " + std::to_string(type) + " is not supported (hexahedra: type 5; faces: 3; lines: 1; points: 15)");
        for (std::size_t e = 0; e < n; ++e) {
          auto f = r.fields();
          const std::size_t etag = r.read<std::size_t>(f, "element tag");
          std::vector<Index> nodes;
          for (int k = 0; k < it->second; ++k) {
            const std::size_t t = r.read<std::size_t>(f, "node tag");
            auto found = nodeIndex.find(t);
            if (found == nodeIndex.end())
              r.fail("element " + std::to_string(etag) + " refers to undefined node " + std::to_string(t));
            nodes.push_back(found->second);
          }
          if (type == 5) {
            Hex hex;
            std::copy(nodes.begin(), nodes.end(), hex.begin());
            entityHexes[{dim, tag}].push_back(mesh.elements.size());
            mesh.elements.push_back(hex);
          } else {
            entityElements[{dim, tag}].push_back(std::move(nodes));
          }
        }
      }
      sawElements = true;
    } else if (line.rfind("$End", 0) == 0 || line[0] != '$') {
      continue;  // section ends and the bodies of unknown sections
    }
  }
  if (!sawFormat) throw InputError(name + ": no $MeshFormat section (not a Gmsh file?)");
  if (!sawElements || mesh.elements.empty()) throw InputError(name + ": no hexahedra (element type 5) in the mesh");
  // Hexahedron faces keyed by their sorted nodes, to orient physical surfaces outward.
  std::map<std::array<Index, 4>, Quad> boundary;
  for (const Quad& q : mesh.boundaryFaces()) {
    std::array<Index, 4> key = q;
    std::sort(key.begin(), key.end());
    boundary[key] = q;
  }
  auto groupName = [&](int dim, int tag) {
    auto it = physicalNames.find({dim, tag});
    return it != physicalNames.end() ? it->second : "physical_" + std::to_string(dim) + "_" + std::to_string(tag);
  };
  for (const auto& [key, phys] : entityPhysicals) {
    for (int tag : phys) {
      const std::string g = groupName(key.dim, tag);
      auto& nodes = mesh.nodeSets[g];
      if (key.dim == 3) {
        for (std::size_t e : entityHexes[key]) nodes.insert(nodes.end(), mesh.elements[e].begin(), mesh.elements[e].end());
      } else {
        for (const auto& el : entityElements[key]) {
          nodes.insert(nodes.end(), el.begin(), el.end());
          if (key.dim == 2 && el.size() == 4) {
            std::array<Index, 4> k{el[0], el[1], el[2], el[3]};
            std::sort(k.begin(), k.end());
            auto f = boundary.find(k);
            if (f == boundary.end())
              throw InputError(name + ": physical surface '" + g + "' has a quad that is not a boundary face of the hexahedra");
            mesh.faceSets[g].push_back(f->second);
          }
        }
      }
      std::sort(nodes.begin(), nodes.end());
      nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    }
  }
  std::vector<Index> all(mesh.numNodes());
  for (Index a = 0; a < all.size(); ++a) all[a] = a;
  mesh.nodeSets["all"] = std::move(all);
  return mesh;
}

}  // namespace cosim::fem
