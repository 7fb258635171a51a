// Regular-lattice discretisation of analytic shapes: cell centres of a cubic
// lattice of spacing h whose cell centre lies inside the shape, volume h^3.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "cosim/pd/body.hpp"
#include "cosim/util/host_memory.hpp"

namespace cosim::pd {
namespace {

[[noreturn]] void fail(const BodySpec& spec, const std::string& what) {
  throw std::invalid_argument("body '" + spec.name + "': " + what);
}

void requirePositive(const BodySpec& spec, double value, const char* key) {
  if (!(value > 0.0) || !std::isfinite(value)) fail(spec, std::string(key) + " must be positive");
}

// Bounding box of the shape.
void bounds(const BodySpec& spec, Vec3& lo, Vec3& hi) {
  switch (spec.shape) {
    case Shape::Box:
      lo = spec.min;
      hi = spec.max;
      return;
    case Shape::Sphere:
      for (int k = 0; k < 3; ++k) {
        lo[k] = spec.center[k] - spec.radius;
        hi[k] = spec.center[k] + spec.radius;
      }
      return;
    case Shape::Cylinder:
      for (int k = 0; k < 3; ++k) {
        const double half = (k == spec.axis) ? 0.5 * spec.length : spec.radius;
        lo[k] = spec.center[k] - half;
        hi[k] = spec.center[k] + half;
      }
      return;
    case Shape::Points:
      break;
  }
  fail(spec, "a points body has no analytic bounds");
}

constexpr double kMaxParticles = 4294967295.0;  // particle indices are std::uint32_t
// Particle arrays, model and output fields per particle; neighbour list and
// the model's per-bond arrays per bond (LPS keeps about ten values, PMB two).
constexpr double kBytesPerParticle = 512.0;
double bytesPerBond(const BodySpec& spec) { return spec.model == "pmb" ? 40.0 : 104.0; }

double atLeastOne(double n) { return n < 1.0 ? 1.0 : n; }  // NaN stays NaN

// Cells of spacing h across an extent (at least one).
double axisCount(double extent, double h) { return atLeastOne(std::round(extent / h)); }

std::string gigabytes(double bytes) {
  std::ostringstream s;
  s.precision(3);
  s << bytes / 1e9 << " GB";
  return s.str();
}

// Estimated counts: whole numbers below a million, else three digits.
std::string amount(double n) {
  std::ostringstream s;
  if (n < 1e6) s << std::llround(n);
  else s << std::setprecision(3) << n;
  return s.str();
}

std::string particleProblem(const BodySpec& spec, double particles, double memory) {
  std::ostringstream why;
  if (spec.shape == Shape::Points) why << "'file' holds " << amount(particles) << " particles";
  else why << "'spacing' " << spec.spacing << " gives about " << amount(particles) << " particles";
  if (std::isfinite(particles)) why << " (" << gigabytes(particles * kBytesPerParticle) << ")";
  why << ": more than the " << static_cast<std::uint64_t>(kMaxParticles) << " a 32-bit particle index holds or the "
      << gigabytes(memory) << " of memory available; use "
      << (spec.shape == Shape::Points ? "fewer points" : "a coarser spacing or a smaller body");
  return why.str();
}

// A bond of the complete reference family (detail::fullLatticeFamily): its
// vector, length and volume.
constexpr double kBytesPerReferenceBond = 5.0 * sizeof(double);

std::string bondProblem(const BodySpec& spec, const BodySize& size, double memory) {
  std::ostringstream why;
  why << "'horizon' " << spec.horizonFactor << " gives about " << amount(size.bonds) << " bonds for "
      << amount(size.particles) << " particles (" << gigabytes(size.bytes) << "): more than the " << gigabytes(memory)
      << " of memory available; use a smaller horizon or a coarser spacing";
  return why.str();
}

}  // namespace

BodySize estimateBodySize(const BodySpec& spec, double particles) {
  const double m = spec.horizonFactor + 0.5;
  const double family = std::min(4.0 / 3.0 * std::numbers::pi * m * m * m, std::max(particles - 1.0, 0.0));
  BodySize size;
  size.particles = particles;
  size.bonds = particles * family;
  size.bytes = particles * kBytesPerParticle + size.bonds * bytesPerBond(spec);
  return size;
}

double latticeParticleEstimate(const BodySpec& spec) {
  const double h = spec.spacing;
  switch (spec.shape) {
    case Shape::Box:
      return axisCount(spec.max[0] - spec.min[0], h) * axisCount(spec.max[1] - spec.min[1], h) *
             axisCount(spec.max[2] - spec.min[2], h);
    case Shape::Sphere:
      return atLeastOne(4.0 / 3.0 * std::numbers::pi * std::pow(spec.radius / h, 3));
    case Shape::Cylinder:  // cross-section cells times layers along the axis
      return atLeastOne(std::numbers::pi * std::pow(spec.radius / h, 2)) * axisCount(spec.length, h);
    case Shape::Points:
      break;
  }
  return 0.0;
}

std::string bodySizeProblem(const BodySpec& spec, double particles, std::string& key) {
  const double memory = util::availableMemoryBytes();
  if (!(particles <= kMaxParticles && particles * kBytesPerParticle <= memory)) {
    key = spec.shape == Shape::Points ? "file" : "spacing";
    return particleProblem(spec, particles, memory);
  }
  const BodySize size = estimateBodySize(spec, particles);
  if (!(size.bytes <= memory)) {
    key = "horizon";
    return bondProblem(spec, size, memory);
  }
  // The models' micromodulus and surface correction are computed against the
  // complete family of an unbounded lattice, whose size grows with the cube
  // of the horizon factor whatever the body's size.
  const double m = spec.horizonFactor + 0.5;
  const double reference = 4.0 / 3.0 * std::numbers::pi * m * m * m;
  if (!(reference * kBytesPerReferenceBond <= memory)) {
    key = "horizon";
    std::ostringstream why;
    why << "'horizon' " << spec.horizonFactor << " gives a complete lattice family of about " << amount(reference)
        << " bonds (" << gigabytes(reference * kBytesPerReferenceBond)
        << "), which the models' micromodulus and surface correction are computed against: more than the "
        << gigabytes(memory) << " of memory available; use a smaller horizon";
    return why.str();
  }
  return {};
}

std::string bondCountProblem(const BodySpec& spec, double particles, double bonds) {
  BodySize size;
  size.particles = particles;
  size.bonds = bonds;
  size.bytes = particles * kBytesPerParticle + bonds * bytesPerBond(spec);
  const double memory = util::availableMemoryBytes();
  return size.bytes <= memory ? std::string() : bondProblem(spec, size, memory);
}

bool insideShape(const BodySpec& spec, const double x[3], double tol) {
  switch (spec.shape) {
    case Shape::Box:
      for (int k = 0; k < 3; ++k)
        if (x[k] < spec.min[k] - tol || x[k] > spec.max[k] + tol) return false;
      return true;
    case Shape::Sphere: {
      double r2 = 0.0;
      for (int k = 0; k < 3; ++k) r2 += (x[k] - spec.center[k]) * (x[k] - spec.center[k]);
      return r2 <= (spec.radius + tol) * (spec.radius + tol);
    }
    case Shape::Cylinder: {
      double r2 = 0.0;
      for (int k = 0; k < 3; ++k) {
        const double d = x[k] - spec.center[k];
        if (k == spec.axis) {
          if (std::abs(d) > 0.5 * spec.length + tol) return false;
        } else {
          r2 += d * d;
        }
      }
      return r2 <= (spec.radius + tol) * (spec.radius + tol);
    }
    case Shape::Points:
      return false;
  }
  return false;
}

PointCloud discretise(const BodySpec& spec) {
  if (spec.shape == Shape::Points) fail(spec, "points bodies are read with readPointFile");
  requirePositive(spec, spec.spacing, "spacing");
  requirePositive(spec, spec.horizonFactor, "horizon");
  if (spec.shape == Shape::Box) {
    for (int k = 0; k < 3; ++k)
      if (!(spec.max[k] > spec.min[k])) fail(spec, "box max must exceed min in every direction");
  } else {
    requirePositive(spec, spec.radius, "radius");
    if (spec.shape == Shape::Cylinder) requirePositive(spec, spec.length, "length");
    if (spec.axis < 0 || spec.axis > 2) fail(spec, "cylinder axis must be x, y or z");
  }
  std::string key;
  if (const auto why = bodySizeProblem(spec, latticeParticleEstimate(spec), key); !why.empty()) fail(spec, why);
  Vec3 lo{}, hi{};
  bounds(spec, lo, hi);
  const double h = spec.spacing;
  // Boxes are filled with whole cells; other shapes use the cells whose
  // centre is inside, on a lattice centred on the bounding box. The counts
  // are bounded by the size check above.
  double n[3];
  for (int k = 0; k < 3; ++k) n[k] = axisCount(hi[k] - lo[k], h);
  const auto count = [&n](int k) { return static_cast<long>(n[k]); };
  PointCloud cloud;
  const double vol = h * h * h;
  for (long i = 0; i < count(0); ++i)
    for (long j = 0; j < count(1); ++j)
      for (long l = 0; l < count(2); ++l) {
        const long idx[3] = {i, j, l};
        double x[3];
        for (int k = 0; k < 3; ++k) {
          const double mid = 0.5 * (lo[k] + hi[k]);
          x[k] = mid + (static_cast<double>(idx[k]) - 0.5 * (n[k] - 1.0)) * h;
        }
        if (spec.shape != Shape::Box && !insideShape(spec, x, 1e-12 * h)) continue;
        cloud.positions.insert(cloud.positions.end(), x, x + 3);
        cloud.volumes.push_back(vol);
      }
  if (cloud.volumes.empty()) fail(spec, "the shape contains no lattice point at this spacing");
  return cloud;
}

}  // namespace cosim::pd
