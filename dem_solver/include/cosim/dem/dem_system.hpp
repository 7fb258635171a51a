#pragma once
// The DEM model: particles, materials, the composed contact law, walls, the
// neighbour list and the integrator, advanced one step at a time. Everything a
// run needs is in here, so a checkpoint of this object is a full restart.
#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cosim/dem/bonds/bonded_spring.hpp"
#include "cosim/dem/contact/contact_law.hpp"
#include "cosim/dem/integrate/integrator.hpp"
#include "cosim/dem/material.hpp"
#include "cosim/dem/neighbor/neighbor_list.hpp"
#include "cosim/dem/particles.hpp"
#include "cosim/dem/periodic_cell.hpp"
#include "cosim/dem/walls/plane_wall.hpp"
#include "cosim/dem/walls/triangle_wall_group.hpp"

namespace cosim::dem {

/// Force on i and torque on j of one listed pair (zero when apart). The row
/// owner i sums its side in the pair loop; j gathers these afterwards.
struct PairForce {
  Vec3 force, torqueJ;
};

/// A plane that may touch a particle before the next neighbour build (DemSystem::planeNear).
struct PlaneCandidate {
  std::uint32_t particle, plane;
};

class DemSystem {
 public:
  DemSystem();
  Particles particles;
  MaterialTable materials;
  std::vector<PlaneWall> planes;
  std::vector<TriangleWallGroup> meshes;
  NeighborList neighbors;
  PeriodicCell cell;  // disabled unless a scene asks for it
  BondedSprings bonds;
  Vec3 gravity;
  double time = 0.0;
  std::uint64_t step = 0;
  double massDamping = 0.0;     // c of the mass damping force -c m v (dynamic relaxation, Liu 2016 Sec. 2.3.2) [1/s]
  double dissipated = 0.0;      // energy lost in dashpots and sliding [J]
  double externalWork = 0.0;    // work of moving walls, external forces and drives [J]
  double driveWork = 0.0;       // its share done by prescribed motion (driven particles, drives, hybrid PD particles) [J]
  /// Wall time of each phase of advance(), summed over the steps taken while
  /// `timing` is on (the DEM share of LAMMPS's Pair/Neigh/Modify breakdown).
  struct PhaseTimes {
    double open = 0.0;       // opening kick and drift, driven particles, moving walls [s]
    double neighbors = 0.0;  // rebuild test, neighbour list, wall candidates [s]
    double pairs = 0.0;      // pair loop: contact detection and pair forces [s]
    double gather = 0.0;     // per-particle force sums, wall contacts, closing kick [s]
    double close = 0.0;      // bonds, closing kick (when not fused), drive work [s]
    std::uint64_t particleSteps = 0;
  };
  bool timing = false;  // off: advance() reads no clock
  PhaseTimes phaseTimes;
  // Pairs kept out of the contact law besides bonded ones: hybrid PD particles
  // of one family (Hartmann 2022 Sec. 3.1). Applied by initialize().
  std::vector<std::pair<std::uint32_t, std::uint32_t>> excludedPairs;

  void setContactLaw(const std::string& normal, const std::string& tangential, const std::string& damping);
  void setIntegrator(const std::string& name);
  const ContactLaw& contactLaw() const { return *law_; }
  const std::array<std::string, 3>& contactLawNames() const { return lawNames_; }
  const std::string& integratorName() const { return integratorName_; }
  /// Pair table, wall histories, neighbour list and the forces at the current state.
  void initialize();
  /// One time step of size dt.
  void advance(double dt);
  /// Sets driven particle i's velocity from outside. The kinetic energy that
  /// changes by is work of the prescribed motion (driveWork, externalWork).
  void setDrivenVelocity(std::size_t i, const Vec3& v);
  /// Sets driven particle i's position and velocity from outside. Moving it
  /// against the force on it (contacts, walls and its weight) is work of the
  /// prescribed motion too, counted at the next force evaluation (advance).
  void setDrivenState(std::size_t i, const Vec3& x, const Vec3& v);
  /// Restarts the driven particles' work count from the current positions
  /// (after a restore: a checkpoint is written where the forces were evaluated).
  void markDrivenEvaluated();
  /// Forces and torques of the current positions and velocities. With
  /// closingKick > 0 each free particle is then kicked over closingKick
  /// (Integrator::fusedKick) as soon as its force is complete.
  void computeForces(double dt, double closingKick = 0.0);

  /// x_i - x_j of listed pair k of row i (nearest image in a periodic cell).
  Vec3 pairVector(std::size_t i, std::size_t k) const {
    const Vec3 d = particles.x[i] - particles.x[neighbors.partner[k]];
    return cell.enabled ? d - cell.shift(neighbors.image[k]) : d;
  }
  /// Maps positions into the periodic cell (between neighbour builds they may leave it).
  void wrapIntoCell();

  std::vector<PairForce> pairForce;           // parallel to neighbors.partner
  std::vector<std::vector<Vec3>> planeShear;  // [wall][particle] tangential history
  std::vector<std::vector<std::uint8_t>> planeTouch;  // [wall][particle] 1 while in contact
  std::vector<std::vector<Vec3>> planeContactForce;    // [wall][particle] force on the particle (valid while touching)
  // Bit w of planeNear[i]: plane w may touch particle i before the next
  // rebuild (closer than r_i + skin at the build; the particle and the plane
  // each move less than skin/2 before one). All bits: no pruning (periodic
  // cell, more than 64 planes). Marked with the neighbour list.
  std::vector<std::uint64_t> planeNear;
  /// Lists planeNear's (particle, plane) candidates in order for the force
  /// loop; called where planeNear is marked or restored (it is not stored).
  void indexPlaneCandidates();
  struct PlaneMark {
    Vec3 point, normal;
  };
  std::vector<PlaneMark> planesAtMark;  // each plane when planeNear was marked

 private:
  /// computeForces(), with the displacement part of the rebuild test already
  /// answered (by the opening pass) when movedBeyondSkin is not null.
  void forces(double dt, double closingKick, const bool* movedBeyondSkin);
  void pairForces(double dt);
  template <class Normal, class Tangential>
  void pairLoopFor(const Normal& normal, const Tangential& tangential, double dt);
  template <bool Periodic, class Normal, class Tangential>
  void pairLoop(const Normal& normal, const Tangential& tangential, double dt);
  void gatherForces(double dt, double closingKick);
  /// Work of the prescribed motion of driven particles since their last force
  /// evaluation: -(f_before + f_after) / 2 . (x - x_eval) - w m g . (x - x_eval)
  /// each, one trapezoid over the whole move (set from outside and moved
  /// with v alike), so exact for linear forces and second order otherwise.
  double drivenWorkSinceEvaluation();
  void addDriveWork(double work);
  /// Adds the tangential part of a driven particle's jump (its state set from
  /// outside less where DEM had moved it) to the history of its contacts.
  void carryJumpIntoHistory(std::size_t i, const Vec3& jump);
  // Each particle's position and force at the last force evaluation (read for driven ones).
  std::vector<Vec3> drivenEvalX_, drivenEvalF_;
  /// Thread t of nt starts the pair loop at this chunk of rows (equal shares of weighed work).
  std::size_t chunkOfPairShare(std::size_t t, std::size_t nt) const;
  /// Weighs each chunk's pair-loop work for the split: its listed pairs plus
  /// kContactWeight times its contacts of the last step (chunkContacts_).
  void weighChunks();
  static constexpr std::uint32_t kContactWeight = 4;
  /// Adds the time since the last lap to `phase` while a timed step runs.
  void lap(double PhaseTimes::*phase);
  bool timedStep_ = false;
  double lapStart_ = 0.0;
  /// Plane candidates of each particle, with the neighbour list (see planeNear).
  void markPlaneCandidates();
  /// True when a plane moved along its normal by more than limit since the candidates were marked.
  bool planesMovedBeyond(double limit) const;
  std::vector<Vec3> pairSumF_, pairSumT_;  // row sides of the pair forces, per particle
  /// Force loops work in chunks of this many particles (rows); their sums
  /// are added in chunk order, whatever thread took a chunk.
  static constexpr std::size_t kRowsPerChunk = 128;
  std::size_t chunkCount() const { return (particles.size() + kRowsPerChunk - 1) / kRowsPerChunk; }
  /// One past the last particle (row) of chunk c.
  std::size_t chunkEnd(std::size_t c) const { return std::min(particles.size(), (c + 1) * kRowsPerChunk); }
  std::vector<double> chunkLost_;          // energy lost in each chunk of rows (pair loop)
  std::vector<std::uint32_t> chunkContacts_;  // contacts each chunk of rows found in the last pair loop
  std::vector<std::uint64_t> chunkWork_;      // prefix sums of the chunks' weights (weighChunks)
  /// What one chunk of the gather loop sums up.
  struct GatherPartial {
    double dissipated = 0.0, work = 0.0;
    std::vector<Vec3> planeForce, planeTorque, meshForce, meshTorque;
    std::vector<double> planeStiffness;
  };
  std::vector<GatherPartial> gatherPartials_;
  /// Energy lost and work done in one chunk of the gather, summed in particle order.
  struct ChunkSums {
    double dissipated = 0.0, work = 0.0;
  };
  /// A triangle within reach of a particle: overlap, closest point, unit normal towards the particle.
  struct MeshCandidate {
    std::uint32_t triangle;
    double overlap;
    Vec3 point, normal;
    std::array<double, 3> bary;
  };
  /// Mesh contacts of each particle, kSlots per particle and group, and how many are used.
  struct MeshGather {
    std::vector<std::vector<TriangleContact>> contacts;  // [group][particle * kSlots + slot]
    std::vector<std::uint8_t> count;                     // [particle * groups + group]
  };
  /// The candidates of planeNear in particle order, then plane order; chunk
  /// c's are [chunkPlaneCand_[c], chunkPlaneCand_[c + 1]).
  std::vector<PlaneCandidate> planeCand_;
  std::vector<std::uint32_t> chunkPlaneCand_;
  std::size_t planeCandParticles_ = 0, planeCandPlanes_ = 0;  // what the list was indexed for
  /// Calls visit(normal, tangential) with the contact law's parts as their
  /// concrete classes where they are built in, so the force loops inline them.
  template <class Visit>
  void visitLaw(Visit&& visit) const;
  template <class Normal, class Tangential>
  void gatherLoop(const Normal& normal, const Tangential& tangential, double dt, double closingKick);
  /// The same for triangle group g (Cheng 2022 Alg. 1), recording the contacts in `out`.
  void addMeshContacts(std::size_t i, std::size_t g, double w, double dt, GatherPartial& local, ChunkSums& sums,
                       MeshGather& out, std::vector<MeshCandidate>& cand, std::vector<MeshCandidate>& kept, Vec3& f,
                       Vec3& t);
  std::unique_ptr<ContactLaw> law_;
  std::unique_ptr<Integrator> integrator_;
  std::array<std::string, 3> lawNames_;
  std::string integratorName_;
};

/// One listed pair of spheres that overlaps now: d = x_i - x_j (nearest
/// image), its length, the overlap and R* = r_i r_j / (r_i + r_j).
struct PairOverlap {
  std::uint32_t i = 0, j = 0, k = 0;  // k: index into the neighbour list
  Vec3 d;
  double dist = 0.0, overlap = 0.0, rEff = 0.0;
};

/// Calls f(PairOverlap) for every listed pair that overlaps at the current positions.
template <class F>
void forEachOverlap(const DemSystem& s, F&& f) {
  const Particles& p = s.particles;
  const auto& nl = s.neighbors;
  for (std::uint32_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      const double rsum = p.radius[i] + p.radius[j];
      const Vec3 d = s.pairVector(i, k);
      const double dist = norm(d);
      if (dist >= rsum) continue;
      f(PairOverlap{i, j, k, d, dist, rsum - dist, p.radius[i] * p.radius[j] / rsum});
    }
}

}  // namespace cosim::dem
