// Influence functions, current positions and the damage index shared by models.
#include <cmath>
#include <stdexcept>

#include "cosim/pd/model.hpp"

namespace cosim::pd {

std::function<double(double, double)> influenceFunction(const std::string& name) {
  if (name == "constant") return [](double, double) { return 1.0; };
  if (name == "inverse") return [](double r, double delta) { return delta / r; };
  if (name == "gaussian") return [](double r, double delta) { return std::exp(-(r * r) / (delta * delta)); };
  throw std::invalid_argument("unknown influence function '" + name +
                              "' (known: constant, inverse, gaussian)");
}

void currentPositions(const BodyContext& body, std::vector<double>& x) {
  const long n3 = static_cast<long>(3 * (body.end - body.begin));
  x.resize(static_cast<std::size_t>(n3));
  const double* X = body.particles.reference.data() + 3 * body.begin;
  const double* u = body.particles.displacement.data() + 3 * body.begin;
  double* out = x.data();
#pragma omp parallel for schedule(static) if (n3 > 3 * kOmpMinParticles)
  for (long q = 0; q < n3; ++q) out[q] = X[q] + u[q];
}

std::vector<double> damage(const BodyContext& body) {
  const auto& b = body.bonds;
  const auto& p = body.particles;
  std::vector<double> out(body.end - body.begin, 0.0);
  for (std::size_t i = 0; i < out.size(); ++i) {
    double full = 0.0, intact = 0.0;
    for (std::size_t k = b.offset[i]; k < b.offset[i + 1]; ++k) {
      const double w = b.volumeFraction[k] * p.volume[b.neighbor[k]];
      full += w;
      if (!b.broken[k]) intact += w;
    }
    out[i] = full > 0.0 ? 1.0 - intact / full : 0.0;
  }
  return out;
}

}  // namespace cosim::pd
