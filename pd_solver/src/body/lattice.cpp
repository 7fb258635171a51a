// Regular-lattice discretisation of analytic shapes: cell centres of a cubic
// lattice of spacing h whose cell centre lies inside the shape, volume h^3.
#include <cmath>
#include <stdexcept>

#include "cosim/pd/body.hpp"

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

}  // namespace

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
  Vec3 lo{}, hi{};
  bounds(spec, lo, hi);
  const double h = spec.spacing;
  int n[3];
  for (int k = 0; k < 3; ++k) {
    // Boxes are filled with whole cells; other shapes use the cells whose
    // centre is inside, on a lattice centred on the bounding box.
    n[k] = static_cast<int>(std::lround((hi[k] - lo[k]) / h));
    if (n[k] < 1) n[k] = 1;
  }
  PointCloud cloud;
  const double vol = h * h * h;
  for (int i = 0; i < n[0]; ++i)
    for (int j = 0; j < n[1]; ++j)
      for (int l = 0; l < n[2]; ++l) {
        const int idx[3] = {i, j, l};
        double x[3];
        for (int k = 0; k < 3; ++k) {
          const double mid = 0.5 * (lo[k] + hi[k]);
          x[k] = mid + (idx[k] - 0.5 * (n[k] - 1)) * h;
        }
        if (spec.shape != Shape::Box && !insideShape(spec, x, 1e-12 * h)) continue;
        cloud.positions.insert(cloud.positions.end(), x, x + 3);
        cloud.volumes.push_back(vol);
      }
  if (cloud.volumes.empty()) fail(spec, "the shape contains no lattice point at this spacing");
  return cloud;
}

}  // namespace cosim::pd
