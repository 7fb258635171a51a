#include "cosim/dem/io/checkpoint.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <type_traits>

#include "cosim/util/binary_record.hpp"
#include "cosim/util/stream_size.hpp"

namespace cosim::dem {
namespace {

constexpr char kMagic[8] = {'C', 'O', 'S', 'I', 'M', 'D', 'E', 'M'};
constexpr std::uint32_t kVersion = 9;  // 7: driveWork; 8: excludedPairs; 9: mesh contacts

// pod and vec as util::BinaryWriter; strings and the final check added.
class Writer : public util::BinaryWriter {
 public:
  Writer(std::ostream& out, const std::string& path) : util::BinaryWriter(out), out_(out), path_(path) {}
  void str(const std::string& s) {
    pod(static_cast<std::uint64_t>(s.size()));
    bytes(s.data(), s.size());
  }
  std::uint64_t finish() {
    out_.flush();
    if (!out_) throw std::runtime_error(path_ + ": write failed");
    return static_cast<std::uint64_t>(out_.tellp());
  }

 private:
  std::ostream& out_;
  std::string path_;
};

class Reader {
 public:
  Reader(std::istream& in, const std::string& path) : in_(in), path_(path) {}
  template <class T>
  T pod() {
    // Not every byte is a bool or an enumerator: those go through flag() and enumerator().
    static_assert(!std::is_same_v<T, bool> && !std::is_enum_v<T>);
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof(T));
    check();
    return v;
  }
  bool flag(const char* what) {
    const auto b = pod<std::uint8_t>();
    if (b > 1)
      throw std::runtime_error(path_ + ": corrupt checkpoint (" + what + " is " + std::to_string(b) + ", not 0 or 1)");
    return b == 1;
  }
  /// An enumerator of E written as its value: one of the first `count`.
  template <class E>
  E enumerator(int count, const char* what) {
    const auto v = pod<std::underlying_type_t<E>>();
    if (v < 0 || v >= count)
      throw std::runtime_error(path_ + ": corrupt checkpoint (" + what + " " + std::to_string(v) + ", not below " +
                               std::to_string(count) + ")");
    return static_cast<E>(v);
  }
  /// A count of records of at least `bytesEach` bytes that must still fit in
  /// the file: a corrupt count must not allocate memory the file cannot fill.
  std::uint64_t count(std::uint64_t bytesEach, const char* what) {
    const auto n = pod<std::uint64_t>();
    if (n > util::bytesLeft(in_, std::uint64_t{1} << 40) / bytesEach)
      throw std::runtime_error(path_ + ": corrupt checkpoint (" + std::to_string(n) + " " + what +
                               ", more than the file holds)");
    return n;
  }
  template <class T>
  void vec(std::vector<T>& v) {
    const auto n = count(sizeof(T), "array elements");
    v.resize(n);
    in_.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
    check();
  }
  std::string str() {
    const auto n = pod<std::uint64_t>();
    if (n > 4096) throw std::runtime_error(path_ + ": corrupt checkpoint (string)");
    std::string s(n, '\0');
    in_.read(s.data(), static_cast<std::streamsize>(n));
    check();
    return s;
  }

 private:
  void check() {
    if (!in_) throw std::runtime_error(path_ + ": truncated checkpoint");
  }
  std::istream& in_;
  std::string path_;
};

// externalForces() writes or reads p.fExt in its place.
template <class IO, class P, class Ext>
void particleArrays(IO& io, P& p, Ext&& externalForces) {
  io(p.x); io(p.v); io(p.omega); io(p.q); io(p.f); io(p.torque); externalForces();
  io(p.radius); io(p.mass); io(p.invMass); io(p.inertia); io(p.invInertia);
  io(p.weight); io(p.material); io(p.driven); io(p.id);
}

template <class IO, class N>
void neighborArrays(IO& io, N& n) {
  io(n.rowStart); io(n.partner); io(n.shear); io(n.touching); io(n.revStart); io(n.revPair); io(n.xRef);
}

/// Throws "PATH: inconsistent checkpoint (WHAT)" unless `ok`.
void require(bool ok, const std::string& path, const std::string& what) {
  if (!ok) throw std::runtime_error(path + ": inconsistent checkpoint (" + what + ")");
}

/// A compressed-row index: `start` has rows + 1 ascending entries from 0 to
/// `items`, or is empty when `optional` (the structure is not in use).
void requireRows(const std::vector<std::uint32_t>& start, std::size_t rows, std::size_t items, bool optional,
                 const std::string& path, const std::string& what) {
  if (optional && start.empty() && items == 0) return;
  require(start.size() == rows + 1 && start.front() == 0 && start.back() == items &&
              std::is_sorted(start.begin(), start.end()),
          path, what + " rows do not match");
}

template <class T>
void requireBelow(const std::vector<T>& ids, std::size_t bound, const std::string& path, const std::string& what) {
  for (const T id : ids) require(static_cast<std::size_t>(id) < bound, path, what + " out of range");
}

/// Every length and index a step relies on, checked before the state is used:
/// a corrupt file must stop with its name, not read out of bounds.
void checkRestored(const DemSystem& s, const std::string& path) {
  const Particles& p = s.particles;
  const std::size_t n = p.size();
  for (const std::size_t len : {p.x.size(), p.v.size(), p.omega.size(), p.q.size(), p.f.size(), p.torque.size(), p.fExt.size(),
                                p.radius.size(), p.mass.size(), p.invMass.size(), p.inertia.size(),
                                p.invInertia.size(), p.weight.size(), p.material.size(), p.driven.size(),
                                p.id.size()})
    require(len == n, path, "particle arrays of different lengths");
  require(std::isfinite(s.time), path, "non-finite time");
  require(std::isfinite(s.neighbors.skin) && s.neighbors.skin >= 0.0, path, "neighbour skin not finite and >= 0");
  if (s.cell.enabled) {
    const auto finiteMatrix = [](const Mat3& m) {
      return std::all_of(m.begin(), m.end(), [](double v) { return std::isfinite(v); });
    };
    require(finiteMatrix(s.cell.h) && finiteMatrix(s.cell.velocityGradient) && finiteMatrix(s.neighbors.hRef), path,
            "non-finite periodic cell");
    require(s.cell.volume() > 0.0 && std::isfinite(s.cell.volume()), path, "periodic cell without a positive, finite volume");
    for (int d = 0; d < 3; ++d) require(std::isfinite(s.cell.width(d)), path, "periodic cell of a non-finite width");
  }
  requireBelow(p.material, s.materials.size(), path, "particle material");
  const auto finite = [](const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); };
  for (std::size_t i = 0; i < n; ++i) {
    if (const std::string defect = p.defectOf(i); !defect.empty())
      require(false, path, "particle " + std::to_string(p.id[i]) + ": " + defect);
    // The first half kick of the next step uses them.
    require(finite(p.f[i]) && finite(p.torque[i]) && finite(p.fExt[i]), path,
            "particle " + std::to_string(p.id[i]) + ": non-finite force or torque");
  }
  const NeighborList& nl = s.neighbors;
  const std::size_t pairs = nl.partner.size();
  requireRows(nl.rowStart, n, pairs, false, path, "neighbour list");
  requireBelow(nl.partner, n, path, "neighbour partner");
  require(nl.shear.size() == pairs && nl.touching.size() == pairs && s.pairForce.size() == pairs, path,
          "pair arrays do not match the neighbour list");
  // The pair loop reads one image per pair in a periodic cell, none otherwise.
  require(nl.image.size() == (s.cell.enabled ? pairs : 0), path,
          s.cell.enabled ? "periodic images do not match the neighbour list" : "periodic images without a periodic cell");
  requireRows(nl.revStart, n, nl.revPair.size(), false, path, "reverse neighbour list");
  requireBelow(nl.revPair, pairs, path, "reverse neighbour pair");
  require(nl.xRef.size() == n, path, "reference positions do not match the particles");
  requireRows(nl.exclStart, n, nl.exclPartner.size(), true, path, "excluded pairs");
  requireBelow(nl.exclPartner, n, path, "excluded partner");
  const BondedSprings& b = s.bonds;
  require(b.second.size() == b.first.size() && b.rest.size() == b.first.size(), path, "bond arrays of different lengths");
  requireBelow(b.first, n, path, "bond end");
  requireBelow(b.second, n, path, "bond end");
  requireRows(b.byParticleStart, n, b.byParticle.size(), true, path, "bonds per particle");
  requireBelow(b.byParticle, b.first.size(), path, "bond id");
  require(s.planeNear.size() == n, path, "plane candidates do not match the particles");
  for (std::size_t k = 0; k < s.planes.size(); ++k) {
    require(s.planes[k].material < s.materials.size(), path, "plane '" + s.planes[k].name + "' material out of range");
    require(s.planeShear[k].size() == n && s.planeTouch[k].size() == n && s.planeContactForce[k].size() == n, path,
            "plane '" + s.planes[k].name + "' contact arrays do not match the particles");
  }
  for (const TriangleWallGroup& m : s.meshes) {
    const std::string who = "triangle wall group '" + m.name + "' ";
    require(m.material < s.materials.size(), path, who + "material out of range");
    require(m.velocities.size() == m.vertices.size() && m.verticesAtBuild().size() == m.vertices.size(), path,
            who + "vertex arrays of different lengths");
    for (const auto& tri : m.triangles)
      for (const std::uint32_t v : tri) require(v < m.vertices.size(), path, who + "triangle vertex out of range");
    requireRows(m.candStart, n, m.candTri.size(), false, path, who + "candidates");
    requireBelow(m.candTri, m.triangles.size(), path, who + "candidate triangle");
    require(m.history.size() == n, path, who + "contact history does not match the particles");
    for (const auto& slots : m.history)
      for (const auto& slot : slots)
        require(slot.triangle >= -1 && slot.triangle < static_cast<std::int64_t>(m.triangles.size()), path,
                who + "contact history triangle out of range");
    for (const TriangleContact& c : m.contacts)
      require(c.particle < n && c.triangle < m.triangles.size(), path, who + "contact out of range");
  }
}

}  // namespace

std::uint64_t writeCheckpoint(const DemSystem& s, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open checkpoint for writing");
  return writeCheckpoint(s, out, path);
}

void readCheckpoint(DemSystem& s, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open checkpoint");
  readCheckpoint(s, in, path);
}

std::uint64_t writeCheckpoint(const DemSystem& s, std::ostream& out, const std::string& path) {
  Writer w(out, path);
  w.pod(kMagic);
  w.pod(kVersion);
  for (const auto& name : s.contactLawNames()) w.str(name);
  w.str(s.integratorName());
  w.pod(s.time); w.pod(s.step); w.pod(s.dissipated); w.pod(s.externalWork); w.pod(s.driveWork); w.pod(s.gravity);
  w.pod(static_cast<std::uint64_t>(s.materials.size()));
  for (const Material& m : s.materials.all()) {
    w.str(m.name);
    w.pod(m.density); w.pod(m.young); w.pod(m.poisson); w.pod(m.restitution); w.pod(m.friction); w.pod(m.kn); w.pod(m.kt);
  }
  auto io = [&w](const auto& v) { w.vec(v); };
  particleArrays(io, s.particles, [&] { io(s.particles.fExt.values()); });
  w.pod(s.neighbors.skin);
  w.pod(s.neighbors.builds);
  neighborArrays(io, s.neighbors);
  w.vec(s.neighbors.image);
  w.pod(s.neighbors.hRef);
  w.pod(s.cell.enabled);
  w.pod(s.cell.h);
  w.pod(s.cell.velocityGradient);
  w.pod(s.massDamping);
  w.pod(s.bonds.stiffness);
  w.vec(s.bonds.first); w.vec(s.bonds.second); w.vec(s.bonds.rest);
  w.vec(s.bonds.byParticleStart); w.vec(s.bonds.byParticle);
  w.vec(s.neighbors.exclStart); w.vec(s.neighbors.exclPartner);
  {  // the pairs initialize() lists again (hybrid PD families arrive at an exchange, not with the scene)
    std::vector<std::uint32_t> flat;
    for (const auto& [a, b] : s.excludedPairs) flat.insert(flat.end(), {a, b});
    w.vec(flat);
  }
  w.vec(s.pairForce);
  w.pod(static_cast<std::uint64_t>(s.planes.size()));
  for (std::size_t k = 0; k < s.planes.size(); ++k) {
    const PlaneWall& p = s.planes[k];
    w.str(p.name);
    w.pod(p.point); w.pod(p.normal); w.pod(p.velocity); w.pod(p.mode); w.pod(p.material);
    w.pod(p.servoStress); w.pod(p.servoArea); w.pod(p.servoGain); w.pod(p.force); w.pod(p.torque);
    w.vec(s.planeShear[k]);
    w.vec(s.planeTouch[k]);
    w.vec(s.planeContactForce[k]);
  }
  w.vec(s.planeNear);
  w.vec(s.planesAtMark);
  w.pod(static_cast<std::uint64_t>(s.meshes.size()));
  for (const TriangleWallGroup& m : s.meshes) {
    w.str(m.name);
    w.pod(m.material);
    w.vec(m.vertices); w.vec(m.velocities); w.vec(m.triangles); w.vec(m.candStart); w.vec(m.candTri);
    w.vec(m.history); w.vec(m.verticesAtBuild()); w.pod(m.force); w.pod(m.torque);
    w.vec(m.contacts);  // the next step's wall work charges their forces (TriangleWallGroup::workBeforeEvaluation)
  }
  return w.finish();
}

void readCheckpoint(DemSystem& s, std::istream& in, const std::string& path) {
  Reader r(in, path);
  const auto magic = r.pod<std::array<char, 8>>();
  if (std::memcmp(magic.data(), kMagic, 8) != 0) throw std::runtime_error(path + ": not a dem_solver checkpoint");
  if (r.pod<std::uint32_t>() != kVersion) throw std::runtime_error(path + ": unsupported checkpoint version");
  const std::string normal = r.str(), tangential = r.str(), damping = r.str(), integrator = r.str();
  try {
    s.setContactLaw(normal, tangential, damping);
    s.setIntegrator(integrator);
  } catch (const std::invalid_argument& e) {  // an unknown name: the registries say which
    throw std::runtime_error(path + ": corrupt checkpoint (" + e.what() + ")");
  }
  s.time = r.pod<double>(); s.step = r.pod<std::uint64_t>(); s.dissipated = r.pod<double>();
  s.externalWork = r.pod<double>(); s.driveWork = r.pod<double>(); s.gravity = r.pod<Vec3>();
  s.materials = MaterialTable{};
  const auto nmat = r.count(8, "materials");
  for (std::uint64_t i = 0; i < nmat; ++i) {
    Material m;
    m.name = r.str();
    m.density = r.pod<double>(); m.young = r.pod<double>(); m.poisson = r.pod<double>();
    m.restitution = r.pod<double>(); m.friction = r.pod<double>(); m.kn = r.pod<double>(); m.kt = r.pod<double>();
    s.materials.add(m);
  }
  s.contactLaw().prepare(s.materials);
  auto io = [&r](auto& v) { r.vec(v); };
  particleArrays(io, s.particles, [&] {
    std::vector<Vec3> forces;
    io(forces);
    s.particles.fExt.restore(std::move(forces));
  });
  s.neighbors.skin = r.pod<double>();
  s.neighbors.builds = r.pod<std::uint64_t>();
  neighborArrays(io, s.neighbors);
  r.vec(s.neighbors.image);
  s.neighbors.hRef = r.pod<Mat3>();
  s.cell.enabled = r.flag("periodic cell flag");
  s.cell.h = r.pod<Mat3>();
  s.cell.velocityGradient = r.pod<Mat3>();
  s.massDamping = r.pod<double>();
  s.bonds.stiffness = r.pod<double>();
  r.vec(s.bonds.first); r.vec(s.bonds.second); r.vec(s.bonds.rest);
  r.vec(s.bonds.byParticleStart); r.vec(s.bonds.byParticle);
  r.vec(s.neighbors.exclStart); r.vec(s.neighbors.exclPartner);
  {
    std::vector<std::uint32_t> flat;
    r.vec(flat);
    require(flat.size() % 2 == 0, path, "excluded pair list of odd length");
    requireBelow(flat, s.particles.size(), path, "excluded pair member");
    s.excludedPairs.clear();
    for (std::size_t k = 0; k + 1 < flat.size(); k += 2) s.excludedPairs.emplace_back(flat[k], flat[k + 1]);
  }
  r.vec(s.pairForce);
  s.planes.resize(r.count(8, "planes"));
  s.planeShear.resize(s.planes.size());
  s.planeTouch.resize(s.planes.size());
  s.planeContactForce.resize(s.planes.size());
  for (std::size_t k = 0; k < s.planes.size(); ++k) {
    PlaneWall& p = s.planes[k];
    p.name = r.str();
    p.point = r.pod<Vec3>(); p.normal = r.pod<Vec3>(); p.velocity = r.pod<Vec3>();
    p.mode = r.enumerator<PlaneWall::Mode>(3, "plane wall mode");
    p.material = r.pod<std::uint16_t>(); p.servoStress = r.pod<double>(); p.servoArea = r.pod<double>();
    p.servoGain = r.pod<double>(); p.force = r.pod<Vec3>(); p.torque = r.pod<Vec3>();
    r.vec(s.planeShear[k]);
    r.vec(s.planeTouch[k]);
    r.vec(s.planeContactForce[k]);
  }
  r.vec(s.planeNear);
  r.vec(s.planesAtMark);
  s.meshes.resize(r.count(8, "triangle wall groups"));
  for (TriangleWallGroup& m : s.meshes) {
    m.name = r.str();
    m.material = r.pod<std::uint16_t>();
    r.vec(m.vertices); r.vec(m.velocities); r.vec(m.triangles); r.vec(m.candStart); r.vec(m.candTri);
    r.vec(m.history);
    std::vector<Vec3> ref;
    r.vec(ref);
    m.setVerticesAtBuild(std::move(ref));
    m.force = r.pod<Vec3>(); m.torque = r.pod<Vec3>();
    r.vec(m.contacts);
    m.markEvaluated();  // written after a step: the contacts are those of these vertices
  }
  checkRestored(s, path);
  s.neighbors.indexPairs(s.particles.size());  // pairRow is not stored
  s.indexPlaneCandidates();                    // nor the list of planeNear
  s.markDrivenEvaluated();  // written after a step: the forces are those of these positions
}

}  // namespace cosim::dem
