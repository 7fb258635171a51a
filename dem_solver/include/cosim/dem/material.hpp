#pragma once
// Material parameters per particle (or wall) material, and the effective
// pair properties a contact law needs, computed once per material pair.
#include <cstdint>
#include <string>
#include <vector>

namespace cosim::dem {

struct Material {
  std::string name = "default";
  double density = 2500.0;      // [kg/m^3]
  double young = 1e9;           // [Pa]  (Hertz-Mindlin)
  double poisson = 0.25;
  double restitution = 1.0;     // requested normal coefficient of restitution
  double friction = 0.0;        // Coulomb coefficient mu
  double kn = 0.0;              // [N/m] linear normal spring
  double kt = 0.0;              // [N/m] linear tangential spring
  double shearModulus() const { return young / (2.0 * (1.0 + poisson)); }
};

/// Effective properties of a contact between materials a and b.
struct PairMaterial {
  double eEff = 0.0;         // E*, Hertz effective modulus
  double gEff = 0.0;         // G*, Mindlin effective shear modulus
  double friction = 0.0;
  double restitution = 1.0;
  double kn = 0.0, kt = 0.0;
  double gamma = 0.0;        // damping coefficient of F_d = -gamma sqrt(S m*) v, set by the damping law
  double mindlinDashpotRatio = 0.0;  // sqrt(k_t / S_n) = sqrt(4 G*/E*) for Hertz-Mindlin
};

/// Combines two materials with the standard Hertz/Mindlin rules (see .cpp).
PairMaterial combine(const Material& a, const Material& b);

class MaterialTable {
 public:
  std::uint16_t add(const Material& m);
  std::uint16_t find(const std::string& name) const;  // throws if unknown
  const Material& operator[](std::size_t i) const { return materials_[i]; }
  std::size_t size() const { return materials_.size(); }
  /// Pair table, row-major by material index; rebuilt by the contact law's prepare().
  std::vector<PairMaterial>& pairs() { return pairs_; }
  const std::vector<PairMaterial>& pairs() const { return pairs_; }
  const PairMaterial& pair(std::uint16_t a, std::uint16_t b) const { return pairs_[a * materials_.size() + b]; }
  const std::vector<Material>& all() const { return materials_; }

 private:
  std::vector<Material> materials_;
  std::vector<PairMaterial> pairs_;
};

}  // namespace cosim::dem
