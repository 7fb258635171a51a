#pragma once
// Time integrators over a Model: implicit Newmark-beta with Newton on the
// consistent tangent, explicit central difference with lumped mass, and a
// static Newton solve (load steps).
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/linalg/sparse_system.hpp"
#include "cosim/fem/model/model.hpp"

namespace cosim::fem {

/// The full kinematic state; what a checkpoint stores.
struct State {
  std::vector<double> u, v, a;  // 3 per node
  std::vector<double> fApplied; // external + reaction forces at the last step (work integral)
  std::vector<double> fViscous; // viscous hourglass forces at the last step (dissipation integral)
  double time = 0.0;
  std::uint64_t step = 0;
  double externalWork = 0.0;
  double viscousDissipated = 0.0;
  // u at the start of the step the explicit integrator is in. Between a split
  // step's predict() and correct() (GMH: the coupler's exchange, and any
  // checkpoint taken there) correct() needs it for the step's work.
  std::vector<double> uStepStart;
  void resize(std::size_t dofs) {
    u.assign(dofs, 0.0);
    v.assign(dofs, 0.0);
    a.assign(dofs, 0.0);
    fApplied.assign(dofs, 0.0);
    fViscous.assign(dofs, 0.0);
  }
};

struct NewtonOptions {
  double tolerance = 1e-10;   // on ||R_free|| / (||f_ext|| + ||f_int|| + ||M a||), all dofs
  int maxIterations = 25;
  std::string linearSolver = "direct";
  double displacementTolerance = 1e-12;  // on ||du|| / ||u - u_start of the solve||
  // Modified Newton: keep the factorised tangent across iterations and steps,
  // refreshing it when a solve needs more than this many iterations (0 = full
  // Newton, a fresh tangent every iteration). Same converged answer, since only
  // the residual decides convergence; far cheaper for small strain increments.
  int tangentReuse = 0;
};

/// Newton convergence record of the last solve (residual history).
struct NewtonReport {
  int iterations = 0;
  std::vector<double> residuals;
};

class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual std::string name() const = 0;
  /// Prepares the state at its current time (initial acceleration, prescribed values).
  virtual void initialise(State& state) = 0;
  virtual void step(State& state, double dt) = 0;
  /// Split step for stresses supplied from outside (GMH): predict() moves the
  /// positions to t + dt, correct() then evaluates forces with the stresses
  /// received for those positions and completes the velocities. Only the
  /// explicit integrator supports it.
  virtual void predict(State& state, double dt);
  virtual void correct(State& state, double dt);
  /// Largest stable step; 0 when unconditionally stable.
  virtual double criticalDt() const { return 0.0; }
  /// Energies of the state (kinetic uses the integrator's mass).
  virtual Energies energies(const State& state) const;
  const NewtonReport& lastNewton() const { return report_; }

 protected:
  explicit Integrator(Model& model) : model_(model) {}
  void applyPrescribed(State& state, double t) const;
  /// Trapezoidal external work with the applied forces of the new step.
  void accumulateWork(State& state, const std::vector<double>& uOld, const std::vector<double>& fNew) const;
  Model& model_;
  NewtonReport report_;
  bool lumpedMass_ = false;
};

struct NewmarkOptions {
  double beta = 0.25;
  double gamma = 0.5;
  bool lumpedMass = false;
  // Small-strain linear elasticity: f_int = K_0 u with the tangent at the
  // reference configuration, factorised once per dt, one solve per step. For
  // loads whose strains and rotations are small (the C1 cantilever: rotations
  // below 0.04 rad), where the finite-strain solve costs 50-100 times more.
  bool linear = false;
  NewtonOptions newton;
};

struct CentralDifferenceOptions {
  double damping = 0.0;  // mass-proportional alpha [1/s]
};

/// Throws InputError when the model has velocity-dependent element forces
/// (viscous hourglass control), which only the explicit integrator applies.
void requireNoViscousForces(const Model& model, const std::string& solver);

std::unique_ptr<Integrator> makeNewmark(Model& model, const NewmarkOptions& options);
std::unique_ptr<Integrator> makeCentralDifference(Model& model, const CentralDifferenceOptions& options);

struct RelaxationOptions {
  double tolerance = 1e-6;     // unbalanced-force ratio
  int maxIterations = 200000;
};

/// Quasi-static equilibrium at state.time by dynamic relaxation (kinetic
/// damping); throws SolveError with the history when it does not converge.
NewtonReport relaxStatic(Model& model, State& state, const RelaxationOptions& options);

/// Static equilibrium at state.time by Newton (load increments of the load
/// factor when steps > 1). Throws SolveError with the residual history.
NewtonReport solveStatic(Model& model, State& state, const NewtonOptions& options, int loadSteps = 1);

/// Small-strain linear statics at state.time: K_0 u = f_ext with K_0 the
/// tangent at the reference configuration, prescribed values applied (one
/// factorisation, one solve; for loads whose strains and rotations are small,
/// where the finite-strain Newton solve assembles and factorises at least
/// twice). Residuals: relative before and after the solve.
NewtonReport solveLinearStatic(Model& model, State& state, const std::string& linearSolver = "direct");

}  // namespace cosim::fem
