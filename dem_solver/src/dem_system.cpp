#include "cosim/dem/dem_system.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "cosim/dem/contact/builtin_laws.hpp"
#include "cosim/dem/lane_batch.hpp"
#include "cosim/dem/parallel.hpp"

namespace cosim::dem {

namespace {

// Contacts of one thread waiting for evaluation, as structure of arrays: the
// pair loop finds contacts pair by pair (branchy), then evaluates a batch of
// them in one loop without branches, which the compiler vectorises (the
// built-in Hertz-Mindlin law is written with selects for that), then hands the
// results back in the order found, so sums are as in a row loop.
struct ContactBatch : LaneBatch<64> {
  Lane<std::uint32_t> pair, row, partner, material;  // material: index into the pair table
  Lane<double> dx, dy, dz;                           // x_i - x_j (with the image shift)
  Lane<double> sx, sy, sz;                           // advanced history (read from the pair's own)
  // Results: force on i, the torque terms a_i n x f and -a_j n x f, energy lost.
  Lane<double> fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz, lost;

  /// Writes pair k into the next lane; it stays there only if `keep` (about
  /// half the listed pairs touch).
  void offer(bool keep, std::uint32_t i, std::uint32_t j, std::uint32_t k, std::uint32_t pairMaterial, const Vec3& d) {
    pair[count] = k, row[count] = i, partner[count] = j, material[count] = pairMaterial;
    dx[count] = d.x, dy[count] = d.y, dz[count] = d.z;
    keepIf(keep);
  }
};

// The contact forces of a batch (each lane independent of the others), in a
// loop compiled for the widest vectors the CPU has (COSIM_DEM_SIMD_CLONES). The
// history is read through the pair index: copying it into the batch cost
// every listed pair, in contact or not, three loads and three stores.
template <bool Periodic, class Normal, class Tangential>
COSIM_DEM_SIMD_CLONES void evaluateContacts(ContactBatch& b, const Particles& p, const Vec3* history,
                                            const PairMaterial* pairs,
                                            const Normal& normalLaw, const Tangential& tangentialLaw, const Mat3& gradV,
                                            double dt) {
  const std::size_t count = b.count;
  // ivdep rather than omp simd: the latter privatises the law's small structs
  // per lane, which stops GCC 12 from vectorising.
#pragma GCC ivdep
  for (std::size_t e = 0; e < count; ++e) {
    const std::uint32_t i = b.row[e], j = b.partner[e];
    const Vec3 d{b.dx[e], b.dy[e], b.dz[e]};
    const double ri = p.radius[i], rj = p.radius[j];
    const double rsum = ri + rj;
    const double dist = std::sqrt(norm2(d));
    const double overlap = rsum - dist;
    const Vec3 nrm = (1.0 / dist) * d;  // from j to i
    // Contact point halfway into the overlap: c_i = -a_i n, c_j = a_j n, so
    // v_i + w_i x c_i - (v_j + w_j x c_j) = v_i - v_j - (a_i w_i + a_j w_j) x n.
    const double armI = ri - 0.5 * overlap, armJ = rj - 0.5 * overlap;
    Vec3 vrel = p.v[i] - p.v[j] - cross(armI * p.omega[i] + armJ * p.omega[j], nrm);
    if constexpr (Periodic) vrel += mul(gradV, d);  // affine part of the relative motion
    // R* = r_i r_j / (r_i + r_j) and m* likewise, with one division.
    const double mi = p.mass[i], mj = p.mass[j], msum = mi + mj;
    const double inv = 1.0 / (rsum * msum);
    const double rEff = ri * rj * msum * inv;
    const double mEff = mi * mj * rsum * inv;
    Vec3 shear = history[b.pair[e]];
    double lost = 0.0;
    Vec3 f = composedForce(normalLaw, tangentialLaw, nrm, overlap, vrel, rEff, mEff, pairs[b.material[e]], dt, shear,
                           lost);
    // Arlequin: contact forces scaled by w at the contact point (Cheng 2022 Eq. 26),
    // w there taken as the mean of the two particles' weights.
    const double wc = 0.5 * (p.weight[i] + p.weight[j]);
    f *= wc;
    // Torques c_i x f = -a_i n x f on i and -c_j x f = -a_j n x f on j.
    const Vec3 nf = cross(nrm, f);
    const Vec3 ti = armI * nf, tj = -armJ * nf;
    b.fx[e] = f.x, b.fy[e] = f.y, b.fz[e] = f.z;
    b.tix[e] = ti.x, b.tiy[e] = ti.y, b.tiz[e] = ti.z;
    b.tjx[e] = tj.x, b.tjy[e] = tj.y, b.tjz[e] = tj.z;
    b.sx[e] = shear.x, b.sy[e] = shear.y, b.sz[e] = shear.z;
    b.lost[e] = wc * lost;
  }
}

// c_i of a sphere of radius r_i touching a wall (plane or triangle) with
// overlap u along the wall's normal n (towards the sphere): halfway into the
// overlap, c_i = -(r_i - u/2) n, as for pairs.
inline Vec3 wallContactArm(double ri, double overlap, const Vec3& n) { return -(ri - 0.5 * overlap) * n; }

// Plane contacts of one chunk of the gather waiting for evaluation, as the
// pair loop's ContactBatch: found candidate by candidate (branchy), evaluated
// in one loop without branches, handed back in the order found. The wall's
// normal and velocity and the history are copied into the lane.
struct PlaneBatch : LaneBatch<64> {
  Lane<std::uint32_t> candidate, material;  // material: index into the pair table
  Lane<double> overlap, nx, ny, nz, wx, wy, wz;
  Lane<double> sx, sy, sz;  // history in, advanced history out
  // Results: force on the particle (scaled by its weight), its torque, energy lost (unscaled).
  Lane<double> fx, fy, fz, tx, ty, tz, lost;
};

// The plane contact forces of a batch, each lane independent of the others
// (COSIM_DEM_SIMD_CLONES as for pairs); R* = r_i and m* = m_i against a wall.
template <class Normal, class Tangential>
COSIM_DEM_SIMD_CLONES void evaluatePlaneContacts(PlaneBatch& b, const Particles& p,
                                                 const PlaneCandidate* cand, const PairMaterial* pairs,
                                                 const Normal& normalLaw, const Tangential& tangentialLaw, double dt) {
  const std::size_t count = b.count;
#pragma GCC ivdep
  for (std::size_t e = 0; e < count; ++e) {
    const std::uint32_t i = cand[b.candidate[e]].particle;
    const double ri = p.radius[i], overlap = b.overlap[e];
    const Vec3 n{b.nx[e], b.ny[e], b.nz[e]};
    const Vec3 ci = wallContactArm(ri, overlap, n);
    const Vec3 vrel = p.v[i] + cross(p.omega[i], ci) - Vec3{b.wx[e], b.wy[e], b.wz[e]};
    Vec3 shear{b.sx[e], b.sy[e], b.sz[e]};
    double lost = 0.0;
    Vec3 f = composedForce(normalLaw, tangentialLaw, n, overlap, vrel, ri, p.mass[i], pairs[b.material[e]], dt, shear,
                           lost);
    f *= p.weight[i];  // Cheng 2022 Eq. 26: contact forces scaled by w
    const Vec3 t = cross(ci, f);
    b.fx[e] = f.x, b.fy[e] = f.y, b.fz[e] = f.z;
    b.tx[e] = t.x, b.ty[e] = t.y, b.tz[e] = t.z;
    b.sx[e] = shear.x, b.sy[e] = shear.y, b.sz[e] = shear.z;
    b.lost[e] = lost;
  }
}

// A plane contact of the chunk, for the gather to add to its particle.
struct PlaneHit {
  std::uint32_t particle;
  Vec3 force, torque;
  double lost, work;  // w x energy lost, work of the moving wall over the step
};

// What the plane pass reads and writes. The wall sums are the chunk's own.
struct PlanePass {
  const Particles* p;
  const std::vector<PlaneWall>* walls;
  const PairMaterial* pairs;
  std::size_t materialCount;
  std::vector<Vec3>* shear;             // [wall][particle]
  std::vector<std::uint8_t>* touch;     // [wall][particle]
  std::vector<Vec3>* contactForce;      // [wall][particle]
  Vec3 *wallForce, *wallTorque;         // [wall]
  double* wallStiffness;                // [wall]
};

// The contacts of one chunk's plane candidates, in candidate order: their
// histories and forces stored, the walls' reactions summed, and each contact
// listed in `hits` for the gather.
template <class Normal, class Tangential>
void planeContactsOfChunk(const PlanePass& a, const PlaneCandidate* cand, std::uint32_t begin,
                          std::uint32_t end, const Normal& normalLaw, const Tangential& tangentialLaw, double dt,
                          PlaneBatch& batch, std::vector<PlaneHit>& hits) {
  const Particles& p = *a.p;
  const std::vector<PlaneWall>& walls = *a.walls;
  hits.clear();
  const auto flush = [&] {
    evaluatePlaneContacts(batch, p, cand, a.pairs, normalLaw, tangentialLaw, dt);
    for (std::size_t e = 0; e < batch.count; ++e) {
      const auto [i, wl] = cand[batch.candidate[e]];
      const PlaneWall& wall = walls[wl];
      const Vec3 fw{batch.fx[e], batch.fy[e], batch.fz[e]};
      const double ri = p.radius[i], overlap = batch.overlap[e], w = p.weight[i];
      a.shear[wl][i] = {batch.sx[e], batch.sy[e], batch.sz[e]};
      a.touch[wl][i] = 1;
      a.contactForce[wl][i] = fw;
      // A servo's stability depends on how stiffly its contacts answer (PlaneWall::servoLoopGain).
      if (wall.mode == PlaneWall::Mode::servo)
        a.wallStiffness[wl] += w * normalLaw.evaluate(overlap, ri, a.pairs[batch.material[e]]).stiffness;
      const Vec3 ci = wallContactArm(ri, overlap, wall.normal);
      a.wallForce[wl] -= fw;
      a.wallTorque[wl] -= cross(p.x[i] + ci - wall.point, fw);
      hits.push_back({i, fw, {batch.tx[e], batch.ty[e], batch.tz[e]}, w * batch.lost[e], dot(fw, wall.velocity) * dt});
    }
    batch.count = 0;
  };
  for (std::uint32_t c = begin; c < end; ++c) {
    const auto [i, wl] = cand[c];
    const PlaneWall& wall = walls[wl];
    const double overlap = p.radius[i] - wall.distance(p.x[i]);
    std::uint8_t& touch = a.touch[wl][i];
    Vec3& shear = a.shear[wl][i];
    if (overlap <= 0.0) {
      if (touch) {  // contact lost: its history ends
        touch = 0;
        shear = {};
      }
      continue;
    }
    const std::size_t e = batch.count++;
    batch.candidate[e] = c;
    batch.material[e] = static_cast<std::uint32_t>(p.material[i] * a.materialCount + wall.material);
    batch.overlap[e] = overlap;
    batch.nx[e] = wall.normal.x, batch.ny[e] = wall.normal.y, batch.nz[e] = wall.normal.z;
    batch.wx[e] = wall.velocity.x, batch.wy[e] = wall.velocity.y, batch.wz[e] = wall.velocity.z;
    batch.sx[e] = shear.x, batch.sy[e] = shear.y, batch.sz[e] = shear.z;
    if (batch.full()) flush();
  }
  flush();
}

// One naive particle-triangle contact before Modifications 1 and 2.
}  // namespace

DemSystem::DemSystem() {
  setContactLaw("hertz", "mindlin", "restitution");
  setIntegrator("velocity-verlet");
}

void DemSystem::setContactLaw(const std::string& normal, const std::string& tangential, const std::string& damping) {
  law_ = std::make_unique<ContactLaw>(normal, tangential, damping);
  lawNames_ = {normal, tangential, damping};
}

void DemSystem::setIntegrator(const std::string& name) {
  integrator_ = IntegratorRegistry::create(name, "integrator");
  integratorName_ = name;
}

void DemSystem::initialize() {
  if (materials.size() == 0) materials.add(Material{});
  law_->prepare(materials);
  const std::size_t n = particles.size();
  planeShear.resize(planes.size());
  for (auto& s : planeShear) s.resize(n);
  planeTouch.resize(planes.size());
  planeContactForce.resize(planes.size());
  for (std::size_t w = 0; w < planes.size(); ++w) {
    planeTouch[w].resize(n);
    planeContactForce[w].resize(n);
    for (std::size_t i = 0; i < n; ++i) planeTouch[w][i] = norm2(planeShear[w][i]) > 0.0;
  }
  for (auto& m : meshes) {
    m.validate();
    m.history.resize(n);
  }
  if (bonds.size() > 0 || !excludedPairs.empty()) {
    if (bonds.size() > 0) bonds.index(n);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs(excludedPairs);
    for (std::size_t b = 0; b < bonds.size(); ++b) pairs.emplace_back(bonds.first[b], bonds.second[b]);
    neighbors.setExclusions(n, pairs);
  }
  neighbors.rowStart.clear();  // force a fresh build
  computeForces(0.0);
  markDrivenEvaluated();
}

namespace {
double steadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

void DemSystem::lap(double PhaseTimes::*phase) {
  if (!timedStep_) return;
  const double now = steadySeconds();
  phaseTimes.*phase += now - lapStart_;
  lapStart_ = now;
}

void DemSystem::advance(double dt) {
  timedStep_ = timing;
  if (timing) lapStart_ = steadySeconds();
  // Most scenes drive no particle: one scan of the flags decides whether to sum their power.
  const bool driven =
      !particles.driven.empty() && std::memchr(particles.driven.data(), 1, particles.driven.size()) != nullptr;
  if (driven && drivenEvalX_.size() != particles.size()) markDrivenEvaluated();
  if (cell.enabled) {
    // The cell and the particles move with the affine field: H <- H + dt L H, x <- x + dt L x.
    const Mat3& L = cell.velocityGradient;
    Mat3 dh = mul(L, cell.h);
    for (std::size_t k = 0; k < 9; ++k) cell.h[k] += dt * dh[k];
    for (Vec3& x : particles.x) x += dt * mul(L, x);
  }
  // The rebuild test in the opening pass, where the neighbour list's
  // criterion is the displacement alone (in a periodic cell it is not).
  const std::size_t n = particles.size();
  DriftWatch watch{neighbors.xRef.data(), neighbors.driftLimit2()};
  const bool watching = !cell.enabled && neighbors.builtFor(n);
  integrator_->beforeForces(particles, dt, watching ? &watch : nullptr);
  // Driven particles (coupled hybrid PD particles, scene-driven spheres) are
  // not integrated; between the states sent from outside they move with their
  // velocity. Flag 2 parks one where it is (hybrid_watch.hpp). Their
  // displacement is the watch's too: the opening pass skips them.
  if (driven) {
    bool beyond = false;
#pragma omp parallel for schedule(static) if (n > kParallelMin) reduction(|| : beyond)
    for (std::size_t i = 0; i < n; ++i) {
      if (particles.driven[i] == 0) continue;
      if (particles.driven[i] == 1) particles.x[i] += dt * particles.v[i];
      if (watching) beyond |= watch.exceededBy(i, particles.x[i]);
    }
    watch.beyond = watch.beyond || beyond;
  }
  for (auto& w : planes) w.move(dt);
  for (auto& m : meshes)
    for (std::size_t v = 0; v < m.vertices.size(); ++v) m.vertices[v] += dt * m.velocities[v];
  lap(&PhaseTimes::open);
  // The closing kick inside the force loop, unless bonds add forces after it.
  const double fused = bonds.size() == 0 ? integrator_->fusedKick() : 0.0;
  forces(dt, fused * dt, watch.checked ? &watch.beyond : nullptr);
  if (fused == 0.0) integrator_->afterForces(particles, dt);
  // Driven particles moved (set from outside, then with v over the step)
  // while the system pushed on them with f: the prescribed motion did work.
  if (driven) addDriveWork(drivenWorkSinceEvaluation());
  time += dt;
  ++step;
  lap(&PhaseTimes::close);
  if (timedStep_) phaseTimes.particleSteps += n;
  timedStep_ = false;
}

double DemSystem::drivenWorkSinceEvaluation() {
  // One trapezoid from the last evaluation point to this one, not one per
  // segment: a state set from outside jumps before any force is evaluated
  // there, and charging that jump the force before it alone missed k dx^2 / 2
  // per contact every exchange (the energy balance of H5's hybrids drifted by it).
  const Particles& p = particles;
  double work = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.driven[i]) {
      const Vec3 dx = p.x[i] - drivenEvalX_[i];
      work -= dot(0.5 * (drivenEvalF_[i] + p.f[i]) + (p.weight[i] * p.mass[i]) * gravity, dx);
      drivenEvalX_[i] = p.x[i];
      drivenEvalF_[i] = p.f[i];
    }
  return work;
}

void DemSystem::markDrivenEvaluated() {
  drivenEvalX_ = particles.x;
  drivenEvalF_ = particles.f;
}

void DemSystem::addDriveWork(double work) {
  driveWork += work;
  externalWork += work;
}

void DemSystem::setDrivenVelocity(std::size_t i, const Vec3& v) {
  Particles& p = particles;
  addDriveWork(0.5 * p.weight[i] * p.mass[i] * (norm2(v) - norm2(p.v[i])));
  p.v[i] = v;
}

void DemSystem::setDrivenState(std::size_t i, const Vec3& x, const Vec3& v) {
  Particles& p = particles;
  carryJumpIntoHistory(i, x - p.x[i]);
  p.x[i] = x;
  setDrivenVelocity(i, v);
}

// A state set from outside lands where the particle's own solver put it, not
// where DEM moved it with its velocity (PD's Verlet: dt^2 a / 2 away per
// step). The normal springs see that jump through the overlap; the
// tangential ones integrate v_t dt (Hartmann 2022 Eq. 34) and would miss it,
// while the drive work (drivenWorkSinceEvaluation) charges the friction force
// along it. So the jump's tangential part goes into the history of every
// contact the particle is in, and the next evaluation limits it to the
// Coulomb cone as any other increment. Without it the friction force did work
// along the hybrids' jumps that no spring stored: about |f_t|^2 dt^2 / (2 m)
// per contact and step, all of one sign, 9e4 J in H5 by t = 2.57 s.
// Triangle-mesh contacts keep their history per triangle and are not carried.
void DemSystem::carryJumpIntoHistory(std::size_t i, const Vec3& jump) {
  if (!(norm2(jump) > 0.0)) return;
  auto tangential = [&](const Vec3& d) {
    const double len2 = norm2(d);
    return len2 > 0.0 ? jump - (dot(jump, d) / len2) * d : jump;
  };
  NeighborList& nl = neighbors;
  if (nl.rowStart.size() == particles.size() + 1 && nl.touching.size() == nl.partner.size()) {
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k)
      if (nl.touching[k]) nl.shear[k] += tangential(pairVector(i, k));  // i moved relative to its partner
    for (std::uint32_t r = nl.revStart[i]; r < nl.revStart[i + 1]; ++r) {
      const std::uint32_t k = nl.revPair[r];
      if (!nl.touching[k]) continue;
      // The row that owns pair k: its partner moved by the jump.
      const auto row = static_cast<std::size_t>(std::upper_bound(nl.rowStart.begin(), nl.rowStart.end(), k) -
                                                nl.rowStart.begin() - 1);
      nl.shear[k] -= tangential(pairVector(row, k));
    }
  }
  for (std::size_t w = 0; w < planes.size() && w < planeTouch.size(); ++w)
    if (i < planeTouch[w].size() && planeTouch[w][i]) planeShear[w][i] += tangential(planes[w].normal);
}

void DemSystem::computeForces(double dt, double closingKick) { forces(dt, closingKick, nullptr); }

void DemSystem::forces(double dt, double closingKick, const bool* movedBeyondSkin) {
  bool rebuild = movedBeyondSkin ? *movedBeyondSkin : neighbors.needsRebuild(particles, &cell);
  for (const auto& m : meshes) rebuild = rebuild || m.movedBeyond(0.5 * neighbors.skin);
  rebuild = rebuild || planeNear.size() != particles.size() || planesMovedBeyond(0.5 * neighbors.skin);
  if (rebuild) {
    if (cell.enabled) wrapIntoCell();
    neighbors.build(particles, &cell);
    pairForce.assign(neighbors.pairs(), {});
    markPlaneCandidates();
    // Cheng 2022 Alg. 2: each triangle's bounding box, grown by the largest
    // radius and the skin (of each size class's grid), picks its candidate particles.
    const std::size_t n = particles.size();
    std::vector<std::uint32_t> found;
    for (auto& m : meshes) {
      std::vector<std::vector<std::uint32_t>> perParticle(n);
      for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        Vec3 lo, hi;
        m.boundingBox(t, lo, hi);
        neighbors.particlesNearBox(lo, hi, found);
        const auto& tri = m.triangles[t];
        for (std::uint32_t i : found) {
          const ClosestPoint cp = closestPointOnTriangle(particles.x[i], m.vertices[tri[0]], m.vertices[tri[1]],
                                                         m.vertices[tri[2]]);
          const double cut = particles.radius[i] + neighbors.skin;
          if (norm2(particles.x[i] - cp.point) < cut * cut) perParticle[i].push_back(static_cast<std::uint32_t>(t));
        }
      }
      m.candStart.assign(n + 1, 0);
      m.candTri.clear();
      for (std::size_t i = 0; i < n; ++i) {
        m.candTri.insert(m.candTri.end(), perParticle[i].begin(), perParticle[i].end());
        m.candStart[i + 1] = static_cast<std::uint32_t>(m.candTri.size());
      }
      m.markBuilt();
    }
  }
  lap(&PhaseTimes::neighbors);
  pairForces(dt);
  lap(&PhaseTimes::pairs);
  gatherForces(dt, closingKick);
  lap(&PhaseTimes::gather);
  if (bonds.size() > 0) bonds.addForces(particles, cell, particles.f);
}

void DemSystem::markPlaneCandidates() {
  const std::size_t n = particles.size();
  planesAtMark.clear();
  for (const PlaneWall& w : planes) planesAtMark.push_back({w.point, w.normal});
  // In a periodic cell the affine motion is not in the rebuild criterion: no pruning.
  if (cell.enabled || planes.size() > 64) {
    planeNear.assign(n, ~std::uint64_t{0});
  } else {
    planeNear.assign(n, 0);
#pragma omp parallel for schedule(static) if (n > kParallelMin)
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t w = 0; w < planes.size(); ++w)
        if (planes[w].distance(particles.x[i]) < particles.radius[i] + neighbors.skin)
          planeNear[i] |= std::uint64_t{1} << w;
  }
  indexPlaneCandidates();
}

void DemSystem::indexPlaneCandidates() {
  const std::size_t n = particles.size(), nw = planes.size(), chunks = chunkCount();
  if (planeNear.size() != n) throw std::logic_error("DemSystem: plane candidates do not match the particles");
  planeCand_.clear();
  chunkPlaneCand_.assign(chunks + 1, 0);
  for (std::size_t c = 0; c < chunks; ++c) {
    for (std::size_t i = c * kRowsPerChunk; i < chunkEnd(c); ++i)
      for (std::uint64_t near = planeNear[i]; near != 0; near &= near - 1) {
        const auto wl = static_cast<std::uint32_t>(std::countr_zero(near));
        if (wl >= nw) break;
        planeCand_.push_back({static_cast<std::uint32_t>(i), wl});
      }
    chunkPlaneCand_[c + 1] = static_cast<std::uint32_t>(planeCand_.size());
  }
  planeCandParticles_ = n;
  planeCandPlanes_ = nw;
}

bool DemSystem::planesMovedBeyond(double limit) const {
  if (planesAtMark.size() != planes.size()) return true;
  for (std::size_t w = 0; w < planes.size(); ++w) {
    const auto& [point, normal] = planesAtMark[w];
    if (planes[w].normal.x != normal.x || planes[w].normal.y != normal.y || planes[w].normal.z != normal.z) return true;
    if (std::fabs(dot(planes[w].point - point, normal)) > limit) return true;
  }
  return false;
}

template <class Visit>
void DemSystem::visitLaw(Visit&& visit) const {
  // Built-in law combinations get loops with the law calls inlined; any
  // other (plug-in) combination runs the same loops through the interfaces.
  const NormalLaw& nl = law_->normal();
  const TangentialLaw& tl = law_->tangential();
  if (const auto* hertz = dynamic_cast<const HertzNormal*>(&nl)) {
    if (const auto* mindlin = dynamic_cast<const MindlinTangential*>(&tl)) return visit(*hertz, *mindlin);
    if (const auto* none = dynamic_cast<const Frictionless*>(&tl)) return visit(*hertz, *none);
  }
  if (const auto* linear = dynamic_cast<const LinearSpring*>(&nl)) {
    if (const auto* lt = dynamic_cast<const LinearTangential*>(&tl)) return visit(*linear, *lt);
    if (const auto* none = dynamic_cast<const Frictionless*>(&tl)) return visit(*linear, *none);
  }
  visit(nl, tl);
}

void DemSystem::pairForces(double dt) {
  visitLaw([&](const auto& normal, const auto& tangential) { pairLoopFor(normal, tangential, dt); });
}

template <class Normal, class Tangential>
void DemSystem::pairLoopFor(const Normal& normal, const Tangential& tangential, double dt) {
  if (cell.enabled) pairLoop<true>(normal, tangential, dt);
  else pairLoop<false>(normal, tangential, dt);
}

void DemSystem::wrapIntoCell() {
  const Mat3 hInv = inverse(cell.h);
  for (Vec3& x : particles.x) {
    Vec3 s = mul(hInv, x);
    for (int d = 0; d < 3; ++d) s[d] -= std::floor(s[d]);
    x = mul(cell.h, s);
  }
}

void DemSystem::weighChunks() {
  const std::size_t chunks = chunkCount(), n = particles.size();
  if (chunkContacts_.size() != chunks) chunkContacts_.assign(chunks, 0);
  chunkWork_.resize(chunks + 1);
  chunkWork_[0] = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::uint32_t pairs = neighbors.rowStart[chunkEnd(c)] - neighbors.rowStart[std::min(n, c * kRowsPerChunk)];
    chunkWork_[c + 1] = chunkWork_[c] + pairs + std::uint64_t{kContactWeight} * chunkContacts_[c];
  }
}

std::size_t DemSystem::chunkOfPairShare(std::size_t t, std::size_t nt) const {
  const std::size_t chunks = chunkCount();
  if (t >= nt) return chunks;
  // The first chunk that starts at or after t/nt of the weighed work. A
  // contact costs several times a listed pair out of contact (its force,
  // then its hand-back), and contacts crowd where the particles have settled:
  // equal shares of pairs left one thread 58 % of the contacts in the dense
  // settling run.
  const std::uint64_t target = chunkWork_[chunks] * t / nt;
  return static_cast<std::size_t>(std::lower_bound(chunkWork_.begin(), chunkWork_.end() - 1, target) -
                                  chunkWork_.begin());
}

namespace {

// What the pair loop reads and writes, as plain pointers taken once: `touching`
// is a byte array, and a store through it may alias anything as far as the
// compiler knows, so it would reload every vector's data pointer after each one.
struct PairLoopArrays {
  const Particles* p;
  const Vec3* x;
  const double* radius;
  const std::uint16_t* material;
  std::size_t materialCount;
  const PairMaterial* pairs;
  const std::uint32_t *rowStart, *partner, *pairRow;
  const std::array<std::int8_t, 3>* image;
  std::uint8_t* touching;
  Vec3* shear;
  PairForce* pf;
  Vec3 *sumF, *sumT;
  double* chunkLost;
  std::uint32_t* chunkContacts;
  const PeriodicCell* box;
  std::size_t n, rowsPerChunk;
};

// One thread's run of chunks [cBegin, cEnd) of the pair loop. A function of
// its own so that it is compiled for the widest registers the CPU has too
// (COSIM_DEM_SIMD_CLONES; the outlined OpenMP body would not inherit it): the
// loop keeps a dozen pointers and the batch's fill live, and the baseline's
// 16 registers spilled them.
template <bool Periodic, class Normal, class Tangential>
COSIM_DEM_SIMD_CLONES void pairChunks(const PairLoopArrays& a, std::size_t cBegin, std::size_t cEnd,
                                      const Normal& normalLaw, const Tangential& tangentialLaw, double dt) {
  const Vec3* x = a.x;
  const double* radius = a.radius;
  const std::uint16_t* material = a.material;
  const std::size_t materialCount = a.materialCount;
  const std::uint32_t *rowStart = a.rowStart, *partner = a.partner, *pairRow = a.pairRow;
  std::uint8_t* touching = a.touching;
  Vec3* shear = a.shear;
  PairForce* pf = a.pf;
  Vec3 *sumF = a.sumF, *sumT = a.sumT;
  const PeriodicCell& box = *a.box;
  double local = 0.0;
  std::uint32_t found = 0;
  ContactBatch batch;
  // Evaluates the batch's contacts and hands each result to its pair and row.
  const auto flush = [&] {
    evaluateContacts<Periodic>(batch, *a.p, shear, a.pairs, normalLaw, tangentialLaw, box.velocityGradient, dt);
    for (std::size_t e = 0; e < batch.count; ++e) {
      const std::uint32_t k = batch.pair[e], i = batch.row[e];
      const Vec3 f{batch.fx[e], batch.fy[e], batch.fz[e]};
      shear[k] = {batch.sx[e], batch.sy[e], batch.sz[e]};
      touching[k] = 1;
      pf[k] = {f, {batch.tjx[e], batch.tjy[e], batch.tjz[e]}};
      sumF[i] += f;
      sumT[i] -= Vec3{batch.tix[e], batch.tiy[e], batch.tiz[e]};
      local += batch.lost[e];
    }
    found += static_cast<std::uint32_t>(batch.count);
    batch.count = 0;
  };
  for (std::size_t c = cBegin; c < cEnd; ++c) {
    local = 0.0;
    found = 0;
    // Row sums start at zero; rows without pairs (most in a dilute flow) are
    // neither written here nor read by the gather.
    const std::size_t rowBegin = c * a.rowsPerChunk, rowEnd = std::min(a.n, (c + 1) * a.rowsPerChunk);
    for (std::size_t i = rowBegin; i < rowEnd; ++i)
      if (rowStart[i] != rowStart[i + 1]) sumF[i] = sumT[i] = {};
    // One loop over the chunk's pairs, not a loop over each row's: the exit
    // of a row's short loop (3-4 pairs in a dense packing, a varying count)
    // mispredicted once per row.
    for (std::uint32_t k = rowStart[rowBegin]; k < rowStart[rowEnd]; ++k) {
      const std::uint32_t i = pairRow[k], j = partner[k];
      Vec3 d = x[i] - x[j];
      if constexpr (Periodic) d -= box.shift(a.image[k]);
      const double rsum = radius[i] + radius[j];
      const bool contact = norm2(d) < rsum * rsum;
      batch.offer(contact, i, j, k, static_cast<std::uint32_t>(material[i] * materialCount + material[j]), d);
      // A contact lost ends its history. One comparison of the two flags
      // (touching 1, contact 0), not a branch on either: about half the
      // listed pairs touch, so a branch on one of them mispredicts, while
      // losing a contact is rare. (`touching[k] != 0 & !contact` let GCC
      // branch on touching[k] first.)
      if (touching[k] > static_cast<std::uint8_t>(contact)) [[unlikely]] {
        touching[k] = 0;
        shear[k] = {};
        pf[k] = {};
      }
      if (batch.full()) flush();
    }
    flush();
    a.chunkLost[c] = local;
    a.chunkContacts[c] = found;
  }
}

}  // namespace

template <bool Periodic, class Normal, class Tangential>
void DemSystem::pairLoop(const Normal& normalLaw, const Tangential& tangentialLaw, double dt) {
  const Particles& p = particles;
  const std::size_t n = p.size();
  pairSumF_.resize(n);
  pairSumT_.resize(n);
  // Rows in chunks; each thread takes a contiguous run of chunks holding an
  // equal share of the weighed work (contacts crowd where the particles have
  // settled, so equal shares of rows are far from equal work, while a
  // contiguous run keeps each thread's rows in its own cache). The energy lost
  // is summed per chunk and the chunks in order: it does not depend on the
  // thread count.
  chunkLost_.assign(chunkCount(), 0.0);
  weighChunks();
  if (neighbors.pairRow.size() != neighbors.pairs())
    throw std::logic_error("DemSystem: neighbour list without its pair rows (NeighborList::indexPairs not called)");
  const PairLoopArrays arrays{&p,
                              p.x.data(),
                              p.radius.data(),
                              p.material.data(),
                              materials.size(),
                              materials.pairs().data(),
                              neighbors.rowStart.data(),
                              neighbors.partner.data(),
                              neighbors.pairRow.data(),
                              neighbors.image.data(),
                              neighbors.touching.data(),
                              neighbors.shear.data(),
                              pairForce.data(),
                              pairSumF_.data(),
                              pairSumT_.data(),
                              chunkLost_.data(),
                              chunkContacts_.data(),
                              &cell,
                              n,
                              kRowsPerChunk};
#pragma omp parallel if (n > kParallelMin)
  {
    const std::size_t t = static_cast<std::size_t>(threadIndex()), nt = static_cast<std::size_t>(teamSize());
    pairChunks<Periodic>(arrays, chunkOfPairShare(t, nt), chunkOfPairShare(t + 1, nt), normalLaw, tangentialLaw, dt);
  }
  for (double v : chunkLost_) dissipated += v;
}

void DemSystem::gatherForces(double dt, double closingKick) {
  visitLaw([&](const auto& normal, const auto& tangential) { gatherLoop(normal, tangential, dt, closingKick); });
}

template <class Normal, class Tangential>
void DemSystem::gatherLoop(const Normal& normalLaw, const Tangential& tangentialLaw, double dt, double closingKick) {
  Particles& p = particles;
  const std::size_t n = p.size();
  const std::size_t nw = planes.size(), nm = meshes.size();
  // Sums per chunk of particles, added in chunk order: wall forces (which
  // drive servo walls), energy lost and work do not depend on the thread count.
  const std::size_t chunks = chunkCount();
  gatherPartials_.resize(chunks);
  for (auto& m : meshes) {
    externalWork += m.workBeforeEvaluation();
    m.contacts.clear();
  }
  // Mesh contacts of each particle, compacted into the groups' lists afterwards.
  MeshGather meshOut;
  if (nm > 0) {
    meshOut.contacts.resize(nm);
    for (auto& out : meshOut.contacts) out.resize(n * TriangleWallGroup::kSlots);
    meshOut.count.assign(n * nm, 0);
  }
  if (planeCandParticles_ != n || planeCandPlanes_ != nw)
    throw std::logic_error("DemSystem: plane candidates not indexed (DemSystem::indexPlaneCandidates not called)");
#pragma omp parallel if (n > kParallelMin)
  {
    std::vector<MeshCandidate> cand, kept;
    PlaneBatch planeBatch;
    std::vector<PlaneHit> hits;
#pragma omp for schedule(static)
    for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
      GatherPartial& local = gatherPartials_[chunk];
      // In registers, not through `local`: most particles touch nothing, and
      // the loop below should cost them a few loads and stores. Walls and
      // meshes are handled out of line for the few particles near them.
      ChunkSums sums;
      // The arrays as plain pointers: the stores below could alias the vectors'
      // own members as far as the compiler knows, and it would reload them.
      const double *weight = p.weight.data(), *mass = p.mass.data(), *invMass = p.invMass.data(),
                   *invInertia = p.invInertia.data();
      const std::uint8_t* driven = p.driven.data();
      const Vec3 *fExt = p.fExt.data(), *sumF = pairSumF_.data(), *sumT = pairSumT_.data();
      const bool external = p.fExt.any();  // else all zero: not read
      Vec3 *v = p.v.data(), *omega = p.omega.data(), *force = p.f.data(), *torque = p.torque.data();
      const std::uint32_t *rowStart = neighbors.rowStart.data(), *revStart = neighbors.revStart.data(),
                          *rev = neighbors.revPair.data();
      const PairForce* pf = pairForce.data();
      const Vec3 g = gravity;
      const double damping = massDamping;
      const bool kicks = closingKick > 0.0;
      const std::size_t end = chunkEnd(chunk);
      local.planeForce.assign(nw, {});
      local.planeTorque.assign(nw, {});
      local.planeStiffness.assign(nw, 0.0);
      local.meshForce.assign(nm, {});
      local.meshTorque.assign(nm, {});
      // The chunk's plane contacts first, in a pass of their own: only the
      // few particles near a plane have any, and batched their law is vectorised.
      const PlanePass planePass{&p, &planes, materials.pairs().data(), materials.size(), planeShear.data(),
                                planeTouch.data(), planeContactForce.data(), local.planeForce.data(),
                                local.planeTorque.data(), local.planeStiffness.data()};
      planeContactsOfChunk(planePass, planeCand_.data(), chunkPlaneCand_[chunk], chunkPlaneCand_[chunk + 1], normalLaw,
                           tangentialLaw, dt, planeBatch, hits);
      const PlaneHit* hit = hits.data();
      const PlaneHit* const hitsEnd = hit + hits.size();
      for (std::size_t i = chunk * kRowsPerChunk; i < end; ++i) {
        const double w = weight[i];
        const bool free = driven[i] == 0;
        // Cheng 2022 Eq. 26: w scales body force. A driven particle's force is its
        // contact reaction only: a hybrid PD particle gets gravity from PD (Hartmann Sec. 3.2).
        const Vec3 fe = external ? fExt[i] : Vec3{};
        Vec3 f = free ? (w * mass[i]) * g + fe : fe;
        Vec3 t{};
        {
          // The row side was summed in the pair loop, for rows with pairs only
          // (a dilute step is bound by memory traffic). Pairs out of contact
          // hold zeros: summing them is cheaper than a branch.
          const bool hasRow = rowStart[i] != rowStart[i + 1];
          const Vec3 rowF = hasRow ? sumF[i] : Vec3{}, rowT = hasRow ? sumT[i] : Vec3{};
          double fx = rowF.x, fy = rowF.y, fz = rowF.z;
          double tx = rowT.x, ty = rowT.y, tz = rowT.z;
          for (std::uint32_t r = revStart[i]; r < revStart[i + 1]; ++r) {
            const PairForce& q = pf[rev[r]];
            fx -= q.force.x; fy -= q.force.y; fz -= q.force.z;
            tx += q.torqueJ.x; ty += q.torqueJ.y; tz += q.torqueJ.z;
          }
          f += Vec3{fx, fy, fz};
          t = {tx, ty, tz};
        }
        // Work of the external force (zero for most particles: adding it is cheaper than a test).
        if (external) sums.work += dot(fe, v[i]) * dt;
        for (; hit != hitsEnd && hit->particle == i; ++hit) {
          f += hit->force;
          t += hit->torque;
          sums.dissipated += hit->lost;
          sums.work += hit->work;
        }
        if (nm > 0) [[unlikely]] {
          // Through copies: were f, t and sums passed out of line themselves,
          // they would live in memory for every particle of the loop.
          Vec3 fm = f, tm = t;
          ChunkSums sm = sums;
          for (std::size_t gm = 0; gm < nm; ++gm) addMeshContacts(i, gm, w, dt, local, sm, meshOut, cand, kept, fm, tm);
          f = fm, t = tm, sums = sm;
        }
        if (damping > 0.0 && free) {
          // Mass damping for dynamic relaxation (Liu 2016 Sec. 2.3.2: c_I); its work is dissipated.
          const Vec3 fd = (-damping * w * mass[i]) * v[i];
          const Vec3 td = (-damping * w * p.inertia[i]) * omega[i];
          sums.dissipated -= (dot(fd, v[i]) + dot(td, omega[i])) * dt;
          f += fd;
          t += td;
        }
        force[i] = f;
        torque[i] = t;
        if (kicks && free) kick(w, invMass[i], invInertia[i], f, t, closingKick, v[i], omega[i]);  // Integrator::fusedKick
      }
      local.dissipated = sums.dissipated;
      local.work = sums.work;
    }
  }
  for (auto& w : planes) {
    w.force = w.torque = {};
    w.stiffness = 0.0;
  }
  for (auto& m : meshes) m.force = m.torque = {};
  for (const GatherPartial& part : gatherPartials_) {
    dissipated += part.dissipated;
    externalWork += part.work;
    for (std::size_t wl = 0; wl < nw && wl < part.planeForce.size(); ++wl) {
      planes[wl].force += part.planeForce[wl];
      planes[wl].torque += part.planeTorque[wl];
      planes[wl].stiffness += part.planeStiffness[wl];
    }
    for (std::size_t g = 0; g < nm && g < part.meshForce.size(); ++g) {
      meshes[g].force += part.meshForce[g];
      meshes[g].torque += part.meshTorque[g];
    }
  }
  for (std::size_t g = 0; g < nm; ++g)
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t c = 0; c < meshOut.count[i * nm + g]; ++c)
        meshes[g].contacts.push_back(meshOut.contacts[g][i * TriangleWallGroup::kSlots + c]);
  for (auto& m : meshes) externalWork += m.workAfterEvaluation();
}

void DemSystem::addMeshContacts(std::size_t i, std::size_t g, double w, double dt, GatherPartial& local,
                                ChunkSums& sums, MeshGather& out, std::vector<MeshCandidate>& cand,
                                std::vector<MeshCandidate>& kept, Vec3& f, Vec3& t) {
  Particles& p = particles;
  TriangleWallGroup& m = meshes[g];
  const double ri = p.radius[i];
  auto& slots = m.history[i];
  cand.clear();
  for (std::uint32_t c = m.candStart[i]; c < m.candStart[i + 1]; ++c) {
    const auto& tri = m.triangles[m.candTri[c]];
    const ClosestPoint cp = closestPointOnTriangle(p.x[i], m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]]);
    const Vec3 d = p.x[i] - cp.point;
    const double dist2 = norm2(d);
    if (dist2 >= ri * ri || dist2 <= 0.0) continue;
    const double dist = std::sqrt(dist2);
    cand.push_back({m.candTri[c], ri - dist, cp.point, (1.0 / dist) * d, cp.bary});
  }
  if (cand.empty()) {
    for (auto& s : slots) s = {};
    return;
  }
  // Cheng 2022 Alg. 1, Modification 1: largest overlap first; a contact with
  // a triangle that meets a kept one at a flat or convex angle as seen from
  // the particle (no vertex of it in front of the kept triangle's plane)
  // is the same contact seen twice and is dropped. Concave pairs stay.
  std::sort(cand.begin(), cand.end(), [](const MeshCandidate& a, const MeshCandidate& b) {
    return a.overlap != b.overlap ? a.overlap > b.overlap : a.triangle < b.triangle;
  });
  kept.clear();
  for (const MeshCandidate& c : cand) {
    bool same = false;
    for (const MeshCandidate& k : kept) {
      const auto& tk = m.triangles[k.triangle];
      const Vec3& a = m.vertices[tk[0]];
      Vec3 nk = cross(m.vertices[tk[1]] - a, m.vertices[tk[2]] - a);
      nk *= (dot(nk, p.x[i] - a) >= 0.0 ? 1.0 : -1.0) / norm(nk);  // towards the particle
      double front = -1.0;
      for (std::uint32_t v : m.triangles[c.triangle]) front = std::max(front, dot(m.vertices[v] - a, nk));
      if (front <= 1e-9 * ri) same = true;
    }
    if (!same && kept.size() < static_cast<std::size_t>(TriangleWallGroup::kSlots)) kept.push_back(c);
  }
  // Contact history: the main contact carries slot 0 from triangle to
  // triangle; further (concave) contacts keep theirs by triangle id.
  std::array<TriangleWallGroup::Slot, TriangleWallGroup::kSlots> next{};
  for (std::size_t c = 0; c < kept.size(); ++c) {
    next[c].triangle = kept[c].triangle;
    if (c == 0) {
      next[0].shear = slots[0].shear;
    } else {
      for (std::size_t s = 1; s < slots.size(); ++s)
        if (slots[s].triangle == kept[c].triangle) next[c].shear = slots[s].shear;
    }
  }
  std::array<Vec3, TriangleWallGroup::kSlots> fc{};
  std::array<double, TriangleWallGroup::kSlots> lostc{};
  double sumF = 0.0;
  const PairMaterial& pm = materials.pair(p.material[i], m.material);
  for (std::size_t c = 0; c < kept.size(); ++c) {
    const auto& tri = m.triangles[kept[c].triangle];
    const Vec3 vw = kept[c].bary[0] * m.velocities[tri[0]] + kept[c].bary[1] * m.velocities[tri[1]] +
                    kept[c].bary[2] * m.velocities[tri[2]];
    const Vec3 ci = wallContactArm(ri, kept[c].overlap, kept[c].normal);
    const Vec3 vrel = p.v[i] + cross(p.omega[i], ci) - vw;
    fc[c] = law_->force(kept[c].normal, kept[c].overlap, vrel, ri, p.mass[i], pm, dt, next[c].shear, lostc[c]);
    sumF += norm(fc[c]);
  }
  slots = next;
  for (std::size_t c = 0; c < kept.size(); ++c) {
    // Modification 2: weight w = |f| / sum |f| (a single contact keeps weight 1).
    const double wgt = kept.size() == 1 ? 1.0 : (sumF > 0.0 ? norm(fc[c]) / sumF : 0.0);
    const Vec3 fw = (w * wgt) * fc[c];
    const Vec3 ci = wallContactArm(ri, kept[c].overlap, kept[c].normal);
    // The wall's work on the particle: TriangleWallGroup::workAfterEvaluation.
    sums.dissipated += w * wgt * lostc[c];
    f += fw;
    t += cross(ci, fw);
    local.meshForce[g] -= fw;
    local.meshTorque[g] -= cross(kept[c].point, fw);
    const double elastic = w * wgt * law_->energy(kept[c].overlap, ri, pm, slots[c].shear);
    out.contacts[g][i * TriangleWallGroup::kSlots + c] = {static_cast<std::uint32_t>(i), kept[c].triangle,
                                                     kept[c].bary, -fw, elastic};
  }
  out.count[i * meshes.size() + g] = static_cast<std::uint8_t>(kept.size());
}

}  // namespace cosim::dem
