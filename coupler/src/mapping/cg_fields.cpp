// Coarse-grained fields on a regular grid (see cg_fields.hpp for the formulas).
// Every field is a sum over point sources y_s carrying a payload p_s:
//   F(x) = sum_s p_s W(|x - y_s|) n_s,
// with n_s = 1 (analytic) or the inverse grid sum of the source's kernel (grid
// normalisation). Particles carry (m, m v, m v v); wall contact points carry
// the wall force; the contact stress's line integrals become sources at the
// Gauss points of each branch vector, carrying w_q f (x) l.
#include "cosim/coupler/mapping/cg_fields.hpp"
#include "cosim/coupler/mapping/gauss_legendre.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

// OpenMP where the build links it (tools/CMakeLists.txt adds it to cosim_coupler).
#ifdef _OPENMP
#define COSIM_CG_OMP(directive) _Pragma(#directive)
#else
#define COSIM_CG_OMP(directive)
#endif

namespace cosim::coupler {
namespace {

using Vec = std::array<double, 3>;

Vec at(std::span<const double> flat, std::size_t i) { return {flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]}; }

double distance(const Vec& a, const Vec& b) {
  const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Point sources with `width` payload values each.
struct Sources {
  explicit Sources(std::size_t w) : width(w) {}
  std::size_t width;
  std::vector<double> positions, payload, factor;
  std::size_t size() const { return factor.size(); }
  void add(const Vec& y, std::span<const double> values) {
    positions.insert(positions.end(), y.begin(), y.end());
    payload.insert(payload.end(), values.begin(), values.end());
    factor.push_back(1.0);
  }
};

// Gauss-Legendre rule mapped to [0, 1] (the branch parameter).
void gaussLegendre01(int n, std::vector<double>& nodes, std::vector<double>& weights) {
  gaussLegendre(n, nodes, weights);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    nodes[i] = 0.5 * (1.0 - nodes[i]);
    weights[i] *= 0.5;
  }
}

// Counting-sort bins of the sources, cells no smaller than c: a source within
// c of a point lies in the point's cell or one of its 26 neighbours.
class SourceBins {
 public:
  SourceBins(const Sources& s, double c) {
    if (s.size() == 0) return;
    lo_ = hi_ = at(s.positions, 0);
    for (std::size_t i = 1; i < s.size(); ++i) {
      const Vec y = at(s.positions, i);
      for (int d = 0; d < 3; ++d) lo_[d] = std::min(lo_[d], y[d]), hi_[d] = std::max(hi_[d], y[d]);
    }
    // Cap the cell count near the source count so that a small c over a wide
    // snapshot does not allocate a huge empty table.
    const double maxCells = 8.0 * static_cast<double>(s.size()) + 64.0;
    double volume = 1.0;
    for (int d = 0; d < 3; ++d) volume *= std::max(hi_[d] - lo_[d], c);
    cell_ = std::max(c, std::cbrt(volume / maxCells));
    for (int d = 0; d < 3; ++d) dims_[d] = static_cast<long>((hi_[d] - lo_[d]) / cell_) + 1;
    start_.assign(static_cast<std::size_t>(dims_[0] * dims_[1] * dims_[2]) + 1, 0);
    std::vector<std::size_t> cellOf(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
      cellOf[i] = flatCell(coord(at(s.positions, i)));
      ++start_[cellOf[i] + 1];
    }
    for (std::size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
    items_.resize(s.size());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < s.size(); ++i) items_[fill[cellOf[i]]++] = static_cast<std::uint32_t>(i);
  }

  /// Calls visit(source) for every source in the cells around x.
  template <class Visit>
  void around(const Vec& x, Visit&& visit) const {
    if (items_.empty()) return;
    std::array<long, 3> c{};
    for (int d = 0; d < 3; ++d) c[d] = static_cast<long>(std::floor((x[d] - lo_[d]) / cell_));
    for (long k = std::max(c[2] - 1, 0L); k <= std::min(c[2] + 1, dims_[2] - 1); ++k)
      for (long j = std::max(c[1] - 1, 0L); j <= std::min(c[1] + 1, dims_[1] - 1); ++j)
        for (long i = std::max(c[0] - 1, 0L); i <= std::min(c[0] + 1, dims_[0] - 1); ++i) {
          const std::size_t cell = static_cast<std::size_t>(i + dims_[0] * (j + dims_[1] * k));
          for (std::size_t n = start_[cell]; n < start_[cell + 1]; ++n) visit(items_[n]);
        }
  }

 private:
  std::array<long, 3> coord(const Vec& y) const {
    std::array<long, 3> c{};
    for (int d = 0; d < 3; ++d) c[d] = std::clamp(static_cast<long>((y[d] - lo_[d]) / cell_), 0L, dims_[d] - 1);
    return c;
  }
  std::size_t flatCell(const std::array<long, 3>& c) const {
    return static_cast<std::size_t>(c[0] + dims_[0] * (c[1] + dims_[1] * c[2]));
  }
  Vec lo_{}, hi_{};
  double cell_ = 1.0;
  std::array<long, 3> dims_{1, 1, 1};
  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> items_;
};

// F(x_g) for every grid point g: width values per point.
std::vector<double> smear(const Sources& s, const CgKernel& kernel, double c, const CgGrid& grid) {
  const std::size_t w = s.width, n = grid.size();
  std::vector<double> out(w * n, 0.0);
  const SourceBins bins(s, c);
COSIM_CG_OMP(omp parallel for schedule(dynamic, 256))
  for (std::size_t g = 0; g < n; ++g) {
    const Vec x = grid.point(g);
    double* f = out.data() + w * g;
    bins.around(x, [&](std::uint32_t src) {
      const double r = distance(x, at(s.positions, src));
      if (r >= c) return;
      const double weight = kernel.value(r, c) * s.factor[src];
      const double* p = s.payload.data() + w * src;
      for (std::size_t k = 0; k < w; ++k) f[k] += weight * p[k];
    });
  }
  return out;
}

// Grid normalisation: n_s = 1 / (h^3 sum_g W(|x_g - y_s|)) over the grid
// points within c of the source. Returns how many sources saw no grid point.
std::size_t normaliseOnGrid(Sources& s, const CgKernel& kernel, double c, const CgGrid& grid) {
  std::size_t dropped = 0;
  const long count = static_cast<long>(s.size());
COSIM_CG_OMP(omp parallel for schedule(dynamic, 64) reduction(+ : dropped))
  for (long src = 0; src < count; ++src) {
    const Vec y = at(s.positions, static_cast<std::size_t>(src));
    std::array<long, 3> first{}, last{};
    for (int d = 0; d < 3; ++d) {
      const long top = static_cast<long>(grid.counts[d]) - 1;
      first[d] = std::max(0L, static_cast<long>(std::ceil((y[d] - c - grid.origin[d]) / grid.spacing[d])));
      last[d] = std::min(top, static_cast<long>(std::floor((y[d] + c - grid.origin[d]) / grid.spacing[d])));
    }
    double sum = 0.0;
    for (long k = first[2]; k <= last[2]; ++k)
      for (long j = first[1]; j <= last[1]; ++j)
        for (long i = first[0]; i <= last[0]; ++i) {
          const Vec x{grid.origin[0] + static_cast<double>(i) * grid.spacing[0],
                      grid.origin[1] + static_cast<double>(j) * grid.spacing[1],
                      grid.origin[2] + static_cast<double>(k) * grid.spacing[2]};
          const double r = distance(x, y);
          if (r < c) sum += kernel.value(r, c);
        }
    sum *= grid.cellVolume();
    s.factor[static_cast<std::size_t>(src)] = sum > 0.0 ? 1.0 / sum : 0.0;
    if (sum <= 0.0) ++dropped;
  }
  return dropped;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("coarse-graining: " + what);
}

bool finite(std::span<const double> v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

void validate(const CgKernel& kernel, const CgOptions& o, const CgGrid& grid, const CgParticles& p,
              const CgPairContacts& pc, const CgWallContacts& wc) {
  require(!kernel.isDirac(), "the " + kernel.name() + " kernel has no width; fields need a kernel with c > 0");
  require(std::isfinite(o.width) && o.width > 0.0, "width c must be a positive number, got " + std::to_string(o.width));
  require(o.branchPoints >= 1 && o.branchPoints <= 16, "branchPoints must be in 1..16");
  for (int d = 0; d < 3; ++d) {
    require(std::isfinite(grid.spacing[d]) && grid.spacing[d] > 0.0, "grid spacing must be positive");
    require(std::isfinite(grid.origin[d]), "grid origin must be finite");
    require(grid.counts[d] >= 1, "grid counts must be >= 1");
  }
  const std::size_t n = p.masses.size();
  require(p.positions.size() == 3 * n && p.velocities.size() == 3 * n && p.radii.size() == n,
          "particle arrays disagree: " + std::to_string(p.positions.size()) + " position values, " +
              std::to_string(p.velocities.size()) + " velocity values, " + std::to_string(n) + " masses, " +
              std::to_string(p.radii.size()) + " radii");
  require(finite(p.positions) && finite(p.velocities), "particle positions and velocities must be finite");
  for (std::size_t i = 0; i < n; ++i)
    require(std::isfinite(p.masses[i]) && p.masses[i] > 0.0 && std::isfinite(p.radii[i]) && p.radii[i] > 0.0,
            "particle " + std::to_string(i) + " needs a positive mass and radius");
  const std::size_t m = pc.first.size();
  require(pc.second.size() == m && pc.points.size() == 3 * m && pc.forces.size() == 3 * m,
          "pair contact arrays disagree in length");
  require(finite(pc.points) && finite(pc.forces), "pair contact points and forces must be finite");
  const std::size_t mw = wc.particle.size();
  require(wc.points.size() == 3 * mw && wc.forces.size() == 3 * mw, "wall contact arrays disagree in length");
  require(finite(wc.points) && finite(wc.forces), "wall contact points and forces must be finite");
}

// The branch vector of particle a at contact point xc must stay inside the
// particle: a longer one is a periodic image or a corrupt index.
Vec branch(const CgParticles& p, std::uint32_t a, const Vec& xc, const std::string& contact) {
  require(a < p.masses.size(), contact + " names particle " + std::to_string(a) + " of " +
                                   std::to_string(p.masses.size()));
  const Vec x = at(p.positions, a);
  const Vec l{xc[0] - x[0], xc[1] - x[1], xc[2] - x[2]};
  const double len = distance(xc, x);
  require(len <= p.radii[a] * (1.0 + 1e-9), contact + ": contact point is " + std::to_string(len) +
                                                " m from particle " + std::to_string(a) + "'s centre, beyond its radius " +
                                                std::to_string(p.radii[a]) + " m (a periodic image?)");
  return l;
}

// Gauss points along x_a + s l, s in [0, 1], carrying w_q f (x) l: the
// contact stress's line integral int_0^1 W(x - x_a - s l) ds (Weinhart 2012 Eq. 17).
void addBranch(Sources& out, const Vec& xa, const Vec& l, const Vec& f, const std::vector<double>& nodes,
               const std::vector<double>& weights) {
  std::array<double, 9> fl{};
  for (std::size_t q = 0; q < nodes.size(); ++q) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) fl[3 * i + j] = weights[q] * f[i] * l[j];
    const double s = nodes[q];
    out.add({xa[0] + s * l[0], xa[1] + s * l[1], xa[2] + s * l[2]}, fl);
  }
}

Sources branchSources(const CgParticles& p, const CgPairContacts& pc, const CgWallContacts& wc, int points) {
  std::vector<double> nodes, weights;
  gaussLegendre01(points, nodes, weights);
  Sources out(9);
  for (std::size_t k = 0; k < pc.first.size(); ++k) {
    const std::string name = "pair contact " + std::to_string(k);
    require(pc.first[k] != pc.second[k], name + " joins particle " + std::to_string(pc.first[k]) + " to itself");
    const Vec xc = at(pc.points, k), f = at(pc.forces, k);
    const Vec lA = branch(p, pc.first[k], xc, name), lB = branch(p, pc.second[k], xc, name);
    addBranch(out, at(p.positions, pc.first[k]), lA, f, nodes, weights);
    addBranch(out, at(p.positions, pc.second[k]), lB, {-f[0], -f[1], -f[2]}, nodes, weights);
  }
  for (std::size_t k = 0; k < wc.particle.size(); ++k) {
    const Vec xc = at(wc.points, k);
    const Vec l = branch(p, wc.particle[k], xc, "wall contact " + std::to_string(k));
    addBranch(out, at(p.positions, wc.particle[k]), l, at(wc.forces, k), nodes, weights);
  }
  return out;
}

// Per particle: m, m v (3), m v (x) v (9).
Sources massSources(const CgParticles& p) {
  Sources out(13);
  std::array<double, 13> q{};
  for (std::size_t a = 0; a < p.masses.size(); ++a) {
    const double m = p.masses[a];
    const Vec v = at(p.velocities, a);
    q[0] = m;
    for (int i = 0; i < 3; ++i) {
      q[1 + i] = m * v[i];
      for (int j = 0; j < 3; ++j) q[4 + 3 * i + j] = m * v[i] * v[j];
    }
    out.add(at(p.positions, a), q);
  }
  return out;
}

Sources wallSources(const CgWallContacts& wc) {
  Sources out(3);
  for (std::size_t k = 0; k < wc.particle.size(); ++k) {
    const Vec f = at(wc.forces, k);
    out.add(at(wc.points, k), f);
  }
  return out;
}

// rho, j, V and the kinetic stress -(sum m v v W - j j / rho) from the mass sources' sums.
void massFields(const std::vector<double>& sums, CgFields& f) {
  const std::size_t n = sums.size() / 13;
  f.density.assign(n, 0.0);
  f.momentum.assign(3 * n, 0.0);
  f.velocity.assign(3 * n, 0.0);
  f.kineticStress.assign(9 * n, 0.0);
  for (std::size_t g = 0; g < n; ++g) {
    const double* s = sums.data() + 13 * g;
    const double rho = s[0];
    f.density[g] = rho;
    for (int i = 0; i < 3; ++i) {
      f.momentum[3 * g + i] = s[1 + i];
      if (rho > 0.0) f.velocity[3 * g + i] = s[1 + i] / rho;
    }
    if (rho <= 0.0) continue;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f.kineticStress[9 * g + 3 * i + j] = -(s[4 + 3 * i + j] - s[1 + i] * s[1 + j] / rho);
  }
}

}  // namespace

std::array<double, 3> CgGrid::point(std::size_t index) const {
  const std::size_t i = index % counts[0], j = (index / counts[0]) % counts[1], k = index / (counts[0] * counts[1]);
  return {origin[0] + static_cast<double>(i) * spacing[0], origin[1] + static_cast<double>(j) * spacing[1],
          origin[2] + static_cast<double>(k) * spacing[2]};
}

CgFields coarseGrain(const CgKernel& kernel, const CgOptions& options, const CgGrid& grid,
                     const CgParticles& particles, const CgPairContacts& pairs, const CgWallContacts& walls) {
  validate(kernel, options, grid, particles, pairs, walls);
  const double c = options.width;
  Sources mass = massSources(particles);
  Sources wall = wallSources(walls);
  Sources branches = branchSources(particles, pairs, walls, options.branchPoints);
  CgFields f;
  if (options.normalisation == CgNormalisation::grid)
    for (Sources* s : {&mass, &wall, &branches}) f.droppedSources += normaliseOnGrid(*s, kernel, c, grid);
  massFields(smear(mass, kernel, c, grid), f);
  f.boundaryForce = smear(wall, kernel, c, grid);
  f.contactStress = smear(branches, kernel, c, grid);
  f.stress.resize(f.contactStress.size());
  for (std::size_t k = 0; k < f.stress.size(); ++k) f.stress[k] = f.contactStress[k] + f.kineticStress[k];
  return f;
}

}  // namespace cosim::coupler
