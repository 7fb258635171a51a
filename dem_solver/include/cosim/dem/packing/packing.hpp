#pragma once
// Packing tools: where initial spheres come from. Each returns centres and
// radii; the caller adds them to a Particles store with a material.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

struct SphereSet {
  std::vector<Vec3> centres, velocities;
  std::vector<double> radii;
  std::vector<std::string> origin;  // "file:line" or generator name, for error messages
};

/// Simple cubic (or "fcc") lattice of counts[0] x counts[1] x counts[2] cells.
SphereSet latticePacking(const Vec3& origin, double spacing, const std::array<int, 3>& counts, double radius,
                         const std::string& kind = "cubic");
/// Random loose packing: random sequential addition of non-overlapping spheres
/// with radii uniform in [rmin, rmax] inside the box [lo, hi] (whole spheres
/// inside). Stops at count spheres or after maxAttempts; deterministic in seed.
SphereSet randomPacking(const Vec3& lo, const Vec3& hi, double rmin, double rmax, std::size_t count,
                        std::uint64_t seed, std::size_t maxAttempts = 0);
/// Reads spheres from CSV (x,y,z,r[,vx,vy,vz] per line, '#' comments and one
/// optional header line) or HDF5 (datasets /positions N x 3, /radii N,
/// optional /velocities N x 3). Errors name the file, line and column.
SphereSet readSphereFile(const std::string& path);

}  // namespace cosim::dem
