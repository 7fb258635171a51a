#pragma once
// Gauss-Legendre quadrature on [-1, 1]: the rule the coupler's maps integrate
// with (CG stress along branch vectors, CG-enriched homogenisation).
#include <vector>

namespace cosim::coupler {

/// n nodes x and weights w on [-1, 1] (Newton iteration on P_n).
void gaussLegendre(int n, std::vector<double>& x, std::vector<double>& w);

}  // namespace cosim::coupler
