#pragma once
// A set of peridynamic bodies with boundary conditions, body forces and
// applied loads, advanced by velocity Verlet (leapfrog, Hartmann Eq. 44), the
// staggered two-kick update of hybrid particles (Eq. 47) or adaptive dynamic
// relaxation for quasi-static loading.
#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cosim/pd/body.hpp"
#include "cosim/pd/bonds.hpp"
#include "cosim/pd/correspondence.hpp"
#include "cosim/pd/model.hpp"
#include "cosim/pd/particles.hpp"

namespace cosim::pd {

struct Body {
  BodySpec spec;
  std::size_t begin = 0, end = 0;
  double spacing = 0.0;
  double horizon = 0.0;
  Bonds bonds;
  std::unique_ptr<PdModel> model;
};

/// Particles picked by a box of reference positions and/or a body name.
struct Selection {
  bool hasBox = false;
  Vec3 min{}, max{};
  std::string body;  // empty = any body
};

enum class Constraint { Fixed, Velocity, NormalOnly };

struct BoundaryCondition {
  Selection where;
  Constraint type = Constraint::Fixed;
  Vec3 velocity{};                     // prescribed velocity
  std::vector<std::uint32_t> particles;  // resolved at finalise()
  std::vector<double> normals;           // NormalOnly: 3 per particle
};

/// A total force spread over a particle set in proportion to volume.
struct AppliedLoad {
  Selection where;
  Vec3 force{};
  std::vector<std::uint32_t> particles;
};

struct Energies {
  double kinetic = 0.0;
  double strain = 0.0;
  double externalWork = 0.0;
};

/// An input error finalise() ties to one entry: a body, boundary condition or
/// load, by its index in the order added (so a scene reader can name its line).
class EntryError : public std::invalid_argument {
 public:
  enum class Entry { Body, Boundary, Load };
  EntryError(Entry entry, std::size_t index, const std::string& what)
      : std::invalid_argument(what), entry_(entry), index_(index) {}
  Entry entry() const { return entry_; }
  std::size_t index() const { return index_; }

 private:
  Entry entry_;
  std::size_t index_;
};

class PdSystem {
 public:
  /// Discretises and appends a body; throws std::invalid_argument naming the
  /// body for bad sizes, and for overlap with a body added before.
  std::size_t addBody(const BodySpec& spec);
  /// Appends a body from given points (volumes > 0).
  std::size_t addBody(const BodySpec& spec, const PointCloud& cloud);
  void addBoundaryCondition(BoundaryCondition bc) { bcs_.push_back(std::move(bc)); }
  void addLoad(AppliedLoad load) { loads_.push_back(std::move(load)); }
  void setBodyForce(const Vec3& g) { gravity_ = g; }
  /// Builds neighbour lists, initialises models, resolves particle sets and
  /// computes the initial forces. Call once after adding everything. Throws
  /// EntryError for a particle with no partner within its horizon, a model
  /// option a model refuses, or a particle set that selects nothing.
  void finalise();

  /// Coupling forces (e.g. DEM contact on hybrid particles), 3 per particle,
  /// added to the external force from the next force evaluation on.
  std::vector<double>& couplingForce() { return coupling_; }
  /// A coupling force that follows its particle over the sub-steps of one
  /// request instead of being held: f = F - K (x - x_F), with F the particle's
  /// couplingForce, x_F where F was evaluated and K = -df/dx (xx yy zz xy xz yz).
  struct LinearisedCoupling {
    std::uint32_t particle = 0;
    std::array<double, 3> position{};
    std::array<double, 6> stiffness{};
  };
  /// Empty: coupling forces are held (Hartmann Alg. 2).
  std::vector<LinearisedCoupling>& linearisedCoupling() { return linearised_; }

  /// One velocity-Verlet step (Hartmann Eq. 44 in its synchronised form).
  void step(double dt) {
    beginStep(dt);
    completeStep(dt);
  }
  /// The first half of step(dt) ahead of the coupling force that ends it:
  /// the half kick, the drift and the peridynamic forces at the new
  /// positions, which depend on the state alone. With the end-of-step
  /// coupling (monolithic Verlet, docs/pd_dem_coupling.md) PdSolver runs it
  /// while DEM evaluates that force at those positions. The state before it
  /// is kept (swapped buffers, no copies) for cancelLookAhead. Does nothing
  /// and returns false where a body's bonds may break: a broken bond cannot
  /// be taken back.
  bool lookAhead(double dt);
  /// Ends the step lookAhead(dt) began, with the coupling force now set:
  /// bitwise what step(dt) gives from the state before lookAhead.
  void completeLookAhead();
  /// Returns to the state before lookAhead, bitwise (nothing pending: no-op).
  void cancelLookAhead();
  /// The step a pending lookAhead began; 0 when none is pending.
  double lookAheadStep() const { return aheadDt_; }
  /// Particle i's velocity for the next step's drift if the forces stay
  /// those of the state: v + dt/2 (f_int + f_ext) / m, its boundary
  /// conditions applied (one particle: PdSolver sends the hybrids' alone).
  void driftVelocity(double dt, std::size_t i, double out[3]) const;
  /// One staggered step (Hartmann Eq. 47): coupling and body-force kick and
  /// drift first, then peridynamic forces at the updated positions, second kick.
  void stepStaggered(double dt);
  /// Adaptive dynamic relaxation (Kilic & Madenci 2010) until the residual
  /// force norm is below tolerance times the external force norm; returns the
  /// iterations used (maxIterations when not converged).
  std::size_t relax(double tolerance, std::size_t maxIterations);

  /// Stable step of velocity Verlet, after Hartmann Eqs. 41-42 with the
  /// horizon as the length: min over bodies of 0.45 delta / c_p (verlet.cpp),
  /// or of the measured steps once measureCriticalSteps ran.
  double criticalTimeStep() const;
  /// Replaces the rule by safety x 2 / omega_max of each body, omega_max by
  /// power iteration at the current configuration (critical_step.cpp);
  /// bodies with the same spectrum share one iteration.
  void measureCriticalSteps(double safety);
  bool criticalStepsMeasured() const { return !measuredStep_.empty(); }
  /// Verlet's limit 2 / omega_max of body b, by power iteration.
  double verletLimit(std::size_t b);
  Energies energies() const;
  double time() const { return time_; }
  std::uint64_t stepCount() const { return step_; }
  void setTime(double t, std::uint64_t step) { time_ = t; step_ = step; }
  double& externalWork() { return work_; }

  Particles& particles() { return particles_; }
  const Particles& particles() const { return particles_; }
  std::vector<Body>& bodies() { return bodies_; }
  const std::vector<Body>& bodies() const { return bodies_; }
  BodyContext context(std::size_t body) const;
  std::vector<std::uint32_t> select(const Selection& where) const;
  const std::vector<BoundaryCondition>& boundaryConditions() const { return bcs_; }

  /// Recomputes internal and external forces at the current configuration
  /// (breaking bonds first where a model has damage).
  void computeForces();
  /// Re-evaluates only the external force (after new coupling forces arrive).
  void updateExternalForces() { computeExternal(); }
  /// Per-particle damage and correspondence fields over all bodies.
  std::vector<double> damageField() const;
  CorrespondenceFields correspondenceFields() const;

  /// Internal state a checkpoint must carry beyond particles and bonds.
  std::vector<double>& previousExternalForce() { return externalPrev_; }

 private:
  void buildBody(std::size_t b);
  std::vector<std::uint32_t> resolve(const Selection& where, EntryError::Entry entry, std::size_t index) const;
  void computeExternal();
  void computeInternal();
  /// Whether bond loops run body by body on threads (many similar bodies).
  bool sharesBodiesOut() const;
  void addLinearisedChange(const LinearisedCoupling& c, std::vector<double>& f) const;
  void applyConstraints();
  /// Lists each particle's boundary-condition entries (finalise).
  void indexConstraints();
  /// Applies the boundary conditions to a velocity field.
  void constrain(std::vector<double>& v) const;
  /// Applies entry q of boundary condition bc to its particle's velocity v (3 values).
  static void constrainEntry(const BoundaryCondition& bc, std::size_t q, double* v);
  /// Particle i's boundary conditions, in their order, on its velocity v (3 values).
  void constrainParticle(std::size_t i, double* v) const;
  /// Half kick and drift into the spare buffers, swapped in; then the
  /// peridynamic forces at the new positions (the old ones are kept).
  void beginStep(double dt);
  /// Coupling and applied forces, the work of the external forces, the
  /// second half kick.
  void completeStep(double dt);

  Particles particles_;
  std::vector<Body> bodies_;
  std::vector<BoundaryCondition> bcs_;
  std::vector<AppliedLoad> loads_;
  Vec3 gravity_{};
  std::vector<double> coupling_;
  std::vector<LinearisedCoupling> linearised_;
  std::vector<double> externalPrev_;
  std::vector<double> velocityBefore_;  // stepStaggered scratch: v_{n-1/2} of the kicked particles
  // Each particle's boundary-condition entries (condition, position in its
  // list) in the conditions' order, rows by particle (built at finalise).
  std::vector<std::uint32_t> constraintOffset_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> constraintEntry_;
  // The state before beginStep (velocity, displacement, internal force): the
  // buffers the step wrote into before the swap.
  std::vector<double> beforeVelocity_, beforeDisplacement_, beforeInternal_;
  double aheadDt_ = 0.0;  // the step a pending lookAhead began
  double time_ = 0.0;
  std::uint64_t step_ = 0;
  double work_ = 0.0;
  std::vector<double> measuredStep_;  // per body, empty: the rule
  bool finalised_ = false;
};

}  // namespace cosim::pd
