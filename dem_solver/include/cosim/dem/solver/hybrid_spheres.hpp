#pragma once
// Hybrid PD surface particles on the DEM side (Hartmann 2022, Sec. 3.1-3.2).
// PD exports its surface particles (position, velocity, quasi-radius Eq. 39,
// body, reference position, horizon); DEM keeps each as a driven sphere: its
// state is set at every exchange and it moves with its velocity over the
// sub-steps, never integrated. Pairs of one PD family (same body, reference
// distance within the horizon) are excluded from contact, since their
// interaction is PD's bond force; every other pair (DEM-hybrid, hybrid of
// another body, or of the same body across its surface) is an ordinary contact.
// The contact (and plane wall) force on each hybrid particle is summed over the
// sub-steps and returned as its mean: the impulse over the interval / interval,
// with the mean position it was felt at and the contact stiffness K = -df/dx
// (so PD can follow the force over its own sub-steps, coupling `forces: linearised`).
#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "cosim/dem/dem_system.hpp"
#include "cosim/dem/solver/hybrid_watch.hpp"
#include "pddem.capnp.h"

namespace cosim::dem {

/// One body's family rule: pairs (a, b) of indices into refPositions (3 per
/// particle) with bodies[a] == bodies[b] and |X_a - X_b| <= horizons[body].
/// Throws std::invalid_argument on inconsistent sizes or an unknown body.
std::vector<std::pair<std::uint32_t, std::uint32_t>> familyPairs(const std::vector<std::uint32_t>& bodies,
                                                                  const std::vector<double>& refPositions,
                                                                  const std::vector<double>& horizons);

class HybridSpheres {
 public:
  /// Adds the spheres of the first message (returns true: the system must be
  /// re-initialised) or updates their positions and velocities. Throws
  /// std::invalid_argument naming the problem for malformed or changed sets.
  bool apply(proto::HybridParticles::Reader message, DemSystem& system, std::uint16_t material);
  std::size_t size() const { return ids_.size(); }
  /// Starts a new interval of contact-force sums, `interval` s long; after a
  /// full state message lists the hybrid watch set (hybrid_watch.hpp).
  void beginInterval(const DemSystem& system, double interval);
  /// After a step of dt: adds its force on every hybrid sphere (and its
  /// position, when asked for) and follows the watch.
  void accumulate(const DemSystem& system, double dt);
  /// Ends the interval of `steps` sub-steps: the returned forces are the mean.
  /// Throws std::runtime_error where the watch's argument broke (hybrid_watch.hpp).
  void endInterval(std::uint32_t steps, const DemSystem& system);
  HybridWatch& watch() { return watch_; }
  /// The set's PD ids and DEM indices, appended to a checkpoint: a restored
  /// DEM drives the hybrid particles it holds instead of adding the set again.
  void save(std::ostream& out) const;
  /// Reads what save wrote; nothing left in the stream means no hybrids.
  /// Throws std::runtime_error naming `path` on a bad record.
  void load(std::istream& in, const std::string& path, std::size_t particles);
  /// The mean force of the last interval (before any: the current one); when
  /// the last HybridParticles asked for it (wantStiffness), also the mean
  /// position and the stiffness at the current state.
  void fill(proto::HybridForces::Builder out, const DemSystem& system) const;
  /// K = -df/dx of each hybrid sphere's contact and plane-wall forces with
  /// respect to its own position at the current state, 6 per sphere (xx yy zz
  /// xy xz yz). Triangle-wall contacts are not included.
  std::vector<double> stiffness(const DemSystem& system) const;
  const std::vector<std::uint32_t>& particleIndices() const { return index_; }
  /// At the start of a run: a hybrid sphere overlapping another sphere (not of
  /// its own PD family) by more than tolerance x the smaller radius would start
  /// with a blast; throws std::invalid_argument naming the PD id and the partner.
  void checkStartOverlaps(const DemSystem& system, double tolerance) const;

 private:
  void add(proto::HybridParticles::Reader message, DemSystem& system, std::uint16_t material);
  /// Position in ids_ of a PD particle id (an id outside the set is bad input).
  std::uint32_t slotOf(std::uint32_t id) const;
  std::vector<std::uint32_t> ids_;    // PD particle ids, as exported
  std::vector<std::uint32_t> index_;  // DEM particle index of each
  std::unordered_map<std::uint32_t, std::uint32_t> slot_;  // PD id -> position in ids_
  mutable std::vector<std::uint32_t> loaded_;               // fill's scratch: slots with a force
  std::vector<Vec3> impulse_, mean_;
  std::vector<Vec3> positionSum_, meanPosition_;
  bool averaged_ = false;
  bool wantStiffness_ = false;  // the last HybridParticles asked for positions and stiffness
  void applyPartial(proto::HybridParticles::Reader message, DemSystem& system);
  /// The interval sums, one per hybrid, cleared.
  void sizeSums();
  HybridWatch watch_;
  std::uint64_t fullSerial_ = 0;  // serial of the last full state message
  bool pendingRebuild_ = false;   // a full state message came with this interval's request
  bool stateArrived_ = false, partial_ = false, parked_ = false;
  double lastStateTime_ = -1.0, cadence_ = 0.0;  // when the last state message came, and the time between two
};

}  // namespace cosim::dem
