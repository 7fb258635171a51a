#pragma once
// Structure-of-arrays particle storage shared by every body of one solver
// instance. Vectors are interleaved xyz (3 doubles per particle); each body
// owns a contiguous index range so a model loops over [begin, end).
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cosim::pd {

/// Loops over fewer particles than this run serially: below it the work per
/// OpenMP region (~0.1 ms) is too small to pay for the fork/join and barrier,
/// and on a loaded machine spinning threads make small problems much slower.
/// Bond loops use dynamic chunks so a thread descheduled by another process
/// does not hold the others at the barrier; each particle sums its own row,
/// so results do not depend on the schedule or the thread count.
inline constexpr long kOmpMinParticles = 4096;

struct Particles {
  std::vector<double> reference;     // X, 3 per particle
  std::vector<double> displacement;  // u, 3 per particle (current x = X + u)
  std::vector<double> velocity;      // v, 3 per particle
  std::vector<double> internalForce; // f^PD, 3 per particle (Hartmann Eq. 12/14)
  std::vector<double> externalForce; // coupling + applied loads + body forces, 3 per particle
  std::vector<double> volume;        // V
  std::vector<double> mass;          // rho V
  std::vector<std::uint32_t> body;   // index of the owning body

  std::size_t size() const { return volume.size(); }
  void append(const double x[3], double v, double m, std::uint32_t bodyIndex) {
    for (int k = 0; k < 3; ++k) {
      reference.push_back(x[k]);
      displacement.push_back(0.0);
      velocity.push_back(0.0);
      internalForce.push_back(0.0);
      externalForce.push_back(0.0);
    }
    volume.push_back(v);
    mass.push_back(m);
    body.push_back(bodyIndex);
  }
  double current(std::size_t i, int k) const { return reference[3 * i + k] + displacement[3 * i + k]; }
};

}  // namespace cosim::pd
