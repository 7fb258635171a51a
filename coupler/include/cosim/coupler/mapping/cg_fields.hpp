#pragma once
// Coarse-grained continuum fields of a particle snapshot on a regular grid
// (Cheng 2022 Sec. 4; the stress is the standard Goldhirsch 2010 / Weinhart
// 2012 coarse-grained stress). With a kernel W of width c:
//   density            rho(x) = sum_a m_a W(x - x_a)                          (Cheng Eq. 8)
//   momentum density   j(x)   = sum_a m_a v_a W(x - x_a),   V = j / rho       (Cheng Eq. 11)
//   kinetic stress     s^k(x) = -sum_a m_a v'_a (x) v'_a W(x - x_a),  v'_a = v_a - V(x)
//   contact stress     s^c(x) = sum_a sum_k f_ak (x) l_ak int_0^1 W(x - x_a - s l_ak) ds
//   boundary force     t(x)   = sum_(wall contacts) f_aw W(x - x^c_aw)        (Cheng Eq. 12)
// where f_ak is the force on particle a at its contact k and l_ak = x^c_ak - x_a
// its branch vector (Cheng Sec. 2). A particle pair contributes both of its
// sides, so s^c reduces to the usual -f_ab (x) (x_a - x_b) line integral along
// the centre line. With these definitions, for particles at rest
//   div s + rho g + t = 0,   s = s^c + s^k,   (div s)_i = d_j s_ij,
// holds pointwise (Weinhart 2012 Eq. 19): t is the force density the walls
// exert on the granular material. Cheng's Eq. 12 writes the same density with
// the opposite sign because it is the load on the wall (the coupled FEM body):
// b^BC = -t.
//
// All inputs are structure-of-arrays spans, vectors flat as x0 y0 z0 x1 ...
// Sources are binned in cells of size c, so each grid point only visits the
// 27 cells around it: the cost is O(grid points x sources per cell), not
// O(grid x N).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "cosim/coupler/mapping/cg_kernel.hpp"

namespace cosim::coupler {

/// Regular grid; point (i, j, k) is origin + (i, j, k) * spacing, stored with i fastest.
struct CgGrid {
  std::array<double, 3> origin{};
  std::array<double, 3> spacing{1.0, 1.0, 1.0};
  std::array<std::size_t, 3> counts{1, 1, 1};
  std::size_t size() const { return counts[0] * counts[1] * counts[2]; }
  std::size_t index(std::size_t i, std::size_t j, std::size_t k) const { return i + counts[0] * (j + counts[1] * k); }
  std::array<double, 3> point(std::size_t index) const;
  double cellVolume() const { return spacing[0] * spacing[1] * spacing[2]; }
};

struct CgParticles {
  std::span<const double> positions;   // 3N [m]
  std::span<const double> velocities;  // 3N [m/s]
  std::span<const double> masses;      // N [kg]
  std::span<const double> radii;       // N [m]: contact points must lie within them
};

/// Particle-particle contacts: forces act on `first` (the partner gets minus them).
struct CgPairContacts {
  std::span<const std::uint32_t> first, second;  // particle indices
  std::span<const double> points;                // 3M contact points [m]
  std::span<const double> forces;                // 3M force on `first` [N]
};

/// Particle-wall contacts: forces the wall exerts on the particle.
struct CgWallContacts {
  std::span<const std::uint32_t> particle;
  std::span<const double> points;  // 3M contact points on the wall [m]
  std::span<const double> forces;  // 3M [N]
};

enum class CgNormalisation {
  /// The kernel's own 3D normalisation: the fields are exactly Eqs. 8, 11, 12
  /// at the grid points; the grid sum of rho h^3 equals the mass only up to
  /// the quadrature error of the grid.
  analytic,
  /// Every source's kernel is divided by its grid sum h^3 sum_g W(x_g - x_a),
  /// the volume analogue of Cheng's quadrature-normalised surface kernel
  /// (Sec. 5.1.2): mass, momentum and wall force then integrate exactly over
  /// the grid, whatever its spacing, and sources near the grid's edge keep
  /// their whole weight inside it.
  grid,
};

struct CgOptions {
  double width = 0.0;  // c [m]
  CgNormalisation normalisation = CgNormalisation::analytic;
  int branchPoints = 4;  // Gauss-Legendre points along each branch vector
};

struct CgFields {
  std::vector<double> density;        // n
  std::vector<double> momentum;       // 3n
  std::vector<double> velocity;       // 3n, zero where the density is zero
  std::vector<double> kineticStress;  // 9n, row-major s_ij
  std::vector<double> contactStress;  // 9n, row-major s_ij, row i = force component
  std::vector<double> stress;         // 9n, kinetic + contact
  std::vector<double> boundaryForce;  // 3n [N/m^3]
  std::size_t droppedSources = 0;     // grid normalisation: sources with no grid point within c
};

/// Coarse-grains one snapshot. Throws std::invalid_argument naming the input
/// that is inconsistent (sizes, indices, non-finite values, contact points
/// farther from the centre than the radius, c <= 0 or a Dirac kernel).
CgFields coarseGrain(const CgKernel& kernel, const CgOptions& options, const CgGrid& grid,
                     const CgParticles& particles, const CgPairContacts& pairs, const CgWallContacts& walls);

}  // namespace cosim::coupler
