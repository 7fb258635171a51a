#pragma once
// The discrete model: mesh, material, element formulation, masses, boundary
// conditions and loads. It evaluates global internal forces (OpenMP over
// coloured element blocks that scatter without atomics, in an order that does
// not depend on the thread count) and assembles tangents into a fixed sparse
// pattern the same way.
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/fem/element_formulation.hpp"
#include "cosim/fem/material/material.hpp"
#include "cosim/fem/mesh/mesh.hpp"
#include "cosim/util/weight_profile.hpp"

namespace cosim::fem {

class SparseSystem;

/// A prescribed degree of freedom: displacement value(t) = amplitude * min(t / ramp, 1)
/// (ramp 0 = applied at once), or a constant velocity (u = amplitude * t).
/// frequency > 0 makes the time function a sine instead (cyclic loading, e.g.
/// the sinusoidal end displacement of Liu 2016 Sec. 3.3): kind displacement
/// u = amplitude sin(2 pi f t), v = u'; kind velocity v = amplitude sin(2 pi f t),
/// u = its integral from 0, amplitude (1 - cos(2 pi f t)) / (2 pi f). Both start
/// from u = 0 at t = 0; ramp is then unused (refused together in the scene).
struct Prescribed {
  enum class Kind { displacement, velocity };
  std::size_t dof = 0;
  Kind kind = Kind::displacement;
  double amplitude = 0.0;
  double ramp = 0.0;
  double frequency = 0.0;  // [Hz]; 0: the ramp / constant-rate functions above
  double displacement(double t) const;
  double velocity(double t) const;
};

/// A periodic tie resolved to one dof: u[dof] = u[master] + jump(t), where
/// master is an independent dof (free or prescribed) and the jump has the time
/// function of Prescribed (amplitude = the jump component).
struct SlaveDof {
  std::size_t dof = 0, master = 0;
  Prescribed jump;
};

/// Arlequin weight profile w(x): the formula shared with DEM and the coupler.
using WeightProfile = util::WeightProfile;

struct Energies {
  double kinetic = 0.0;
  double strain = 0.0;
  double hourglass = 0.0;
  double externalWork = 0.0;
  double viscousDissipated = 0.0;  // work of the viscous element forces (explicit)
};

class Model {
 public:
  Model(Mesh mesh, std::unique_ptr<Material> material, std::unique_ptr<ElementFormulation> formulation,
        const FormulationOptions& options = {});

  const Mesh& mesh() const { return mesh_; }
  const Material& material() const { return *material_; }
  Material& material() { return *material_; }
  const ElementFormulation& formulation() const { return *formulation_; }
  std::size_t numNodes() const { return mesh_.numNodes(); }
  std::size_t numDofs() const { return 3 * mesh_.numNodes(); }

  // --- boundary conditions ---------------------------------------------------
  void prescribe(Index node, int direction, Prescribed::Kind kind, double amplitude, double ramp = 0.0,
                 double frequency = 0.0);
  const std::vector<Prescribed>& prescribed() const { return prescribed_; }
  bool isFixed(std::size_t dof) const { return fixed_[dof] != 0; }
  /// Free-dof numbering: index into the reduced system, or -1 when prescribed.
  /// A periodic slave dof carries its master's index (master-slave
  /// elimination: assembly through this map sums slave rows and columns onto
  /// the master, i.e. forms T^T K T for u = T u_independent + jump).
  const std::vector<int>& dofMap() const {
    refreshDofMap();
    return dofMap_;
  }
  int numFree() const {
    refreshDofMap();
    return numFree_;
  }

  // --- periodic constraints --------------------------------------------------
  /// Ties every dof of each node `slave` to node `master`: u_slave = u_master + jump(t)
  /// (jump with the time function of Prescribed: ramp, or constant rate for
  /// kind velocity). Chains (corners of two periodic directions) resolve to
  /// one independent dof; a prescribed dof is always the independent one. A
  /// tie between two prescribed dofs is dropped (the prescriptions win).
  /// Throws InputError for inconsistent ties (a closed loop with a nonzero
  /// net jump, or jumps with different time functions meeting at one node).
  /// pairs: (slave, master) node ids, e.g. from matchPeriodicNodes.
  void tie(const std::vector<std::pair<Index, Index>>& pairs, const Vec3& jump,
           Prescribed::Kind kind = Prescribed::Kind::displacement, double ramp = 0.0);
  const std::vector<SlaveDof>& slaves() const {
    refreshDofMap();
    return slaves_;
  }
  /// Sets prescribed dofs, then slave dofs from their masters, at time t
  /// (velocities too when v is given).
  void applyConstraints(double t, std::vector<double>& u, std::vector<double>* v) const;
  /// Slave dofs only: u_s = u_m + jump(t), v_s = v_m + jump'(t).
  void enforceSlaves(double t, std::vector<double>& u, std::vector<double>* v) const;
  /// Full (3 per node) vector into the reduced one: entries of slave dofs are
  /// summed onto their master (T^T f), prescribed dofs dropped.
  void reduce(const std::vector<double>& full, Eigen::VectorXd& reduced) const;
  /// Explicit update with the lumped mass: the net force r (3 per node) and
  /// masses of slaves are summed onto their masters, a = sum r / sum m there,
  /// slaves copy their master's a, prescribed dofs get 0. Returns |T^T r|^2
  /// over the free dofs.
  double constrainedAcceleration(const std::vector<double>& r, std::vector<double>& a) const;
  /// Lumped mass per dof after elimination: slave masses summed onto their
  /// masters, 0 on slave dofs (sum unchanged: mass is conserved).
  std::vector<double> constrainedLumpedMass() const;
  /// Applied forces of the constrained system: with res = (inertia + f_int -
  /// f_ext) per dof, a slave's constraint force res_s acts on it and -res_s
  /// on its free master (their work is res_s * d jump).
  void addTieReactions(const std::vector<double>& res, std::vector<double>& fApplied) const;

  // --- loads -----------------------------------------------------------------
  /// Dead nodal loads scaled by min(t / loadRamp, 1).
  std::vector<double>& referenceLoad() { return referenceLoad_; }
  void setLoadRamp(double ramp) { loadRamp_ = ramp; }
  /// Adds int N^T t dA over a face set (constant traction in the reference configuration).
  void addTraction(const std::vector<Quad>& faces, const Vec3& traction);
  /// A pressure on a face set that follows the deformed face (acts along the
  /// current inward normal; a constant confining pressure on a moving face).
  void addPressure(const std::vector<Quad>& faces, double pressure);
  /// Adds the follower loads at displacement u to f (scaled like dead loads).
  void addFollowerLoads(double t, const std::vector<double>& u, std::vector<double>& f) const;
  bool hasFollowerLoads() const { return !pressures_.empty(); }
  /// Adds int N^T rho g dV over the whole body.
  void addBodyForce(const Vec3& acceleration);
  /// Nodal forces supplied from outside for the current step (coupling).
  std::vector<double>& couplingForce() { return couplingForce_; }
  void externalForce(double t, std::vector<double>& f) const;

  // --- element loops ---------------------------------------------------------
  /// Velocity-proportional element forces (viscous hourglass control of the
  /// one-point element) at velocity v, 3 per node; false (f zero) when the
  /// formulation has none.
  bool viscousForce(const std::vector<double>& v, std::vector<double>& f) const;
  /// Internal force (3 per node) and energies at displacement u.
  void internalForce(const std::vector<double>& u, std::vector<double>& f, ElementEnergy& energy) const;
  /// Tangent (free-free block) and internal force; the system must have been built for this model.
  void assembleTangent(const std::vector<double>& u, SparseSystem& K, std::vector<double>& f,
                       ElementEnergy& energy) const;
  /// Small-strain linear elasticity about the reference configuration: K_0
  /// (the tangent at u = 0, free-free block) and f = K_0 u on all dofs
  /// (prescribed ones get their reactions), strain energy u . f / 2.
  void assembleLinearStiffness(const std::vector<double>& u, SparseSystem& K, std::vector<double>& f,
                               ElementEnergy& energy) const;
  /// Consistent mass into a system with the same pattern.
  void assembleMass(SparseSystem& M) const;
  /// K_0 + massFactor M on the free dofs, built here: the system matrix of
  /// linear elastodynamics under Newmark (massFactor = 1 / (beta dt^2)).
  SparseSystem shiftedStiffness(double massFactor) const;
  /// y = M x with the consistent mass (lumped when lumped = true), all dofs.
  void massTimes(const std::vector<double>& x, std::vector<double>& y, bool lumped) const;
  double kineticEnergy(const std::vector<double>& v, bool lumped) const;
  /// Lumped (row-sum) mass per node.
  const std::vector<double>& lumpedMass() const { return lumpedMass_; }
  /// Weights every element integral (mass, internal and body forces) by
  /// 1 - w(X) at its material points (Cheng 2022 Eq. 25); surface tractions
  /// stay unweighted. Throws naming a node left without mass.
  void setArlequinWeight(const WeightProfile& profile);
  /// Reference position of material point q of element e: the element centre
  /// for one-point quadrature, else Gauss point q.
  Vec3 materialPoint(std::size_t e, int q) const;
  /// Multiplies all masses (mass scaling for explicit steps).
  void setMassScale(double s);
  double massScale() const { return massScale_; }
  /// Largest stable central-difference step from element eigenvalues with the
  /// lumped mass (Irons' bound), reduced for mass-proportional damping alpha
  /// [1/s] by Liu 2016 Eq. 65.
  double criticalTimeStep(double dampingAlpha = 0.0) const;
  /// Element displacement matrix (8 x 3) from a global vector.
  Mat83 gather(std::size_t e, const std::vector<double>& u) const;

  /// Throws SolveError naming the dof and node for the first non-finite value.
  void checkFinite(const std::vector<double>& x, const std::string& what) const;

 private:
  /// Splits the elements into contiguous blocks and colours them so that
  /// blocks of one colour share no node (greedy colouring of the block
  /// adjacency graph).
  void colourElementBlocks();
  /// Runs kernel(block, first, last) over every element block, colour after
  /// colour; the blocks of a colour run in parallel when `parallel` holds.
  /// Blocks of one colour touch disjoint nodes, so kernels scatter straight
  /// into global vectors without atomics, and every node receives its element
  /// contributions in one fixed order (colour, then element) whatever the
  /// thread count: results are bit-for-bit reproducible.
  template <class Kernel>
  void forEachElementBlock(bool parallel, Kernel&& kernel) const;
  /// Tangent (linear = false) or K_0 (linear = true) and the matching internal force.
  void assemble(const std::vector<double>& u, bool linear, SparseSystem& K, std::vector<double>& f,
                ElementEnergy& energy) const;
  /// Adds the element vector fe (24, node-major xyz) of element e into f (3 per node).
  void scatter(std::size_t e, const Vec24& fe, std::vector<double>& f) const;
  /// Renumbers the free dofs and resolves the ties: O(dofs), so prescribe()
  /// only marks the numbering stale (clamping a face node by node would
  /// otherwise cost O(dofs^2)) and the accessors renumber on first use.
  void rebuildDofMap() const;
  void refreshDofMap() const {
    if (dofMapStale_) rebuildDofMap();
  }
  struct Tie {
    Index slave, master;
    Vec3 jump;
    Prescribed::Kind kind;
    double ramp;
  };
  std::vector<Tie> ties_;
  mutable std::vector<SlaveDof> slaves_;
  void computeMass();
  /// 1 - w at the 2x2x2 Gauss points of element e (1 without a profile).
  double massWeight(std::size_t e, int q) const;
  const double* gaussScale(std::size_t e) const;
  Mesh mesh_;
  std::unique_ptr<Material> material_;
  std::unique_ptr<ElementFormulation> formulation_;
  std::vector<char> fixed_;
  std::vector<Prescribed> prescribed_;
  mutable std::vector<int> dofMap_;
  mutable int numFree_ = 0;
  mutable bool dofMapStale_ = false;
  std::vector<double> referenceLoad_, couplingForce_;
  double loadRamp_ = 0.0;
  std::vector<std::pair<std::vector<Quad>, double>> pressures_;
  std::vector<double> lumpedMass_, unscaledLumpedMass_;
  double massScale_ = 1.0;
  std::vector<double> gaussWeight_;  // 1 - w at the 8 Gauss points of each element, empty = 1
  std::vector<double> bodyAcceleration_;
  std::vector<std::size_t> colourStart_;            // blocks of colour c: colourBlocks_[colourStart_[c] ...]
  std::vector<std::size_t> colourBlocks_;           // block ids grouped by colour, ascending within a colour
  mutable std::vector<ElementEnergy> blockEnergy_;  // energy of each element block (summed in block order)
  mutable std::vector<double> reducedForce_;        // constrainedAcceleration buffer
  // Consistent element mass matrices (8 x 8 per element, scaled): constant in a
  // total Lagrangian model, so built once and rebuilt when the mass scale or the
  // Arlequin weights change. massTimes runs every Newmark iteration.
  const Eigen::Matrix<double, 8, 8>& elementMassMatrix(std::size_t e) const;
  mutable std::vector<Eigen::Matrix<double, 8, 8>> elementMass_;
};

}  // namespace cosim::fem
