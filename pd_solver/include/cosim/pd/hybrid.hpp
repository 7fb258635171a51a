#pragma once
// Hybrid surface particles (Hartmann 2022 Sec. 3.1).
#include <cstdint>
#include <vector>

#include "cosim/pd/bonds.hpp"
#include "cosim/pd/particles.hpp"

namespace cosim::pd {

/// Surface criterion: a particle is on the surface when it has fewer than 18
/// partners within 1.5 h (h = body spacing); 18 is the count of the first two
/// shells (6 faces + 12 edges) of a complete simple-cubic lattice, so exactly
/// the outermost layer of a lattice body is selected.
std::vector<std::uint32_t> surfaceParticles(const Particles& particles, std::size_t begin,
                                            std::size_t end, double spacing);

/// Quasi-radius of a hybrid particle, Hartmann 2022 Eq. 39: R = (3V / 4 pi)^(1/3).
double quasiRadius(double volume);

/// Outward unit normal estimated from the family: n = -sum(beta V_j xi) / |.|.
/// Returns false (n untouched) where the family is balanced (interior).
bool surfaceNormal(const Particles& particles, const Bonds& bonds, std::size_t particle,
                   double normal[3]);

}  // namespace cosim::pd
