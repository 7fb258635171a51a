#pragma once
// Element formulations of the eight-node hexahedron behind one interface
// (full 2x2x2 Gauss, incompatible modes, one-point with hourglass control).
// A formulation precomputes what it needs per element at initialise() and
// then evaluates internal force, tangent and energies from nodal
// displacements (total Lagrangian: everything refers to the reference mesh).
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/material/material.hpp"
#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/fem/registry.hpp"
#include "cosim/fem/types.hpp"

namespace cosim::fem {

struct FormulationOptions {
  /// One-point quadrature: stiffness type (f = k Gamma Gamma^T u) or viscous
  /// type (f = c Gamma Gamma^T v), Flanagan & Belytschko 1981.
  enum class Hourglass { stiffness, viscous };
  Hourglass hourglassType = Hourglass::stiffness;
  double hourglassCoefficient = 0.05;
  /// One-point quadrature: stiffness-proportional (Rayleigh) damping beta [s],
  /// a viscous element stress beta C : D with C the material's small-strain
  /// elasticity and D the element's rate of deformation; 0 = none.
  double stiffnessDamping = 0.0;
};

struct ElementEnergy {
  double strain = 0.0;
  double hourglass = 0.0;
};

/// State at one material point, for output and external materials.
struct MaterialPointState {
  Mat3 F;  // deformation gradient
  Mat3 S;  // second Piola-Kirchhoff stress
};

class ElementFormulation {
 public:
  static std::string registryKind() { return "element formulation"; }
  virtual ~ElementFormulation() = default;
  virtual std::string name() const = 0;
  /// Precomputes reference geometry; throws InputError naming an inverted element.
  virtual void initialise(const Mesh& mesh, const Material& material, const FormulationOptions& options) = 0;
  /// Internal force fe (24, node-major xyz), optional tangent, energies.
  virtual void evaluate(std::size_t e, const Mat83& ue, Vec24& fe, Mat24* Ke, ElementEnergy& energy) const = 0;
  virtual int pointsPerElement() const = 0;
  /// Velocity-proportional element forces (viscous hourglass control, stiffness damping).
  virtual bool hasViscousForce() const { return false; }
  /// Rayleigh beta [s] of the stiffness damping these forces include (0: none);
  /// the model's critical step takes its damping fraction from it (Liu Eq. 65).
  virtual double stiffnessDamping() const { return 0.0; }
  /// Element force fe (24) at nodal velocities ve; zero without viscous forces.
  virtual void viscousForce(std::size_t, const Mat83&, Vec24& fe) const { fe.setZero(); }
  /// Material point states of element e (pointsPerElement() entries).
  virtual void pointStates(std::size_t e, const Mat83& ue, MaterialPointState* out) const = 0;

  /// Multiplies every material-point integral by a factor (Arlequin 1 - w at
  /// the point, Cheng 2022 Eq. 25); pointsPerElement() factors per element,
  /// empty = 1 everywhere.
  void setPointScale(std::vector<double> scale) { pointScale_ = std::move(scale); }
  double pointScale(std::size_t e, int q) const {
    return pointScale_.empty() ? 1.0
                               : pointScale_[e * static_cast<std::size_t>(pointsPerElement()) + static_cast<std::size_t>(q)];
  }

 private:
  std::vector<double> pointScale_;
};

using FormulationRegistry = Registry<ElementFormulation>;

}  // namespace cosim::fem
