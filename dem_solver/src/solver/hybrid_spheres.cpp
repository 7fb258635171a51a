#include "cosim/dem/solver/hybrid_spheres.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <span>
#include <stdexcept>
#include <string>

#include "cosim/dem/solver/scene_params.hpp"
#include "cosim/util/binary_record.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::dem {
namespace {

Vec3 at(std::span<const double> v, std::size_t k) { return {v[3 * k], v[3 * k + 1], v[3 * k + 2]}; }

bool finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

}  // namespace

std::vector<std::pair<std::uint32_t, std::uint32_t>> familyPairs(const std::vector<std::uint32_t>& bodies,
                                                                  const std::vector<double>& refPositions,
                                                                  const std::vector<double>& horizons) {
  const std::size_t n = bodies.size();
  if (refPositions.size() != 3 * n)
    throw std::invalid_argument("hybrid particles: " + std::to_string(refPositions.size()) +
                                " reference coordinates for " + std::to_string(n) + " particles");
  // Bin each body's particles in cells one horizon wide: family partners lie in the 27 around.
  std::map<std::array<long, 4>, std::vector<std::uint32_t>> cells;
  std::vector<std::array<long, 4>> key(n);
  for (std::size_t a = 0; a < n; ++a) {
    const std::uint32_t b = bodies[a];
    if (b >= horizons.size() || !(horizons[b] > 0.0))
      throw std::invalid_argument("hybrid particle " + std::to_string(a) + ": body " + std::to_string(b) +
                                  " has no positive horizon (" + std::to_string(horizons.size()) + " sent)");
    key[a] = {static_cast<long>(b), 0, 0, 0};
    for (std::size_t d = 0; d < 3; ++d)
      key[a][d + 1] = static_cast<long>(std::floor(refPositions[3 * a + d] / horizons[b]));
    cells[key[a]].push_back(static_cast<std::uint32_t>(a));
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (std::size_t a = 0; a < n; ++a) {
    // A family is |xi| <= delta (Hartmann Eq. 1); the relative slack keeps lattice
    // partners exactly at delta in the family despite round-off.
    const double reach = horizons[bodies[a]] * (1.0 + 1e-9);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find({key[a][0], key[a][1] + dx, key[a][2] + dy, key[a][3] + dz});
          if (it == cells.end()) continue;
          for (std::uint32_t b : it->second) {
            if (b <= a) continue;
            double d2 = 0.0;
            for (std::size_t d = 0; d < 3; ++d) {
              const double e = refPositions[3 * a + d] - refPositions[3 * b + d];
              d2 += e * e;
            }
            if (d2 <= reach * reach) pairs.emplace_back(static_cast<std::uint32_t>(a), b);
          }
        }
  }
  return pairs;
}

bool HybridSpheres::apply(proto::HybridParticles::Reader message, DemSystem& system, std::uint16_t material) {
  const auto ids = wire::view(message.getIds());
  const bool first = ids_.empty();
  if (first && ids.empty())
    throw std::invalid_argument("hybrid particles: the first message must carry the set (ids, body ids, reference "
                                "positions, radii, horizons); this one holds only positions and velocities");
  if (first) add(message, system, material);
  wantStiffness_ = message.getWantStiffness();
  stateArrived_ = true;
  if (lastStateTime_ >= 0.0) cadence_ = system.time - lastStateTime_;
  lastStateTime_ = system.time;
  if (message.getPartial()) {
    applyPartial(message, system);
    return first;
  }
  // Every state: the parked ones move again, and a new watch set follows.
  partial_ = false;
  // (Unconditionally: a checkpoint taken while parked holds the flags.)
  for (const std::uint32_t i : index_) system.particles.driven[i] = 1;
  parked_ = false;
  watch_.forget();
  fullSerial_ = message.getSerial();
  pendingRebuild_ = true;
  // Without ids the states are the set's, in its order (pddem.capnp).
  const std::size_t n = ids.empty() ? ids_.size() : ids.size();
  if (n != ids_.size())
    throw std::invalid_argument("hybrid particles: " + std::to_string(n) + " sent, but the set had " +
                                std::to_string(ids_.size()) + " (the set is fixed at its first exchange)");
  const auto x = wire::view(message.getPositions());
  const auto v = wire::view(message.getVelocities());
  if (x.size() != 3 * n || v.size() != 3 * n)
    throw std::invalid_argument("hybrid particles: positions and velocities must hold 3 values per particle (" +
                                std::to_string(n) + " particles, " + std::to_string(x.size()) + " and " +
                                std::to_string(v.size()) + " values)");
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t slot = ids.empty() ? static_cast<std::uint32_t>(k) : slotOf(ids[k]);
    const Vec3 xk = at(x, k), vk = at(v, k);
    if (!finite(xk) || !finite(vk))
      throw std::invalid_argument("hybrid particles: non-finite state of id " + std::to_string(ids_[slot]));
    system.setDrivenState(index_[slot], xk, vk);
  }
  return first;
}

void HybridSpheres::applyPartial(proto::HybridParticles::Reader message, DemSystem& system) {
  const auto indices = wire::view(message.getIndices());
  watch_.checkPartial(message.getWatchBasis(), indices);
  const auto x = wire::view(message.getPositions());
  const auto v = wire::view(message.getVelocities());
  if (x.size() != 3 * indices.size() || v.size() != 3 * indices.size())
    throw std::invalid_argument("hybrid particles: partial states of " + std::to_string(indices.size()) +
                                " particles with " + std::to_string(x.size()) + " position and " +
                                std::to_string(v.size()) + " velocity values (need 3 per particle)");
  partial_ = true;
  if (!parked_)  // unwatched hybrids keep the place their last state drifted them to
    for (std::uint32_t k = 0; k < index_.size(); ++k)
      if (!watch_.watches(k)) system.particles.driven[index_[k]] = 2;
  parked_ = true;
  for (std::size_t q = 0; q < indices.size(); ++q) {
    const Vec3 xk = at(x, q), vk = at(v, q);
    if (!finite(xk) || !finite(vk))
      throw std::invalid_argument("hybrid particles: non-finite state of id " + std::to_string(ids_[indices[q]]));
    system.setDrivenState(index_[indices[q]], xk, vk);
  }
}

std::uint32_t HybridSpheres::slotOf(std::uint32_t id) const {
  const auto it = slot_.find(id);
  if (it == slot_.end())
    throw std::invalid_argument("hybrid particles: id " + std::to_string(id) + " was not in the first set");
  return it->second;
}

void HybridSpheres::add(proto::HybridParticles::Reader message, DemSystem& system, std::uint16_t material) {
  const auto ids = wire::view(message.getIds());
  const auto bodies = wire::view(message.getBodyIds());
  const auto radii = wire::view(message.getRadii());
  const auto ref = wire::view(message.getReferencePositions());
  const auto horizons = wire::view(message.getHorizons());
  if (bodies.size() != ids.size() || radii.size() != ids.size())
    throw std::invalid_argument("hybrid particles: " + std::to_string(ids.size()) + " ids but " +
                                std::to_string(bodies.size()) + " body ids and " + std::to_string(radii.size()) +
                                " radii");
  const auto pairs = familyPairs({bodies.begin(), bodies.end()}, {ref.begin(), ref.end()},
                                 {horizons.begin(), horizons.end()});
  Particles& p = system.particles;
  const auto first = static_cast<std::uint32_t>(p.size());
  // Mass from the hybrid material's density and the quasi-radius (rho 4/3 pi R^3 = rho V, Eq. 39):
  // it enters only the reduced mass of the contact damping.
  const double density = system.materials[material].density;
  for (std::size_t k = 0; k < ids.size(); ++k) {
    if (!(radii[k] > 0.0) || !std::isfinite(radii[k]))
      throw std::invalid_argument("hybrid particle id " + std::to_string(ids[k]) + ": radius must be positive");
    if (!slot_.emplace(ids[k], static_cast<std::uint32_t>(k)).second)
      throw std::invalid_argument("hybrid particles: id " + std::to_string(ids[k]) + " sent twice");
    const std::size_t i = p.add({}, radii[k], density, material);
    p.driven[i] = 1;
    ids_.push_back(ids[k]);
    index_.push_back(static_cast<std::uint32_t>(i));
  }
  for (const auto& [a, b] : pairs) system.excludedPairs.emplace_back(first + a, first + b);
  sizeSums();
}

void HybridSpheres::sizeSums() {
  impulse_.assign(ids_.size(), {});
  mean_.assign(ids_.size(), {});
  positionSum_.assign(ids_.size(), {});
  meanPosition_.assign(ids_.size(), {});
  averaged_ = false;
}

namespace {
constexpr std::uint64_t kHybridMagic = 0x3142594848534f43;  // "COSHHYB1"
}  // namespace

void HybridSpheres::save(std::ostream& out) const {
  if (ids_.empty()) return;
  util::BinaryWriter w(out);
  w.pod(kHybridMagic);
  w.vec(ids_), w.vec(index_);
  w.pod(fullSerial_);
  for (const bool b : {pendingRebuild_, stateArrived_, partial_, parked_}) w.pod(static_cast<std::uint8_t>(b));
  w.pod(lastStateTime_), w.pod(cadence_);
  watch_.save(w);
}

void HybridSpheres::load(std::istream& in, const std::string& path, std::size_t particles) {
  std::uint64_t magic = 0;
  if (!in.read(reinterpret_cast<char*>(&magic), sizeof magic)) return;  // the system alone: no hybrids
  util::BinaryReader r(in, path);
  if (magic != kHybridMagic) r.fail("hybrid particles", "not a hybrid particle record after the DEM system");
  auto ids = r.vec<std::uint32_t>("hybrid particle ids");
  auto index = r.vec<std::uint32_t>("hybrid particle indices");
  if (index.size() != ids.size()) r.fail("hybrid particles", "ids and indices differ in number");
  slot_.clear();
  for (std::size_t k = 0; k < ids.size(); ++k)
    if (index[k] >= particles || !slot_.emplace(ids[k], static_cast<std::uint32_t>(k)).second)
      r.fail("hybrid particles", "id " + std::to_string(ids[k]) + " at index " + std::to_string(index[k]) +
                                     " repeats or lies beyond the " + std::to_string(particles) + " particles");
  fullSerial_ = r.pod<std::uint64_t>("hybrid particles");
  for (bool* b : {&pendingRebuild_, &stateArrived_, &partial_, &parked_})
    *b = r.pod<std::uint8_t>("hybrid particles") != 0;
  lastStateTime_ = r.pod<double>("hybrid particles");
  cadence_ = r.pod<double>("hybrid particles");
  watch_.load(r, particles, ids.size());
  ids_ = std::move(ids);
  index_ = std::move(index);
  sizeSums();
}

void HybridSpheres::checkStartOverlaps(const DemSystem& system, double tolerance) const {
  std::unordered_map<std::uint32_t, std::uint32_t> pdIdOf;  // DEM index -> PD id
  for (std::size_t k = 0; k < index_.size(); ++k) pdIdOf.emplace(index_[k], ids_[k]);
  const auto o = excessOverlap(system, tolerance, [&pdIdOf](std::uint32_t i, std::uint32_t j) {
    return pdIdOf.count(i) > 0 || pdIdOf.count(j) > 0;
  });
  if (!o) return;
  const auto name = [&](std::uint32_t n) {
    const auto h = pdIdOf.find(n);
    return h != pdIdOf.end() ? "hybrid PD particle " + std::to_string(h->second)
                             : "DEM particle " + std::to_string(system.particles.id[n]);
  };
  throw std::invalid_argument(name(o->i) + " starts inside " + name(o->j) + ": overlap " + std::to_string(o->overlap) +
                              " m, tolerance " + std::to_string(o->allowed) +
                              " m (params.overlap_tolerance x the smaller radius)");
}

void HybridSpheres::beginInterval(const DemSystem& system, double interval) {
  impulse_.assign(ids_.size(), {});
  // The mean position goes out with the stiffness only (fill).
  if (wantStiffness_) positionSum_.assign(ids_.size(), {});
  // A watch set needs the time a state drifts over: the time between two
  // messages, known from the second on.
  if (pendingRebuild_ && cadence_ > 0.0 && watch_.available(system))
    watch_.rebuild(system, index_, fullSerial_, std::max(cadence_, interval));
  watch_.beginInterval(system, partial_, stateArrived_);
  pendingRebuild_ = stateArrived_ = false;
}

void HybridSpheres::accumulate(const DemSystem& system, double dt) {
  watch_.track(system, dt);
  const Particles& p = system.particles;
  // p.f of a driven sphere is its contact and wall reaction only (no body force).
  for (std::size_t k = 0; k < index_.size(); ++k) impulse_[k] += p.f[index_[k]];
  if (!wantStiffness_) return;  // the mean position goes out with the stiffness only
  for (std::size_t k = 0; k < index_.size(); ++k) positionSum_[k] += p.x[index_[k]];
}

void HybridSpheres::endInterval(std::uint32_t steps, const DemSystem& system) {
  watch_.endInterval(system);
  for (std::size_t k = 0; k < impulse_.size(); ++k) mean_[k] = (1.0 / steps) * impulse_[k];
  if (wantStiffness_)
    for (std::size_t k = 0; k < positionSum_.size(); ++k) meanPosition_[k] = (1.0 / steps) * positionSum_[k];
  averaged_ = true;
}

void HybridSpheres::fill(proto::HybridForces::Builder out, const DemSystem& system) const {
  const Particles& p = system.particles;
  // Loaded particles only (pddem.capnp): an unlisted one has no force, and PD
  // clamps a linearised change about a zero force to zero, so nothing is lost.
  auto& loaded = loaded_;
  loaded.clear();
  for (std::uint32_t k = 0; k < ids_.size(); ++k) {
    const Vec3 fk = averaged_ ? mean_[k] : p.f[index_[k]];
    if (fk.x != 0.0 || fk.y != 0.0 || fk.z != 0.0) loaded.push_back(k);
  }
  watch_.fill(out);
  const auto n = static_cast<unsigned>(loaded.size());
  auto ids = wire::view(out.initIds(n));
  auto f = wire::view(out.initForces(3 * n));
  for (unsigned q = 0; q < n; ++q) {
    const std::uint32_t k = loaded[q];
    ids[q] = ids_[k];
    const Vec3 fk = averaged_ ? mean_[k] : p.f[index_[k]];
    for (int d = 0; d < 3; ++d) f[3 * q + static_cast<unsigned>(d)] = fk[d];
  }
  if (!wantStiffness_) return;
  auto x = wire::view(out.initPositions(3 * n));
  for (unsigned q = 0; q < n; ++q) {
    const std::uint32_t k = loaded[q];
    const Vec3 xk = averaged_ ? meanPosition_[k] : p.x[index_[k]];
    for (int d = 0; d < 3; ++d) x[3 * q + static_cast<unsigned>(d)] = xk[d];
  }
  const std::vector<double> k = stiffness(system);
  auto kOut = wire::view(out.initStiffness(6 * n));
  for (unsigned q = 0; q < n; ++q)
    std::copy_n(k.begin() + 6 * static_cast<long>(loaded[q]), 6, kOut.begin() + 6 * q);
}

namespace {

/// Adds the stiffness of one contact with unit normal n to a 6-vector (xx yy zz
/// xy xz yz): S_n n (x) n normally and kTangent (I - n (x) n) across, where
/// kTangent is k_t while the tangential spring sticks (|F_t| below the Coulomb
/// limit: sliding contacts have none) minus F_n / |d| for a sphere pair, whose
/// normal turns as the particle moves across it (geometric stiffness).
void addContactStiffness(double* k, const Vec3& n, double sn, double kTangent, double weight) {
  const double a = weight * (sn - kTangent), b = weight * kTangent;
  k[0] += a * n.x * n.x + b;
  k[1] += a * n.y * n.y + b;
  k[2] += a * n.z * n.z + b;
  k[3] += a * n.x * n.y;
  k[4] += a * n.x * n.z;
  k[5] += a * n.y * n.z;
}

/// k_t of a contact whose force on the particle is f, or 0 while it slides.
double stickingStiffness(const TangentialLaw& law, const Vec3& f, const Vec3& n, double overlap, double rEff,
                         const PairMaterial& pm) {
  const double kt = law.stiffness(overlap, rEff, pm);
  if (kt <= 0.0) return 0.0;
  const double fn = dot(f, n);
  const double ft = std::sqrt(std::max(0.0, norm2(f) - fn * fn));
  return ft < (1.0 - 1e-6) * pm.friction * std::fabs(fn) ? kt : 0.0;
}

}  // namespace

std::vector<double> HybridSpheres::stiffness(const DemSystem& system) const {
  const Particles& p = system.particles;
  const ContactLaw& law = system.contactLaw();
  std::vector<double> k(6 * ids_.size(), 0.0);
  std::vector<std::int64_t> slot(p.size(), -1);
  for (std::size_t s = 0; s < index_.size(); ++s) slot[index_[s]] = static_cast<std::int64_t>(s);
  forEachOverlap(system, [&](const PairOverlap& c) {
    if (c.dist <= 0.0 || (slot[c.i] < 0 && slot[c.j] < 0)) return;
    const Vec3 n = (1.0 / c.dist) * c.d;
    const PairMaterial& pm = system.materials.pair(p.material[c.i], p.material[c.j]);
    const NormalResponse nr = law.normal().evaluate(c.overlap, c.rEff, pm);
    const double kt = stickingStiffness(law.tangential(), system.pairForce[c.k].force, n, c.overlap, c.rEff, pm);
    // The pair force depends on x_i - x_j: -df_i/dx_i = -df_j/dx_j = K.
    const double w = 0.5 * (p.weight[c.i] + p.weight[c.j]);
    for (const std::int64_t s : {slot[c.i], slot[c.j]})
      if (s >= 0) addContactStiffness(&k[6 * static_cast<std::size_t>(s)], n, nr.stiffness, kt - nr.force / c.dist, w);
  });
  for (std::size_t wl = 0; wl < system.planes.size(); ++wl) {
    const PlaneWall& wall = system.planes[wl];
    for (std::size_t s = 0; s < index_.size(); ++s) {
      const std::uint32_t i = index_[s];
      if (!system.planeTouch[wl][i]) continue;
      const double overlap = p.radius[i] - dot(p.x[i] - wall.point, wall.normal);
      if (overlap <= 0.0) continue;
      const PairMaterial& pm = system.materials.pair(p.material[i], wall.material);
      const double sn = law.normal().evaluate(overlap, p.radius[i], pm).stiffness;
      const double kt =
          stickingStiffness(law.tangential(), system.planeContactForce[wl][i], wall.normal, overlap, p.radius[i], pm);
      addContactStiffness(&k[6 * s], wall.normal, sn, kt, p.weight[i]);
    }
  }
  return k;
}

}  // namespace cosim::dem
