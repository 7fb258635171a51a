// Bond-based micro-elastic (prototype microelastic brittle) model,
// Hartmann 2022 Eqs. 8-12: t = phi c s along the deformed bond, with
// c = 18 K / (pi delta^4) and optional critical-stretch bond breakage.
#include <cmath>
#include <numbers>

#include "cosim/pd/model.hpp"
#include "surface_factors.hpp"

namespace cosim::pd {
namespace {

class Pmb final : public PdModel {
 public:
  std::string name() const override { return "pmb"; }

  void initialise(const BodyContext& body) override {
    // Hartmann 2022 Eq. 10: spring constant from the bulk modulus.
    c_ = 18.0 * body.material.bulkModulus() / (std::numbers::pi * std::pow(body.horizon, 4));
    const auto full = detail::fullLatticeFamily(body.spacing, body.horizon, body.options.partialVolume);
    if (body.options.micromodulus == "discrete") {
      // The continuum integral of |xi| over the horizon (pi delta^4) replaced
      // by the one-point quadrature the forces use, so an interior particle
      // of the lattice has exactly the bulk modulus K under dilatation.
      double sum = 0.0;
      for (std::size_t q = 0; q < full.length.size(); ++q) sum += full.length[q] * full.volume[q];
      c_ *= std::numbers::pi * std::pow(body.horizon, 4) / sum;
    }
    const auto& b = body.bonds;
    const auto& p = body.particles;
    factor_.assign(b.count(), 1.0);
    coef_.clear();
    for (std::size_t k = 0; k < b.count(); ++k) factor_[k] = b.volumeFraction[k];
    if (!body.options.surfaceCorrection) return;
    // Strain energy density of particle i under uniaxial strain eps along
    // axis a is (c eps^2 / 4) sum beta V_j xi_a^4 / |xi|^3; its ratio to the
    // same sum over a complete family is the correction (1 in the interior).
    double bulk[3] = {0, 0, 0};
    for (std::size_t q = 0; q < full.length.size(); ++q)
      for (int a = 0; a < 3; ++a) bulk[a] += full.volume[q] * std::pow(full.xi[3 * q + a], 4) / std::pow(full.length[q], 3);
    const std::size_t n = body.end - body.begin;
    std::vector<double> g(3 * n, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
      double sum[3] = {0, 0, 0};
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        const std::size_t j = b.neighbor[k];
        const double r = b.length[k];
        for (int a = 0; a < 3; ++a) {
          const double xa = p.reference[3 * j + a] - p.reference[3 * (body.begin + i) + a];
          sum[a] += b.volumeFraction[k] * p.volume[j] * xa * xa * xa * xa / (r * r * r);
        }
      }
      for (int a = 0; a < 3; ++a) g[3 * i + a] = sum[a] > 0.0 ? bulk[a] / sum[a] : 1.0;
    }
    // Pair potential: the bond factor must be symmetric, so both ends' factors are averaged.
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        const std::size_t jl = b.neighbor[k] - body.begin;
        double nrm[3], gm[3];
        for (int a = 0; a < 3; ++a) {
          nrm[a] = (p.reference[3 * b.neighbor[k] + a] - p.reference[3 * (body.begin + i) + a]) /
                   b.length[k];
          gm[a] = 0.5 * (g[3 * i + a] + g[3 * jl + a]);
        }
        factor_[k] *= detail::ellipsoidFactor(nrm, gm);
      }
  }

  void computeForces(const BodyContext& body, std::vector<double>& force) override {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    if (coef_.size() != b.count()) {
      coef_.resize(b.count());
      for (std::size_t k = 0; k < b.count(); ++k)
        coef_[k] = c_ * factor_[k] * p.volume[b.neighbor[k]] / b.length[k];
    }
    currentPositions(body, x_);
    const double* x = x_.data();
    const std::uint32_t* nb = b.neighbor.data();
    const double* len = b.length.data();
    const double* coef = coef_.data();
    const std::size_t first = body.begin;
    const long n = static_cast<long>(body.end - body.begin);
#pragma omp parallel for schedule(dynamic, 256) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) {
      const double xi0 = x[3 * il], xi1 = x[3 * il + 1], xi2 = x[3 * il + 2];
      double f0 = 0.0, f1 = 0.0, f2 = 0.0;
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;  // a broken bond carries no force (phi = 0)
        const double* xj = x + 3 * (nb[k] - first);
        const double y0 = xj[0] - xi0, y1 = xj[1] - xi1, y2 = xj[2] - xi2;
        const double ylen = std::sqrt(y0 * y0 + y1 * y1 + y2 * y2);
        // Eq. 12: t_IJ V_J along the deformed bond direction (Eq. 9), with the
        // stretch s = (|Y| - |xi|) / |xi| (Eq. 10) folded into the bond
        // coefficient c beta g V_J / |xi|: t / |Y| = coef (|Y| - |xi|) / |Y|.
        const double t = coef[k] * (ylen - len[k]) / ylen;
        f0 += t * y0;
        f1 += t * y1;
        f2 += t * y2;
      }
      const double f[3] = {f0, f1, f2};
      storeBondSum(force, p, first + static_cast<std::size_t>(il), f);
    }
  }

  std::vector<double> energyDensity(const BodyContext& body) const override {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    std::vector<double> w(body.end - body.begin, 0.0);
    for (std::size_t il = 0; il < w.size(); ++il) {
      const std::size_t i = body.begin + il;
      double sum = 0.0;
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;
        const double s = stretch(p, i, b.neighbor[k], b.length[k]);
        // Micro-potential c s^2 |xi| / 2, half of it attributed to each end.
        sum += 0.25 * c_ * s * s * b.length[k] * factor_[k] * p.volume[b.neighbor[k]];
      }
      w[il] = sum;
    }
    return w;
  }

  double strainEnergy(const BodyContext& body) const override {
    const auto w = energyDensity(body);
    double e = 0.0;
    for (std::size_t il = 0; il < w.size(); ++il) e += w[il] * body.particles.volume[body.begin + il];
    return e;
  }

  bool mayBreakBonds(const BodyContext& body) const override { return body.options.criticalStretch > 0.0; }

  std::size_t breakBonds(const BodyContext& body, Bonds& b) override {
    const double s0 = body.options.criticalStretch;
    if (!(s0 > 0.0)) return 0;
    const auto& p = body.particles;
    std::size_t broken = 0;
    const long n = static_cast<long>(body.end - body.begin);
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : broken) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) {
      const std::size_t i = body.begin + static_cast<std::size_t>(il);
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;
        // Stretch is symmetric in i and j, so both directions break together.
        if (stretch(p, i, b.neighbor[k], b.length[k]) > s0) {
          b.broken[k] = 1;
          ++broken;
        }
      }
    }
    return broken;
  }

  double stiffnessBound(const BodyContext& body, std::size_t il) const override {
    const auto& b = body.bonds;
    double k = 0.0;
    for (std::size_t q = b.offset[il]; q < b.offset[il + 1]; ++q)
      k += c_ * factor_[q] * body.particles.volume[b.neighbor[q]] / b.length[q];
    return k;
  }

 private:
  static double stretch(const Particles& p, std::size_t i, std::size_t j, double len) {
    double y2 = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double y = p.current(j, a) - p.current(i, a);
      y2 += y * y;
    }
    return (std::sqrt(y2) - len) / len;
  }

  double c_ = 0.0;
  std::vector<double> factor_;  // beta * surface-correction factor per bond
  std::vector<double> coef_;    // c beta g V_J / |xi| per bond (built on first use)
  std::vector<double> x_;       // current positions of the body (scratch)
};

}  // namespace

PD_REGISTER_MODEL("pmb", Pmb);

}  // namespace cosim::pd
