#pragma once
// The FEM solver behind the wire: reads its `params:` section of the scene,
// builds the model, advances it with the configured integrator, and answers
// fields, energies, critical step, checkpoint and restore.
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/model/model.hpp"
#include "cosim/fem/time/integrator.hpp"
#include "cosim/wire/solver.hpp"

namespace cosim::fem {

class ParamMap;

class SnapshotWriter;
class ExternalStressMaterial;
class SurfaceExport;
class VolumeZone;

class FemSolver final : public wire::Solver {
 public:
  FemSolver();
  ~FemSolver() override;
  wire::SolverInfo info() const override;
  void setup(const wire::SetupContext& context, proto::CouplingData::Builder outputs) override;
  void advance(const wire::AdvanceRequest& request, proto::CouplingData::Builder outputs) override;
  void fields(const std::vector<std::string>& names, proto::CouplingData::Builder out) override;
  std::uint64_t checkpoint(const std::string& path) override;
  void restore(const std::string& path) override;
  double time() const override { return state_.time; }
  std::uint64_t step() const override { return state_.step; }
  double criticalDt() const override;
  wire::NamedValues energies() const override;
  std::size_t outputWordsHint() const override;

  // In-process access for tests and benchmarks.
  const Model& model() const { return *model_; }
  const State& state() const { return state_; }
  /// Writes a snapshot now (HDF5 + XDMF sidecar) when output is configured.
  void writeSnapshot();

 private:
  void applyCouplingForces(proto::CouplingData::Reader inputs);
  /// Coupling exports; atSetup: the setup reply (the only one a `quadrature: setup` export goes with).
  void fillCouplingOutputs(proto::CouplingData::Builder outputs, bool atSetup) const;
  /// `boundary:` list: prescribed displacements or velocities of node sets.
  void readBoundary(ParamMap& p);
  /// `periodic:` list: node pairs of opposite faces tied with an optional jump.
  void readPeriodic(ParamMap& p);
  /// GMH: stresses of unit-cell results into the external material.
  void applyUnitCellResults(proto::CouplingData::Reader inputs);
  /// GMH: deformation gradients at all material points (9 per point, row-major).
  std::vector<double> pointDeformationGradients() const;
  void fillUnitCellJobs(proto::CouplingData::Builder outputs, double dt);
  std::unique_ptr<Model> model_;
  std::unique_ptr<Integrator> integrator_;
  State state_;
  std::string integratorType_;
  bool force_ = false;
  NewtonOptions staticNewton_;
  bool staticLinear_ = false;  // static: small-strain linear (K_0 u = f_ext)
  RelaxationOptions relaxation_;
  int outputEvery_ = 0;
  std::unique_ptr<SnapshotWriter> snapshots_;
  std::vector<SurfaceExport> surfaces_;
  std::vector<VolumeZone> zones_;
  enum class QuadratureExport { None, SetupOnly, EveryExchange };
  QuadratureExport surfaceQuadrature_ = QuadratureExport::None;
  ExternalStressMaterial* external_ = nullptr;  // owned by the model
  std::vector<double> pointF_;                  // F at the last exchange (GMH)
  // Initial velocity v = v0 + L (X - origin), e.g. a homogeneous simple shear
  // that starts without a front running in from the driven boundary.
  struct InitialVelocity {
    Vec3 v0 = Vec3::Zero(), origin = Vec3::Zero();
    Mat3 gradient = Mat3::Zero();
  };
  InitialVelocity initialVelocity_;
  double pendingDt_ = 0.0;                      // GMH: a predicted step awaits its stresses
};

}  // namespace cosim::fem
