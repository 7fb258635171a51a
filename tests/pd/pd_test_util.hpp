#pragma once
// Helpers shared by the PD verification tests: lattice boxes in lattice units
// (spacing h), affine displacement fields, interior particle selection,
// scratch input files.
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cosim/pd/system.hpp"

namespace cosim::pd::test {

inline BodySpec box(const std::string& name, const std::string& model, int nx, int ny, int nz,
                    double h, double horizonFactor, double nu = 0.25) {
  BodySpec b;
  b.name = name;
  b.shape = Shape::Box;
  b.min = {0.0, 0.0, 0.0};
  b.max = {nx * h, ny * h, nz * h};
  b.spacing = h;
  b.horizonFactor = horizonFactor;
  b.model = model;
  b.material.youngsModulus = 1.0e9;
  b.material.poissonRatio = nu;
  b.material.density = 1000.0;
  return b;
}

using Mat3 = std::array<std::array<double, 3>, 3>;

/// u = (F - I) X for every particle.
inline void applyAffine(Particles& p, const Mat3& F) {
  for (std::size_t i = 0; i < p.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      double x = 0.0;
      for (int b = 0; b < 3; ++b) x += F[a][b] * p.reference[3 * i + b];
      p.displacement[3 * i + a] = x - p.reference[3 * i + a];
    }
}

/// Particles farther than margin from every face of the box [lo, hi].
inline std::vector<std::size_t> interior(const Particles& p, const BodySpec& b, double margin) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    bool in = true;
    for (int a = 0; a < 3; ++a) {
      const double x = p.reference[3 * i + a];
      in = in && x - b.min[a] > margin && b.max[a] - x > margin;
    }
    if (in) out.push_back(i);
  }
  return out;
}

/// Writes text to pd_test_<name> in the temporary directory (point files,
/// bad input) and returns its path.
inline std::filesystem::path tempFile(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("pd_test_" + name);
  std::ofstream(p) << text;
  return p;
}

}  // namespace cosim::pd::test
