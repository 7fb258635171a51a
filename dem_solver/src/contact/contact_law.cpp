#include "cosim/dem/contact/contact_law.hpp"

#include "cosim/dem/contact/builtin_laws.hpp"

#include <cmath>
#include <numbers>

namespace cosim::dem {

ContactLaw::ContactLaw(const std::string& normal, const std::string& tangential, const std::string& damping)
    : normal_(NormalLawRegistry::create(normal, "normal contact law")),
      tangential_(TangentialLawRegistry::create(tangential, "tangential contact law")),
      damping_(DampingLawRegistry::create(damping, "damping law")),
      name_(normal + "/" + tangential + "/" + damping),
      hertzMindlin_(dynamic_cast<const HertzNormal*>(normal_.get()) &&
                    dynamic_cast<const MindlinTangential*>(tangential_.get())) {}

void ContactLaw::prepare(MaterialTable& table) const {
  auto& pairs = table.pairs();
  const std::size_t n = table.size();
  pairs.assign(n * n, {});
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < n; ++b) {
      PairMaterial p = combine(table[a], table[b]);
      p.gamma = damping_->coefficient(*normal_, p);
      pairs[a * n + b] = p;
    }
}

Vec3 ContactLaw::force(const Vec3& n, double overlap, const Vec3& vRel, double rEff, double mEff,
                       const PairMaterial& pm, double dt, Vec3& shear, double& dissipated) const {
  if (hertzMindlin_)
    return composedForce(static_cast<const HertzNormal&>(*normal_), static_cast<const MindlinTangential&>(*tangential_),
                         n, overlap, vRel, rEff, mEff, pm, dt, shear, dissipated);
  return composedForce(*normal_, *tangential_, n, overlap, vRel, rEff, mEff, pm, dt, shear, dissipated);
}

double ContactLaw::energy(double overlap, double rEff, const PairMaterial& pm, const Vec3& shear) const {
  return normal_->energy(overlap, rEff, pm) + 0.5 * tangential_->stiffness(overlap, rEff, pm) * norm2(shear);
}

double linearDampingCoefficient(double e) {
  if (e >= 1.0) return 0.0;
  const double le = std::log(e);
  return -2.0 * le / std::sqrt(std::numbers::pi * std::numbers::pi + le * le);
}

}  // namespace cosim::dem
