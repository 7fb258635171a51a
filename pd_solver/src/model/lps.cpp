// Linear peridynamic solid (state-based), Hartmann 2022 Eqs. 13-25:
// weighted volume m (Eq. 19), dilatation theta (Eq. 20), deviatoric extension
// (Eq. 22), scalar force state t = 3 K theta w |xi| / m + alpha w e^d (Eq. 25)
// with alpha = 15 G / m, forces f_I = sum (t_IJ + t_JI) M_IJ V_I V_J (Eq. 14).
#include <algorithm>
#include <Eigen/Dense>
#include <cmath>
#include <cstring>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "cosim/pd/model.hpp"
#include "surface_factors.hpp"

namespace cosim::pd {
namespace {

class Lps final : public PdModel {
 public:
  std::string name() const override { return "lps"; }

  void initialise(const BodyContext& body) override {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    const auto w = influenceFunction(body.options.influence);
    const std::size_t n = body.end - body.begin;
    K_ = body.material.bulkModulus();
    G_ = body.material.shearModulus();
    weight_.resize(b.count());
    dilatationFactor_.assign(b.count(), 1.0);
    deviatoricFactor_.assign(b.count(), 1.0);
    m_.assign(n, 0.0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        // Partial volume folded into the weight: w beta.
        weight_[k] = w(b.length[k], body.horizon) * b.volumeFraction[k];
        m_[i] += weight_[k] * b.length[k] * b.length[k] * p.volume[b.neighbor[k]];  // Eq. 19
      }
    // alpha = 15 G / m (Eq. 25) per particle, fixed with m.
    alpha_.resize(n);
    for (std::size_t i = 0; i < n; ++i) alpha_[i] = m_[i] > 0.0 ? 15.0 * G_ / m_[i] : 0.0;
    buildReverse(body);
    buildPairs(body);
    if (body.options.surfaceCorrection) surfaceCorrection(body);
    // Per-bond constants of the two bond loops, so they gather no partner
    // volume and multiply no factors: Eq. 20's h w |xi| V_J and w beta V_J.
    thetaCoef_.resize(b.count());
    weightVolume_.resize(b.count());
    for (std::size_t k = 0; k < b.count(); ++k) {
      weightVolume_[k] = weight_[k] * p.volume[b.neighbor[k]];
      thetaCoef_[k] = dilatationFactor_[k] * weightVolume_[k] * b.length[k];
    }
    t_.assign(b.count(), 0.0);
    e_.assign(b.count(), 0.0);
    theta_.assign(n, 0.0);
  }

  void computeForces(const BodyContext& body, std::vector<double>& force) override {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    const long n = static_cast<long>(body.end - body.begin);
    if (!corrected_ && pairwise(body)) {
      pairForces(body, force);
      return;
    }
    updateExtensions(body);
    if (!corrected_) {
      uncorrectedForces(body, force);
      return;
    }
#pragma omp parallel for schedule(dynamic, 256) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) scalarForceState(body, static_cast<std::size_t>(il));
    const double* x = x_.data();
#pragma omp parallel for schedule(dynamic, 256) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) {
      const std::size_t i = body.begin + static_cast<std::size_t>(il);
      const double* xi = x + 3 * il;
      double f[3] = {0, 0, 0};
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;
        const std::size_t j = b.neighbor[k];
        const double* xj = x + 3 * (j - body.begin);
        double y[3];
        for (int a = 0; a < 3; ++a) y[a] = xj[a] - xi[a];
        // Eq. 14 with Eq. 23: (T_I<xi_IJ> - T_J<xi_JI>) = (t_IJ + t_JI) M_IJ;
        // |Y| = e + |xi| from the extension pass (no second square root).
        const double s = (t_[k] + t_[reverse_[k]]) * b.volumeFraction[k] * p.volume[j] / (e_[k] + b.length[k]);
        for (int a = 0; a < 3; ++a) f[a] += s * y[a];
      }
      storeBondSum(force, p, i, f);
    }
  }

  std::vector<double> energyDensity(const BodyContext& body) const override {
    // The energy is asked for after advances, usually at the state the last
    // force evaluation saw (Verlet ends with one): reuse its extensions, from
    // the row loops or the pair loops, whichever ran. Otherwise (the
    // staggered update moves after its force evaluation) recompute them with
    // the loops the forces would use: the pair loops take half the roots.
    // Without correction and broken bonds, that sweep also sums S = sum w V e^2,
    // which gives the densities without a second pass over the bonds
    // (squaredEnergyDensity).
    if (!extensionsAreCurrent(body)) {
      const bool squares = !corrected_ && intact(body);
      if (squares && onOneThread(body)) pairExtensions<true>(body);  // pairwise(), intact already known
      else if (squares) updateExtensions<true>(body);
      else updateExtensions<false>(body);
    }
    if (squaresAreCurrent_) return squaredEnergyDensity();
    return extensionsInPairs_ ? pairEnergyDensity(body) : rowEnergyDensity(body);
  }

  double strainEnergy(const BodyContext& body) const override {
    const auto w = energyDensity(body);
    double e = 0.0;
    for (std::size_t i = 0; i < w.size(); ++i) e += w[i] * body.particles.volume[body.begin + i];
    return e;
  }

  double stiffnessBound(const BodyContext& body, std::size_t il) const override {
    // Bond-spring equivalent of the P-wave modulus: 18 (K + 4G/3) / (pi delta^4).
    const double c = 18.0 * (K_ + 4.0 * G_ / 3.0) / (3.141592653589793 * std::pow(body.horizon, 4));
    const auto& b = body.bonds;
    double k = 0.0;
    for (std::size_t q = b.offset[il]; q < b.offset[il + 1]; ++q)
      k += c * b.volumeFraction[q] * body.particles.volume[b.neighbor[q]] / b.length[q];
    return 2.0 * k;
  }

 private:
  /// Energy density W = K theta^2 / 2 + alpha / 2 sum h w (e^d)^2 V_J (Eq. 24
  /// with Eq. 22) from the row loops' e_ and theta_.
  std::vector<double> rowEnergyDensity(const BodyContext& body) const {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    std::vector<double> out(body.end - body.begin, 0.0);
    for (std::size_t i = 0; i < out.size(); ++i) {
      double dev = 0.0;
      // theta / 3 once per particle: a division per bond cost as much as the rest of the loop.
      const double thirdTheta = theta_[i] / 3.0;
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        if (b.broken[k]) continue;
        const double ed = e_[k] - thirdTheta * b.length[k];  // Eq. 22
        dev += deviatoricFactor_[k] * weight_[k] * ed * ed * p.volume[b.neighbor[k]];
      }
      out[i] = particleEnergyDensity(i, dev);
    }
    return out;
  }

  /// Eq. 24 for one particle from its deviatoric sum sum h w (e^d)^2 V_J.
  double particleEnergyDensity(std::size_t il, double dev) const {
    if (!(m_[il] > 0.0)) return 0.0;
    return 0.5 * K_ * theta_[il] * theta_[il] + 0.5 * alpha_[il] * dev;
  }

  /// Eq. 24 from the sweep's S = sum w V e^2 (uncorrected, no broken bond).
  /// With Eq. 22, sum w V (e - theta |xi| / 3)^2 = S - (2 theta / 3) sum w V
  /// |xi| e + (theta^2 / 9) sum w V |xi|^2, and by Eqs. 20 and 19 the two
  /// sums are theta m / 3 and m: the deviatoric sum is S - m theta^2 / 9.
  /// Where the strain is nearly isotropic the two terms nearly cancel; the
  /// error is then round-off of S against the much larger K theta^2 / 2,
  /// and the sum of squares is kept from going below zero.
  std::vector<double> squaredEnergyDensity() const {
    std::vector<double> out(squares_.size());
    for (std::size_t il = 0; il < out.size(); ++il)
      out[il] = particleEnergyDensity(il, std::max(0.0, squares_[il] - m_[il] * theta_[il] * theta_[il] / 9.0));
    return out;
  }

  // Bond index of j -> i for every bond i -> j (rows are sorted by partner).
  void buildReverse(const BodyContext& body) {
    const auto& b = body.bonds;
    reverse_.assign(b.count(), 0);
    for (std::size_t i = 0; i < b.rows(); ++i)
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        const std::size_t jl = b.neighbor[k] - body.begin;
        const std::uint32_t gi = static_cast<std::uint32_t>(body.begin + i);
        std::size_t lo = b.offset[jl], hi = b.offset[jl + 1];
        while (lo < hi) {
          const std::size_t mid = (lo + hi) / 2;
          if (b.neighbor[mid] < gi) lo = mid + 1; else hi = mid;
        }
        reverse_[k] = lo;
      }
  }

  // Extension e (Eq. 18) per bond and dilatation theta (Eq. 20) per particle.
  // Deformed bonds are differences of current positions, x_j - x_i with
  // x = X + u rounded first, so Y_JI = -Y_IJ exactly and e_IJ = e_JI: forces
  // of a pair cancel to round-off and momentum is conserved. With Squares,
  // also S = sum w beta V_J e^2 per particle (squaredEnergyDensity).
  template <bool Squares = false>
  void updateExtensions(const BodyContext& body) const {
    const auto& b = body.bonds;
    currentPositions(body, x_);
    const double* x = x_.data();
    const std::uint32_t* nb = b.neighbor.data();
    const double* len = b.length.data();
    const double* coef = thetaCoef_.data();
    const double* wv = weightVolume_.data();
    double* e = e_.data();
    const std::size_t first = body.begin;
    const long n = static_cast<long>(body.end - body.begin);
    if constexpr (Squares) squares_.resize(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(dynamic, 256) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) {
      const double xi0 = x[3 * il], xi1 = x[3 * il + 1], xi2 = x[3 * il + 2];
      double th = 0.0, sq = 0.0;
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        const double* xj = x + 3 * (nb[k] - first);
        const double y0 = xj[0] - xi0, y1 = xj[1] - xi1, y2 = xj[2] - xi2;
        const double ek = std::sqrt(y0 * y0 + y1 * y1 + y2 * y2) - len[k];
        e[k] = ek;
        if (!b.broken[k]) th += coef[k] * ek;
        if constexpr (Squares) sq += wv[k] * ek * ek;  // only asked for without broken bonds
      }
      theta_[il] = m_[il] > 0.0 ? 3.0 * th / m_[il] : 0.0;
      if constexpr (Squares) squares_[static_cast<std::size_t>(il)] = sq;
    }
    rememberExtensions(body, false, Squares);
  }

  /// Records the displacements e and theta now belong to, whether e is per
  /// bond (e_, row loops) or per pair (pairExtension_, pair loops), and
  /// whether squares_ was summed with them.
  void rememberExtensions(const BodyContext& body, bool inPairs, bool squares) const {
    const auto firstU = body.particles.displacement.begin() + static_cast<long>(3 * body.begin);
    uOfExtensions_.assign(firstU, firstU + static_cast<long>(3 * (body.end - body.begin)));
    extensionsInPairs_ = inPairs;
    squaresAreCurrent_ = squares;
  }

  /// True when the body's displacements are bitwise those of the last
  /// updateExtensions (bonds break only in computeForces, before it).
  bool extensionsAreCurrent(const BodyContext& body) const {
    const std::size_t n3 = 3 * (body.end - body.begin);
    if (uOfExtensions_.size() != n3) return false;
    const double* u = body.particles.displacement.data() + 3 * body.begin;
    return std::equal(uOfExtensions_.begin(), uOfExtensions_.end(), u);
  }

  // Without surface correction every factor is 1 and t_IJ = (A_I w |xi| + B_I w e)
  // with per-particle A = 3 K theta / m - alpha theta / 3, B = alpha
  // (Eq. 25 with Eq. 22), so t_IJ + t_JI needs only per-particle values of
  // the partner: one pass over the bonds, no gather of the partner's bond.
  void uncorrectedForces(const BodyContext& body, std::vector<double>& force) {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    const long n = static_cast<long>(body.end - body.begin);
    particleCoefficients(n);
    const double* x = x_.data();
    const std::uint32_t* nb = b.neighbor.data();
    const double* len = b.length.data();
    const double* wv = weightVolume_.data();
    const double* e = e_.data();
    const double* A = coefA_.data();
    const double* B = alpha_.data();
    const std::size_t first = body.begin;
#pragma omp parallel for schedule(dynamic, 256) if (n > kOmpMinParticles)
    for (long il = 0; il < n; ++il) {
      const double xi0 = x[3 * il], xi1 = x[3 * il + 1], xi2 = x[3 * il + 2];
      const double Ai = A[il], Bi = B[il];
      double f0 = 0.0, f1 = 0.0, f2 = 0.0;
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;
        const std::size_t jl = nb[k] - first;
        const double* xj = x + 3 * jl;
        const double y0 = xj[0] - xi0, y1 = xj[1] - xi1, y2 = xj[2] - xi2;
        const double L = len[k];
        // |Y| = e + |xi| from the extension pass (no second square root).
        const double tSum = (Ai + A[jl]) * L + (Bi + B[jl]) * e[k];
        const double s = tSum * wv[k] / (e[k] + L);  // wv = w beta V_J
        f0 += s * y0;
        f1 += s * y1;
        f2 += s * y2;
      }
      const double f[3] = {f0, f1, f2};
      storeBondSum(force, p, first + static_cast<std::size_t>(il), f);
    }
  }

  // Per-particle A = 3 K theta / m - alpha theta / 3 of t_IJ (see above); B
  // is alpha_, fixed.
  void particleCoefficients(long n) {
    coefA_.resize(static_cast<std::size_t>(n));
    for (std::size_t il = 0; il < coefA_.size(); ++il)
      coefA_[il] = m_[il] > 0.0 ? 3.0 * K_ * theta_[il] / m_[il] - alpha_[il] * theta_[il] / 3.0 : 0.0;
  }

  // ---- Pairwise loops (uncorrected LPS on one thread) ----------------------
  // Visiting each pair once, from its first particle, takes one root and one
  // read of the partner's position, index, |xi| and w beta for both
  // directions (w beta V_J is formed from the particle volumes): 1.3-1.45x
  // faster than the row loops on one thread (docs/pd.md). Y_JI = -Y_IJ and
  // e_JI = e_IJ exactly, and every particle's sums take their terms in the
  // order of its row (earlier partners' terms arrive first, in ascending
  // order, then its own row adds the later ones), so theta and the forces
  // are bitwise those of the row loops. Such loops write both ends of a
  // pair, so they run only where no other thread shares the body.

  /// Whether the body's bond loops run on this thread alone (a small body,
  /// one thread, or bodies already shared out over threads) and no bond is
  /// broken (the pair lists carry no flags; LPS has no breakage criterion).
  bool pairwise(const BodyContext& body) const { return onOneThread(body) && intact(body); }

  /// The body's bond loops run on this thread alone.
  static bool onOneThread([[maybe_unused]] const BodyContext& body) {
#ifdef _OPENMP
    return body.end - body.begin <= static_cast<std::size_t>(kOmpMinParticles) || omp_get_max_threads() == 1 ||
           omp_in_parallel();
#else
    return true;
#endif
  }

  /// No bond of the body is broken. Asked every force evaluation (a restore
  /// may bring broken flags): memchr scans the flags at memory speed,
  /// std::find one byte at a time.
  static bool intact(const BodyContext& body) {
    const auto& broken = body.bonds.broken;
    return broken.empty() || std::memchr(broken.data(), 1, broken.size()) == nullptr;
  }

  // Each bond i -> j with j after i, in row order.
  void buildPairs(const BodyContext& body) {
    const auto& b = body.bonds;
    const std::size_t n = b.rows();
    pairOffset_.assign(n + 1, 0);
    pairPartner_.clear(), pairLength_.clear(), pairWeight_.clear();
    for (std::size_t il = 0; il < n; ++il) {
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.neighbor[k] <= body.begin + il) continue;
        // w depends on |xi| only and beta is symmetric: weight_ is the pair's.
        pairPartner_.push_back(static_cast<std::uint32_t>(b.neighbor[k] - body.begin));
        pairLength_.push_back(b.length[k]);
        pairWeight_.push_back(weight_[k]);
      }
      pairOffset_[il + 1] = pairPartner_.size();
    }
    pairExtension_.assign(pairPartner_.size(), 0.0);
    // A lattice body's particles share one volume V: then both ends of a pair
    // add the same (w beta V) |xi| e to theta and take the same force factor,
    // formed once from per-pair constants (bitwise the products the general
    // loops form: ((w V) |xi|) e and t (w V) / |Y|).
    const double* V = body.particles.volume.data() + body.begin;
    uniformVolume_ = n > 0 && std::all_of(V, V + n, [V](double v) { return v == V[0]; });
    pairWeightVolume_.clear(), pairThetaCoef_.clear();
    if (!uniformVolume_) return;
    for (std::size_t q = 0; q < pairWeight_.size(); ++q) {
      pairWeightVolume_.push_back(pairWeight_[q] * V[0]);
      pairThetaCoef_.push_back(pairWeightVolume_.back() * pairLength_[q]);
    }
  }

  void pairForces(const BodyContext& body, std::vector<double>& force) {
    pairExtensions(body);
    particleCoefficients(static_cast<long>(body.end - body.begin));
    pairBondForces(body, force);
  }

  // e (Eq. 18) per pair and theta (Eq. 20) at the current positions, as
  // updateExtensions for the row loops; thetaCoef_ = (w beta V_J) |xi|.
  // With Squares also S = sum w beta V_J e^2, in each particle's row order
  // like theta, so bitwise the row loops' S.
  template <bool Squares = false>
  void pairExtensions(const BodyContext& body) const {
    if (uniformVolume_) pairExtensionsOf<Squares, true>(body);
    else pairExtensionsOf<Squares, false>(body);
  }

  template <bool Squares, bool Uniform>
  void pairExtensionsOf(const BodyContext& body) const {
    currentPositions(body, x_);
    const std::size_t n = body.end - body.begin;
    const double* x = x_.data();
    const double* V = body.particles.volume.data() + body.begin;
    std::fill(theta_.begin(), theta_.end(), 0.0);
    if constexpr (Squares) squares_.assign(n, 0.0);
    // Data pointers taken once: the loop has more live values than registers,
    // and members would be reloaded through `this` after every store.
    const std::size_t* offset = pairOffset_.data();
    const std::uint32_t* partner = pairPartner_.data();
    const double* length = pairLength_.data();
    const double* weight = pairWeight_.data();
    const double* weightVolume = pairWeightVolume_.data();  // Uniform: w beta V
    const double* thetaCoef = pairThetaCoef_.data();        // Uniform: (w beta V) |xi|
    const double* mass = m_.data();
    double* extension = pairExtension_.data();
    double* theta = theta_.data();
    double* squares = squares_.data();
    for (std::size_t il = 0; il < n; ++il) {
      const double xi0 = x[3 * il], xi1 = x[3 * il + 1], xi2 = x[3 * il + 2], Vi = V[il];
      double th = theta[il];
      double sq = Squares ? squares[il] : 0.0;
      for (std::size_t q = offset[il]; q < offset[il + 1]; ++q) {
        const std::size_t jl = partner[q];
        const double* xj = x + 3 * jl;
        const double y0 = xj[0] - xi0, y1 = xj[1] - xi1, y2 = xj[2] - xi2;
        const double L = length[q];
        const double ek = std::sqrt(y0 * y0 + y1 * y1 + y2 * y2) - L;
        extension[q] = ek;
        if constexpr (Uniform) {
          const double t = thetaCoef[q] * ek;
          th += t;
          theta[jl] += t;
          if constexpr (Squares) {
            const double s2 = weightVolume[q] * ek * ek;
            sq += s2;
            squares[jl] += s2;
          }
        } else {
          const double w = weight[q];
          th += w * V[jl] * L * ek;
          theta[jl] += w * Vi * L * ek;
          if constexpr (Squares) {
            sq += w * V[jl] * ek * ek;
            squares[jl] += w * Vi * ek * ek;
          }
        }
      }
      theta[il] = mass[il] > 0.0 ? 3.0 * th / mass[il] : 0.0;
      if constexpr (Squares) squares[il] = sq;
    }
    rememberExtensions(body, true, Squares);
  }

  // Eq. 24 from the pair loops' e and theta. Every particle sums its
  // deviatoric terms w (e^d)^2 V_J in its row's order, as pairExtensions
  // sums theta, so the densities are bitwise rowEnergyDensity's.
  std::vector<double> pairEnergyDensity(const BodyContext& body) const {
    const std::size_t n = body.end - body.begin;
    const double* V = body.particles.volume.data() + body.begin;
    std::vector<double> dev(n, 0.0), thirdTheta(n);
    for (std::size_t il = 0; il < n; ++il) thirdTheta[il] = theta_[il] / 3.0;
    for (std::size_t il = 0; il < n; ++il) {
      const double Vi = V[il];
      double d = dev[il];
      for (std::size_t q = pairOffset_[il]; q < pairOffset_[il + 1]; ++q) {
        const std::size_t jl = pairPartner_[q];
        const double L = pairLength_[q], w = pairWeight_[q], ek = pairExtension_[q];
        const double edi = ek - thirdTheta[il] * L, edj = ek - thirdTheta[jl] * L;  // Eq. 22
        d += w * edi * edi * V[jl];
        dev[jl] += w * edj * edj * Vi;
      }
      dev[il] = particleEnergyDensity(il, d);
    }
    return dev;
  }

  // s = (t_IJ + t_JI) w beta V_J / |Y| per direction, f_I = V_I sum s Y (Eq. 14).
  void pairBondForces(const BodyContext& body, std::vector<double>& force) {
    if (uniformVolume_) pairBondForcesOf<true>(body, force);
    else pairBondForcesOf<false>(body, force);
  }

  template <bool Uniform>
  void pairBondForcesOf(const BodyContext& body, std::vector<double>& force) {
    const std::size_t n = body.end - body.begin;
    const double* x = x_.data();
    const double* V = body.particles.volume.data() + body.begin;
    const double* A = coefA_.data();
    const double* B = alpha_.data();
    pairForce_.assign(3 * n, 0.0);
    double* sums = pairForce_.data();
    // Data pointers taken once, as in pairExtensions.
    const std::size_t* offset = pairOffset_.data();
    const std::uint32_t* partner = pairPartner_.data();
    const double* length = pairLength_.data();
    const double* weight = pairWeight_.data();
    const double* weightVolume = pairWeightVolume_.data();  // Uniform: w beta V
    const double* extension = pairExtension_.data();
    for (std::size_t il = 0; il < n; ++il) {
      const double xi0 = x[3 * il], xi1 = x[3 * il + 1], xi2 = x[3 * il + 2];
      const double Ai = A[il], Bi = B[il], Vi = V[il];
      double f0 = sums[3 * il], f1 = sums[3 * il + 1], f2 = sums[3 * il + 2];
      for (std::size_t q = offset[il]; q < offset[il + 1]; ++q) {
        const std::size_t jl = partner[q];
        const double* xj = x + 3 * jl;
        const double y0 = xj[0] - xi0, y1 = xj[1] - xi1, y2 = xj[2] - xi2;
        const double L = length[q], ek = extension[q];
        const double tSum = (Ai + A[jl]) * L + (Bi + B[jl]) * ek;
        const double Y = ek + L;
        double si, sj;
        if constexpr (Uniform) {
          si = sj = tSum * weightVolume[q] / Y;
        } else {
          // Equal volumes give bitwise equal factors: one division.
          const double w = weight[q];
          si = tSum * (w * V[jl]) / Y;
          sj = V[jl] == Vi ? si : tSum * (w * Vi) / Y;
        }
        f0 += si * y0;
        f1 += si * y1;
        f2 += si * y2;
        double* fj = sums + 3 * jl;
        fj[0] -= sj * y0;
        fj[1] -= sj * y1;
        fj[2] -= sj * y2;
      }
      const double f[3] = {f0, f1, f2};
      storeBondSum(force, body.particles, body.begin + il, f);
    }
  }

  // Scalar force state t_IJ (Eq. 25). With bond-wise surface factors the
  // deviatoric energy also depends on theta through e^d, which adds the
  // term -(alpha/3) S (3/m) d w |xi| (S = sum h w e^d |xi| V) so forces stay
  // the exact derivative of the energy; S = 0 without correction.
  void scalarForceState(const BodyContext& body, std::size_t il) {
    const auto& b = body.bonds;
    const auto& p = body.particles;
    if (!(m_[il] > 0.0)) return;
    const double alpha = alpha_[il];
    double S = 0.0;
    if (corrected_)
      for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
        if (b.broken[k]) continue;
        const double ed = e_[k] - theta_[il] * b.length[k] / 3.0;
        S += deviatoricFactor_[k] * weight_[k] * ed * b.length[k] * p.volume[b.neighbor[k]];
      }
    const double iso = 3.0 * (K_ * theta_[il] - alpha * S / 3.0) / m_[il];
    for (std::size_t k = b.offset[il]; k < b.offset[il + 1]; ++k) {
      if (b.broken[k]) { t_[k] = 0.0; continue; }
      const double ed = e_[k] - theta_[il] * b.length[k] / 3.0;
      // Partial volume beta sits in weight_ and is divided out here: the force
      // loop multiplies by beta V_J once.
      const double w = weight_[k] / b.volumeFraction[k];
      t_[k] = iso * dilatationFactor_[k] * w * b.length[k] + alpha * deviatoricFactor_[k] * w * ed;
    }
  }

  // Surface correction: two per-particle tensors replace the scalar factors
  // of the complete family, so near-surface particles respond like the bulk.
  //  - Dilatation: theta_i = sum (n^T M_i n) w |xi| e V with the symmetric M_i
  //    solving sum w V (n^T M n) xi (x) xi = I, so theta = tr(eps) for every
  //    small affine strain whatever the family's shape ("position-aware"
  //    dilatation; Mitchell, Silling & Littlewood 2015 use the same idea).
  //  - Deviatoric: bond factor h = n^T H_i n with a diagonal H_i chosen so the
  //    deviatoric energy of the three axial deviators (the deviatoric parts of
  //    uniaxial strain or stress along x, y, z) equals the complete family's,
  //    scaled by m_i / m_full as alpha = 15G/m. (Off-diagonal H would be
  //    invisible to reflection-symmetric families: that system is singular.)
  // In a complete cubic-lattice family M = (3/m) I and H = I: Eq. 20 and 24.
  void surfaceCorrection(const BodyContext& body) {
    corrected_ = true;
    const auto& b = body.bonds;
    const auto& p = body.particles;
    const auto w = influenceFunction(body.options.influence);
    const auto full = detail::fullLatticeFamily(body.spacing, body.horizon, body.options.partialVolume);
    using Vec6 = Eigen::Matrix<double, 6, 1>;
    using Mat6 = Eigen::Matrix<double, 6, 6>;
    // (n . D_b n) for the six basis modes, and the tensor row of n^T X n.
    auto modes = [](const double* n, Vec6& proj) {
      proj << n[0] * n[0] - 1.0 / 3.0, n[1] * n[1] - 1.0 / 3.0, n[2] * n[2] - 1.0 / 3.0, n[0] * n[1],
          n[1] * n[2], n[2] * n[0];
    };
    auto tensorRow = [](const double* n, Vec6& row) {
      row << n[0] * n[0], n[1] * n[1], n[2] * n[2], 2 * n[0] * n[1], 2 * n[1] * n[2], 2 * n[2] * n[0];
    };
    double mFull = 0.0;
    Vec6 devFull = Vec6::Zero();
    for (std::size_t k = 0; k < full.length.size(); ++k) {
      const double r = full.length[k], wv = w(r, body.horizon) * full.volume[k];
      const double n[3] = {full.xi[3 * k] / r, full.xi[3 * k + 1] / r, full.xi[3 * k + 2] / r};
      Vec6 proj;
      modes(n, proj);
      mFull += wv * r * r;
      devFull += wv * r * r * proj.cwiseProduct(proj);
    }
    const std::size_t count = body.end - body.begin;
    for (std::size_t i = 0; i < count; ++i) {
      Mat6 A = Mat6::Zero();
      Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        const std::size_t j = b.neighbor[k];
        const double r = b.length[k];
        double n[3];
        for (int a = 0; a < 3; ++a) n[a] = (p.reference[3 * j + a] - p.reference[3 * (body.begin + i) + a]) / r;
        Vec6 row, proj, xx;
        tensorRow(n, row);
        modes(n, proj);
        xx << n[0] * n[0], n[1] * n[1], n[2] * n[2], n[0] * n[1], n[1] * n[2], n[2] * n[0];
        const double wv = weight_[k] * p.volume[j] * r * r;
        A += wv * xx * row.transpose();
        const Eigen::Vector3d axial = proj.head<3>().cwiseProduct(proj.head<3>());
        B += wv * axial * Eigen::Vector3d(n[0] * n[0], n[1] * n[1], n[2] * n[2]).transpose();
      }
      Vec6 rhsM;
      rhsM << 1, 1, 1, 0, 0, 0;
      const auto luA = A.fullPivLu();
      const auto luB = B.fullPivLu();
      // Degenerate families (a line of particles) keep the plain factors.
      const bool okM = luA.isInvertible(), okH = luB.isInvertible();
      const Vec6 M = okM ? Vec6(luA.solve(rhsM)) : Vec6::Zero();
      const Eigen::Vector3d H =
          okH ? Eigen::Vector3d(luB.solve(Eigen::Vector3d(devFull.head<3>() * (m_[i] / mFull))))
              : Eigen::Vector3d::Ones();
      for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
        double n[3];
        for (int a = 0; a < 3; ++a)
          n[a] = (p.reference[3 * b.neighbor[k] + a] - p.reference[3 * (body.begin + i) + a]) / b.length[k];
        Vec6 row;
        tensorRow(n, row);
        if (okM) dilatationFactor_[k] = m_[i] / 3.0 * row.dot(M);
        if (okH) deviatoricFactor_[k] = n[0] * n[0] * H[0] + n[1] * n[1] * H[1] + n[2] * n[2] * H[2];
      }
    }
  }

  double K_ = 0.0, G_ = 0.0;
  bool corrected_ = false;
  std::vector<double> weight_, dilatationFactor_, deviatoricFactor_, m_, t_;
  std::vector<double> thetaCoef_, weightVolume_;  // per bond: h w |xi| V_J and w beta V_J
  mutable std::vector<double> theta_, e_, x_;  // scratch of the current configuration
  mutable std::vector<double> uOfExtensions_;  // the body's displacements e and theta_ belong to
  mutable bool extensionsInPairs_ = false;     // e is in pairExtension_ (pair loops), else in e_
  mutable std::vector<double> squares_;        // per particle sum w beta V_J e^2 (updateExtensions<true>)
  mutable bool squaresAreCurrent_ = false;     // squares_ belongs to the remembered extensions
  std::vector<std::size_t> reverse_;
  // Pair lists of the pairwise loops: pairs of row i in [pairOffset_[i], pairOffset_[i + 1]).
  std::vector<std::size_t> pairOffset_;
  std::vector<std::uint32_t> pairPartner_;  // body-local index of the later particle
  std::vector<double> pairLength_, pairWeight_;  // |xi|, w beta
  bool uniformVolume_ = false;                    // every particle of the body has one volume V
  std::vector<double> pairWeightVolume_, pairThetaCoef_;  // uniformVolume_ only: w beta V, (w beta V) |xi|
  mutable std::vector<double> pairExtension_;      // e of the pair loops (scratch, as e_)
  std::vector<double> pairForce_;  // force sums, 3 per particle
  std::vector<double> coefA_;  // per particle A of t_IJ (particleCoefficients)
  std::vector<double> alpha_;  // per particle alpha = 15 G / m (Eq. 25), B of t_IJ
};

}  // namespace

PD_REGISTER_MODEL("lps", Lps);

}  // namespace cosim::pd
