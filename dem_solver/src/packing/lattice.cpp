#include <stdexcept>

#include "cosim/dem/packing/packing.hpp"

namespace cosim::dem {

SphereSet latticePacking(const Vec3& origin, double spacing, const std::array<int, 3>& counts, double radius,
                         const std::string& kind) {
  if (!(spacing > 0.0)) throw std::invalid_argument("lattice spacing must be positive");
  if (counts[0] < 1 || counts[1] < 1 || counts[2] < 1) throw std::invalid_argument("lattice counts must be >= 1");
  SphereSet s;
  std::vector<Vec3> basis{{0, 0, 0}};
  if (kind == "fcc") basis = {{0, 0, 0}, {0.5, 0.5, 0}, {0.5, 0, 0.5}, {0, 0.5, 0.5}};
  else if (kind != "cubic") throw std::invalid_argument("unknown lattice kind '" + kind + "' (known: cubic, fcc)");
  for (int k = 0; k < counts[2]; ++k)
    for (int j = 0; j < counts[1]; ++j)
      for (int i = 0; i < counts[0]; ++i)
        for (const Vec3& b : basis) {
          s.centres.push_back(origin + spacing * Vec3{i + b.x, j + b.y, k + b.z});
          s.velocities.push_back({});
          s.radii.push_back(radius);
          s.origin.push_back("lattice");
        }
  return s;
}

}  // namespace cosim::dem
