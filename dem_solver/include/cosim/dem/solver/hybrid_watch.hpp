#pragma once
// The hybrid watch: a Verlet skin across the wire (pddem.capnp, docs/protocol.md).
//
// Most hybrid PD surface particles are nowhere near anything they could touch
// (H5: 4-35 % of 11584 are), yet PD sent every state every step. After a full
// state message DEM lists the hybrids within r_i + r_j + skin + m of a
// partner (a DEM sphere, another body's hybrid, one of its own body outside
// its family) or within r_i + skin + m of a plane: the watched set, m the
// watch margin. PD then sends the watched states alone while every hybrid
// stays within m/2 of where the full message put it (its drift over DEM's
// interval counted), and DEM keeps its own particles and planes within m/2 of
// where they were then. An unwatched hybrid therefore stays more than
// r_i + r_j + skin from everything: it has no contact, is no neighbour
// candidate, and its force is zero, as with its states sent. DEM parks it
// (driven flag 2: it keeps its last position) until the next full message.
#include <cstdint>
#include <span>
#include <vector>

#include "cosim/dem/dem_system.hpp"
#include "cosim/util/binary_record.hpp"
#include "pddem.capnp.h"

namespace cosim::dem {

/// The default watch margin per Verlet skin (params.hybrid.watch_margin).
constexpr double kWatchMarginPerSkin = 4.0;

class HybridWatch {
 public:
  /// params.hybrid.watch_margin: < 0 the default (kWatchMarginPerSkin x the
  /// skin), 0 off (PD sends every state).
  double requestedMargin = -1.0;

  /// Off for triangle walls (their vertices come from outside each exchange)
  /// and periodic cells (images), or when asked.
  bool available(const DemSystem& s) const { return requestedMargin != 0.0 && s.meshes.empty() && !s.cell.enabled; }
  /// After a full state message `serial` set every hybrid's state: lists the
  /// watched hybrids at the current state and takes DEM's own particles and
  /// planes as references. `interval` is the time DEM drifts a state over.
  void rebuild(const DemSystem& s, std::span<const std::uint32_t> hybridIndex, std::uint64_t serial,
               double interval);
  /// A full state message came: the watch set it rests on is gone.
  void forget() { built_ = false; }
  /// Whether the last rebuild listed set position k.
  bool watches(std::uint32_t k) const { return k < watched_.size() && watched_[k] != 0; }
  /// Throws std::invalid_argument unless a partial message of `indices`
  /// resting on full message `basis` matches this watch set.
  void checkPartial(std::uint64_t basis, std::span<const std::uint32_t> indices) const;
  /// Starts an interval: partial = its states came without the unwatched
  /// ones; stateArrived = a state message came with this interval's request.
  void beginInterval(const DemSystem& s, bool partial, bool stateArrived);
  /// After every step of dt: how far DEM's own particles and planes are from their references.
  void track(const DemSystem& s, double dt);
  /// Ends the interval: decides sendAll; throws std::runtime_error where an
  /// interval on partial states let a particle or plane pass m/2.
  void endInterval(const DemSystem& s);
  /// The watch fields of DEM's reply (a new watch set once, sendAll always).
  void fill(proto::HybridForces::Builder out) const;
  /// The whole state, for a checkpoint: a restored run continues bit for bit.
  void save(util::BinaryWriter& w) const;
  void load(util::BinaryReader& r, std::size_t particles, std::size_t hybrids);

 private:
  /// Largest distance of an own particle (not a hybrid) or a plane from its reference; `who` names it.
  double farthest(const DemSystem& s, std::string* who) const;
  std::vector<std::uint8_t> watched_;  // per set position
  std::vector<std::uint32_t> list_;    // watched set positions, ascending
  struct PlanePose {
    Vec3 point, normal;
  };
  std::vector<std::uint32_t> own_;     // DEM's own particles (every one but the hybrids)
  std::vector<Vec3> ownRef_;           // own particles at the rebuild
  std::vector<Vec3> intervalStart_;    // own particles at the interval's start
  std::vector<PlanePose> planeRef_, planeStart_;
  std::uint64_t basis_ = 0;
  bool built_ = false;       // a watch set is listed
  bool rebuiltNow_ = false;  // listed for this interval's message: it goes out with the reply
  bool fresh_ = false;       // the reply carries the watch set
  bool partial_ = false;     // this interval's states came without the unwatched ones
  bool sendAll_ = true;
  double margin_ = 0.0, interval_ = 0.0;
  double farthest_ = 0.0;    // largest distance of an own particle or plane from its reference so far
  double sinceState_ = 0.0;  // time the hybrid states have drifted since their message
};

}  // namespace cosim::dem
