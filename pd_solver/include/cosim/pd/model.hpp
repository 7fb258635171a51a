#pragma once
#include "cosim/util/registry.hpp"
// Peridynamic force models (PdModel) behind a registry keyed by the name a
// scene uses ("pmb", "lps"). Adding a model is adding one file that registers
// itself with PD_REGISTER_MODEL.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cosim/pd/body.hpp"
#include "cosim/pd/bonds.hpp"
#include "cosim/pd/particles.hpp"

namespace cosim::pd {

/// What a model sees of one body.
struct BodyContext {
  const Particles& particles;
  const Bonds& bonds;
  std::size_t begin = 0, end = 0;  // particle range of the body
  const Material& material;
  double horizon = 0.0;
  double spacing = 0.0;
  const ModelOptions& options;
};

class PdModel {
 public:
  virtual ~PdModel() = default;
  virtual std::string name() const = 0;
  /// Precomputes reference quantities (weighted volumes, correction factors).
  virtual void initialise(const BodyContext& body) = 0;
  /// Writes the peridynamic force f^PD of every particle of the body into
  /// particles.internalForce (overwrites the body's range).
  virtual void computeForces(const BodyContext& body, std::vector<double>& force) = 0;
  /// Total strain energy of the body [J].
  virtual double strainEnergy(const BodyContext& body) const = 0;
  /// Strain energy density per particle [J/m^3] (size end - begin).
  virtual std::vector<double> energyDensity(const BodyContext& body) const = 0;
  /// Marks bonds that fail in the current configuration; returns how many broke.
  virtual std::size_t breakBonds(const BodyContext&, Bonds&) { return 0; }
  /// Whether breakBonds may break any bond of the body (a step computed ahead
  /// can only be taken back where none can, PdSystem::lookAhead).
  virtual bool mayBreakBonds(const BodyContext&) const { return false; }
  /// Stiffness bound per unit volume used by dynamic relaxation's fictitious density.
  virtual double stiffnessBound(const BodyContext& body, std::size_t particle) const = 0;
};

/// PD models register by the name a body's `model:` uses (the project's one registry).
using ModelRegistry = cosim::Registry<PdModel>;

#define PD_REGISTER_MODEL(NAME, TYPE)                                     \
  [[maybe_unused]] static const bool pdModelRegistration_##TYPE =         \
      ::cosim::pd::ModelRegistry::add(NAME, [] { return std::unique_ptr<::cosim::pd::PdModel>(new TYPE()); })

/// Influence function w<xi> of the LPS model, by name: "constant" (w = 1),
/// "inverse" (w = delta / |xi|), "gaussian" (w = exp(-|xi|^2 / delta^2)).
std::function<double(double, double)> influenceFunction(const std::string& name);

/// Current positions x = X + u of the body's particles (3 per particle,
/// body-local index). Rounded once, so a deformed bond x_j - x_i is exactly
/// -(x_i - x_j): both directions of a bond see the same |Y| and pair forces
/// cancel to round-off; the bond loops also read 3 values per partner, not 6.
void currentPositions(const BodyContext& body, std::vector<double>& x);

/// Writes particle i's force f^PD = V_I sum (...) V_J from its bond sum f.
inline void storeBondSum(std::vector<double>& force, const Particles& p, std::size_t i, const double f[3]) {
  for (int a = 0; a < 3; ++a) force[3 * i + a] = f[a] * p.volume[i];
}

/// Damage index per particle: 1 - (unbroken weighted family volume) / (full).
std::vector<double> damage(const BodyContext& body);

}  // namespace cosim::pd
