#pragma once
// Arlequin weight profile w(x) along one axis (Cheng 2022 Eqs. 22-24, Sec.
// 6.2): w = 1 on the DEM side of `start`, w = 0 beyond `end`, and between
// them either linear or a half cosine, w = (1 + cos(pi t)) / 2 with
// t = (x_axis - start) / (end - start). DEM weights particles by w, FEM
// weights element integrals by 1 - w (Eqs. 25-26). The one formula the
// coupler, dem_solver and fem_solver share, so both sides sum to one exactly.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace cosim::util {

struct WeightProfile {
  std::string kind = "half-cosine";  // "half-cosine" or "linear"
  int axis = 0;                       // 0 = x, 1 = y, 2 = z
  double start = 0.0, end = 1.0;

  /// Empty when usable, else why not (for messages that name the key).
  std::string problem() const {
    if (kind != "half-cosine" && kind != "linear") return "unknown kind '" + kind + "' (known: half-cosine, linear)";
    if (axis < 0 || axis > 2) return "axis must be 0, 1 or 2 (x, y or z)";
    if (!std::isfinite(start) || !std::isfinite(end)) return "start and end must be finite";
    if (!(end != start)) return "start and end must differ";
    return {};
  }

  /// w at coordinate s along the axis.
  double along(double s) const {
    const double t = std::clamp((s - start) / (end - start), 0.0, 1.0);
    if (kind == "linear") return 1.0 - t;
    return 0.5 * (1.0 + std::cos(std::numbers::pi * t));
  }

  /// w at a point (anything indexable by 0, 1, 2: Eigen vectors, DEM Vec3, arrays).
  template <class Point>
  double operator()(const Point& x) const {
    return along(x[axis]);
  }
};

}  // namespace cosim::util
