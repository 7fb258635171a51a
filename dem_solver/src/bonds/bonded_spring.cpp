#include "cosim/dem/bonds/bonded_spring.hpp"

#include <cmath>

#include "cosim/dem/neighbor/neighbor_list.hpp"
#include "cosim/dem/parallel.hpp"

namespace cosim::dem {

Vec3 BondedSprings::bondVector(const Particles& p, const PeriodicCell& cell, std::size_t b) const {
  Vec3 d = p.x[first[b]] - p.x[second[b]];
  if (cell.enabled) {  // nearest image
    Vec3 s = mul(inverse(cell.h), d);
    for (int k = 0; k < 3; ++k) s[k] -= std::round(s[k]);
    d = mul(cell.h, s);
  }
  return d;
}

std::size_t BondedSprings::bondNeighbours(const Particles& p, const PeriodicCell& cell, double factor) {
  NeighborList search;
  double rmax = 0.0;
  for (double r : p.radius) rmax = std::max(rmax, r);
  search.skin = (factor - 1.0) * 2.0 * rmax;
  search.build(p, &cell);
  std::size_t made = 0;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = search.rowStart[i]; k < search.rowStart[i + 1]; ++k) {
      const std::uint32_t j = search.partner[k];
      Vec3 d = p.x[i] - p.x[j];
      if (cell.enabled) d -= cell.shift(search.image[k]);
      const double len = norm(d);
      if (len < factor * (p.radius[i] + p.radius[j])) {
        first.push_back(static_cast<std::uint32_t>(i));
        second.push_back(j);
        rest.push_back(len);
        ++made;
      }
    }
  index(p.size());
  return made;
}

void BondedSprings::index(std::size_t n) {
  byParticleStart.assign(n + 1, 0);
  for (std::size_t b = 0; b < size(); ++b) {
    ++byParticleStart[first[b] + 1];
    ++byParticleStart[second[b] + 1];
  }
  for (std::size_t i = 0; i < n; ++i) byParticleStart[i + 1] += byParticleStart[i];
  byParticle.resize(2 * size());
  std::vector<std::uint32_t> fill(byParticleStart.begin(), byParticleStart.end() - 1);
  for (std::size_t b = 0; b < size(); ++b) {
    byParticle[fill[first[b]]++] = static_cast<std::uint32_t>(b);
    byParticle[fill[second[b]]++] = static_cast<std::uint32_t>(b);
  }
}

void BondedSprings::addForces(const Particles& p, const PeriodicCell& cell, std::vector<Vec3>& f) {
  const std::size_t nb = size(), n = p.size();
  force_.resize(nb);
#pragma omp parallel for schedule(static) if (nb > kParallelMin)
  for (std::size_t b = 0; b < nb; ++b) {
    const Vec3 d = bondVector(p, cell, b);
    const double len = norm(d);
    // Tension and compression alike, scaled by the Arlequin weight at the
    // bond (Cheng 2022 Eq. 26: w_ab f_ab), taken as the mean of the two
    // particles' weights as for contacts.
    const double wb = 0.5 * (p.weight[first[b]] + p.weight[second[b]]);
    force_[b] = (-wb * stiffness * (len - rest[b]) / len) * d;
  }
#pragma omp parallel for schedule(static) if (n > kParallelMin)
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t k = byParticleStart[i]; k < byParticleStart[i + 1]; ++k) {
      const std::uint32_t b = byParticle[k];
      f[i] += first[b] == i ? force_[b] : -force_[b];
    }
}

double BondedSprings::energy(const Particles& p, const PeriodicCell& cell) const {
  double e = 0.0;
  for (std::size_t b = 0; b < size(); ++b) {
    const double stretch = norm(bondVector(p, cell, b)) - rest[b];
    e += 0.5 * (0.5 * (p.weight[first[b]] + p.weight[second[b]])) * stiffness * stretch * stretch;
  }
  return e;
}

}  // namespace cosim::dem
