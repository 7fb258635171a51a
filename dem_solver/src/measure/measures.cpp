#include "cosim/dem/measure/measures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace cosim::dem {

Energies energies(const DemSystem& s) {
  const Particles& p = s.particles;
  const ContactLaw& law = s.contactLaw();
  Energies e;
  for (std::size_t i = 0; i < p.size(); ++i) {
    e.translational += 0.5 * p.weight[i] * p.mass[i] * norm2(p.v[i]);
    e.rotational += 0.5 * p.weight[i] * p.inertia[i] * norm2(p.omega[i]);
    e.potential -= p.weight[i] * p.mass[i] * dot(s.gravity, p.x[i]);
  }
  forEachOverlap(s, [&](const PairOverlap& c) {
    const double wc = 0.5 * (p.weight[c.i] + p.weight[c.j]);
    e.elastic += wc * law.energy(c.overlap, c.rEff, s.materials.pair(p.material[c.i], p.material[c.j]),
                                 s.neighbors.shear[c.k]);
  });
  for (std::size_t w = 0; w < s.planes.size(); ++w)
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double overlap = p.radius[i] - s.planes[w].distance(p.x[i]);
      if (overlap > 0.0)
        e.elastic += p.weight[i] * law.energy(overlap, p.radius[i], s.materials.pair(p.material[i], s.planes[w].material),
                                              s.planeShear[w][i]);
    }
  // Triangle-mesh contacts of the last evaluation (a coupled FE surface).
  for (const TriangleWallGroup& m : s.meshes)
    for (const TriangleContact& c : m.contacts) e.elastic += c.elastic;
  e.elastic += s.bonds.energy(p, s.cell);
  e.dissipated = s.dissipated;
  e.externalWork = s.externalWork;
  return e;
}

double coordinationNumber(const DemSystem& s) {
  if (s.particles.size() == 0) return 0.0;
  std::size_t c = 0;
  for (std::uint8_t t : s.neighbors.touching) c += t;
  return 2.0 * static_cast<double>(c) / static_cast<double>(s.particles.size());
}

std::array<double, 9> loveWeberStress(const DemSystem& s, double volume) {
  const Particles& p = s.particles;
  std::array<double, 9> sig{};
  auto add = [&sig](const Vec3& a, const Vec3& b, double scale) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) sig[static_cast<std::size_t>(3 * r + c)] += scale * a[r] * b[c];
  };
  const auto& nl = s.neighbors;
  for (std::size_t i = 0; i < p.size(); ++i) {
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k)
      if (nl.touching[k]) add(s.pairForce[k].force, s.pairVector(i, k), -1.0);
    add(p.v[i], p.v[i], -p.weight[i] * p.mass[i]);  // kinetic (Reynolds) part
  }
  // Wall contacts: the wall is the boundary of V, so the branch runs from the
  // particle centre to the contact point on the wall surface (Liu 2016 Eq. 54
  // with the wall as the partner: sum_c f_c (x) (x_c - x_p)). Pair terms do not
  // depend on where x_c lies; these do, and only the surface point makes
  // sigma V = sum_walls f (x) x_c exact for a packing in equilibrium.
  for (std::size_t w = 0; w < s.planes.size(); ++w)
    for (std::size_t i = 0; i < p.size(); ++i)
      if (s.planeTouch[w][i])
        add(s.planeContactForce[w][i], -s.planes[w].distance(p.x[i]) * s.planes[w].normal, 1.0);
  for (const TriangleWallGroup& m : s.meshes)
    for (const TriangleContact& c : m.contacts) {
      const auto& tri = m.triangles[c.triangle];
      const Vec3 point = c.bary[0] * m.vertices[tri[0]] + c.bary[1] * m.vertices[tri[1]] + c.bary[2] * m.vertices[tri[2]];
      add(c.force, point - p.x[c.particle], -1.0);  // c.force acts on the wall
    }
  for (double& v : sig) v /= volume;
  return sig;
}

double solidVolume(const DemSystem& s) {
  double v = 0.0;
  for (double r : s.particles.radius) v += 4.0 / 3.0 * std::numbers::pi * r * r * r;
  return v;
}

namespace {

double fastestSpeed(const DemSystem& s) {
  double vmax = 0.0;
  for (const Vec3& v : s.particles.v) vmax = std::max(vmax, norm(v));
  for (const auto& w : s.planes) vmax = std::max(vmax, norm(w.velocity));
  return vmax;
}

/// The step that particle i's contacts allow when it is integrated under them.
/// withRayleigh: also the Rayleigh wave step of the sphere's own material, which
/// a PD particle standing in for a sphere does not have.
double particleCriticalStep(const DemSystem& s, std::size_t i, double vmax, bool withRayleigh) {
  const Particles& p = s.particles;
  const NormalLaw& normal = s.contactLaw().normal();
  const std::uint16_t a = p.material[i];
  // Lightest pairing: this particle against an equal one (m* = m/2).
  const double mEff = 0.5 * p.mass[i] * p.weight[i];
  double dt = std::numeric_limits<double>::max();
  for (std::size_t b = 0; b < s.materials.size(); ++b) {
    const PairMaterial& pm = s.materials.pair(a, static_cast<std::uint16_t>(b));
    if (normal.isHertz()) {
      // Rayleigh wave step (Li et al. 2005): pi R sqrt(rho/G) / (0.1631 nu + 0.8766).
      const Material& m = s.materials[a];
      const double rayleigh = std::numbers::pi * p.radius[i] * std::sqrt(m.density / m.shearModulus()) /
                              (0.1631 * m.poisson + 0.8766);
      if (withRayleigh) dt = std::min(dt, rayleigh);
      if (vmax > 0.0) dt = std::min(dt, normal.contactTime(mEff, 0.5 * p.radius[i], 2.0 * vmax, pm) / std::numbers::pi);
    } else if (pm.kn > 0.0) {
      dt = std::min(dt, std::sqrt(mEff / pm.kn));
    }
  }
  return dt;
}

double orZero(double dt) { return dt == std::numeric_limits<double>::max() ? 0.0 : dt; }

/// The smallest particleCriticalStep over `indices` (each a particle index).
/// A particle with the mass, weight, radius and material of the one before
/// has its step: the hybrid particles of a PD body all do, and a Hertz step
/// costs a power per material, which every tenth exchange of H5 paid for
/// 11584 of them.
template <class Indices>
double smallestCriticalStep(const DemSystem& s, const Indices& indices, double vmax, bool withRayleigh) {
  const Particles& p = s.particles;
  double dt = std::numeric_limits<double>::max();
  std::size_t last = p.size();
  double lastDt = 0.0;
  for (const std::size_t i : indices) {
    const bool same = last < p.size() && p.mass[i] == p.mass[last] && p.weight[i] == p.weight[last] &&
                      p.radius[i] == p.radius[last] && p.material[i] == p.material[last];
    if (!same) lastDt = particleCriticalStep(s, i, vmax, withRayleigh);
    last = i;
    dt = std::min(dt, lastDt);
  }
  return dt;
}

}  // namespace

double criticalTimeStep(const DemSystem& s) {
  const Particles& p = s.particles;
  // A driven particle (a hybrid PD particle, an indenter) is not integrated
  // here: its partners' own terms limit the step. All driven: no limit (0).
  std::vector<std::size_t> free;
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!p.driven[i]) free.push_back(i);
  const double dt = smallestCriticalStep(s, free, fastestSpeed(s), true);
  const double bonds = bondCriticalStep(s);
  return orZero(bonds > 0.0 ? std::min(dt, bonds) : dt);
}

// The Gershgorin bound on M^-1 K: particle i with bonds b (stiffness k,
// weighted by w_b as in the force) has omega^2 <= 2 k sum_b w_b / (w_i m_i);
// dt = 1 / omega, as sqrt(m*/k) for a linear contact (one bond between equal
// particles gives exactly that).
double bondCriticalStep(const DemSystem& s) {
  const BondedSprings& b = s.bonds;
  const Particles& p = s.particles;
  if (b.size() == 0 || !(b.stiffness > 0.0)) return 0.0;
  std::vector<double> load(p.size(), 0.0);
  for (std::size_t k = 0; k < b.size(); ++k) {
    const double wb = 0.5 * (p.weight[b.first[k]] + p.weight[b.second[k]]);
    load[b.first[k]] += wb;
    load[b.second[k]] += wb;
  }
  double dt = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (!p.driven[i] && load[i] > 0.0) dt = std::min(dt, std::sqrt(p.weight[i] * p.mass[i] / (2.0 * b.stiffness * load[i])));
  return orZero(dt);
}

double criticalTimeStep(const DemSystem& s, std::span<const std::uint32_t> integratedElsewhere) {
  return orZero(smallestCriticalStep(s, integratedElsewhere, fastestSpeed(s), false));
}

FineTimeStep fineTimeStep(const DemSystem& s) {
  const Particles& p = s.particles;
  const ContactLaw& law = s.contactLaw();
  std::vector<double> kn(p.size(), 0.0), kt(p.size(), 0.0);
  const auto add = [&](std::size_t i, double overlap, double rEff, const PairMaterial& pm) {
    kn[i] += law.normal().evaluate(overlap, rEff, pm).stiffness;
    kt[i] += law.tangential().stiffness(overlap, rEff, pm);
  };
  forEachOverlap(s, [&](const PairOverlap& c) {
    const PairMaterial& pm = s.materials.pair(p.material[c.i], p.material[c.j]);
    add(c.i, c.overlap, c.rEff, pm);
    add(c.j, c.overlap, c.rEff, pm);
  });
  for (const PlaneWall& w : s.planes)
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double overlap = p.radius[i] - w.distance(p.x[i]);
      if (overlap > 0.0) add(i, overlap, p.radius[i], s.materials.pair(p.material[i], w.material));
    }
  FineTimeStep f;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.driven[i]) continue;
    const double m = p.weight[i] * p.mass[i];
    f.omegaN = std::max(f.omegaN, std::sqrt(kn[i] / m));               // Liu Eq. 64
    f.omegaTheta = std::max(f.omegaTheta, std::sqrt(2.5 * kt[i] / m));  // k_theta / I = k_t R^2 / (2/5 m R^2)
  }
  f.omegaMax = std::max(f.omegaN, f.omegaTheta);
  if (f.omegaMax <= 0.0) return f;
  f.dampingFraction = s.massDamping / (2.0 * f.omegaMax);
  const double xi = f.dampingFraction;
  f.criticalDt = 2.0 / f.omegaMax * (std::sqrt(1.0 + xi * xi) - xi);  // Liu Eq. 63
  return f;
}

}  // namespace cosim::dem

namespace cosim::dem {

double unbalancedForceIndex(const DemSystem& s) {
  const Particles& p = s.particles;
  double num = 0.0, den = 0.0;
  std::size_t contacts = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p.driven[i]) continue;
    const Vec3 unbalanced = p.f[i] + (s.massDamping * p.weight[i] * p.mass[i]) * p.v[i];
    num += norm2(unbalanced);
  }
  for (std::size_t k = 0; k < s.neighbors.pairs(); ++k)
    if (s.neighbors.touching[k]) {
      den += norm2(s.pairForce[k].force);
      ++contacts;
    }
  if (contacts == 0 || den == 0.0) return 0.0;
  return std::sqrt(num / static_cast<double>(p.size())) / std::sqrt(den / static_cast<double>(contacts));
}

long relax(DemSystem& s, double dt, double tolerance, long maxSteps, long every) {
  long steps = 0;
  while (steps < maxSteps) {
    for (long k = 0; k < every; ++k) s.advance(dt);
    steps += every;
    const double index = unbalancedForceIndex(s);
    if (index > 0.0 && index < tolerance) break;
  }
  return steps;
}

}  // namespace cosim::dem
