#pragma once
// Discretisation of one peridynamic body: a regular lattice filling a box,
// sphere or cylinder, or a point cloud with volumes read from a file.
#include <array>
#include <string>
#include <vector>

#include "cosim/pd/bonds.hpp"
#include "cosim/pd/material.hpp"

namespace cosim::pd {

using Vec3 = std::array<double, 3>;

enum class Shape { Box, Sphere, Cylinder, Points };

/// Options of the force model of one body (the registry picks the model by name).
struct ModelOptions {
  std::string influence = "constant";  // LPS influence function w<xi>
  bool surfaceCorrection = false;      // energy-method correction near surfaces
  double criticalStretch = 0.0;        // PMB bond breakage; 0 = off
  /// PMB spring constant: "continuum" c = 18 K / (pi delta^4) (Hartmann Eq. 10)
  /// or "discrete" (same, with pi delta^4 replaced by its lattice quadrature).
  std::string micromodulus = "continuum";
  PartialVolume partialVolume = PartialVolume::Centered;
};

struct BodySpec {
  std::string name;
  Shape shape = Shape::Box;
  Vec3 min{}, max{};        // box
  Vec3 center{};            // sphere, cylinder (mid-point of the axis)
  double radius = 0.0;      // sphere, cylinder
  double length = 0.0;      // cylinder
  int axis = 2;             // cylinder axis 0/1/2
  std::string pointsFile;   // points: "x y z volume" per line
  double spacing = 0.0;     // lattice spacing h (points: cbrt of the mean volume when 0)
  double horizonFactor = 3.0;  // delta = horizonFactor * h
  Material material;
  std::string model = "pmb";
  ModelOptions options;
  Vec3 initialVelocity{};
};

struct PointCloud {
  std::vector<double> positions;  // 3 per point
  std::vector<double> volumes;
};

/// Lattice points (cell centres of spacing h) inside the shape, volume h^3 each.
/// Throws std::invalid_argument naming the body for a non-positive spacing or size.
PointCloud discretise(const BodySpec& spec);

/// Size of a body estimated before it is built: particles (a lattice: the
/// shape's volume / h^3), bonds (particles x the lattice family of horizon
/// factor m, about 4/3 pi (m + 1/2)^3, at most particles - 1) and bytes.
struct BodySize {
  double particles = 0.0;
  double bonds = 0.0;
  double bytes = 0.0;
};
BodySize estimateBodySize(const BodySpec& spec, double particles);

/// Lattice points an analytic shape will hold (box: the exact count; sphere
/// and cylinder: volume / h^3); inf or NaN for sizes no double count holds.
double latticeParticleEstimate(const BodySpec& spec);

/// Empty when a body of `particles` particles fits the 32-bit particle index
/// and the available memory (util::availableMemoryBytes); otherwise why not, with `key` set to the key to
/// change: "spacing" ("file" for a points body) when the particles alone do
/// not fit, "horizon" when their bonds do not.
std::string bodySizeProblem(const BodySpec& spec, double particles, std::string& key);

/// Empty when the bonds counted for a body of `particles` particles fit the
/// available memory with their model's arrays; otherwise why not (the key to
/// change is 'horizon'). A points body's families can be far larger than the
/// lattice estimate of bodySizeProblem: clustered points, or volumes in
/// another unit than the positions, bond every pair.
std::string bondCountProblem(const BodySpec& spec, double particles, double bonds);

/// Reads "x y z volume" lines ('#' starts a comment). Throws naming file and
/// line for unreadable lines, NaN/Inf values or non-positive volumes.
PointCloud readPointFile(const std::string& path);

/// True when a point lies inside the analytic shape (points bodies: never).
bool insideShape(const BodySpec& spec, const double x[3], double tolerance);

}  // namespace cosim::pd
