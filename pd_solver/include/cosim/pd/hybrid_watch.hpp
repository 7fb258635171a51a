#pragma once
// PD's side of the hybrid watch (pddem.capnp; DEM's side and the argument:
// dem_solver's hybrid_watch.hpp). After DEM has listed the hybrids it watches
// for one of PD's full state messages, PD sends those states alone while
// every hybrid stays within half the watch margin of where that message put
// it, counting the drift watchInterval |v| of the state it sends; otherwise,
// or when DEM asks (sendAll), it sends every state and DEM lists a new set.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "cosim/util/binary_record.hpp"
#include "pddem.capnp.h"

namespace cosim::pd {

class HybridWatch {
 public:
  /// Reads a reply's watch fields: sendAll, and a watch set that rests on the
  /// last full message sent (any other is stale and ignored). Returns a
  /// description of malformed fields, or "" (nothing is kept then).
  std::string receive(proto::HybridForces::Reader forces, std::size_t hybrids);
  /// The set positions whose states the next message may hold alone, given
  /// every hybrid's position and drift velocity (3 per particle); nullptr: send all.
  const std::vector<std::uint32_t>* select(std::span<const double> x, std::span<const double> v) const;
  /// Notes a sent message (full or partial) of serial > 0; a full one becomes
  /// the basis of the next watch set.
  void sent(bool full, std::span<const double> x, std::uint64_t serial);
  std::uint64_t basis() const { return lastFull_; }
  /// The whole state, for a checkpoint: a restored run continues bit for bit.
  void save(util::BinaryWriter& w) const;
  /// Throws std::runtime_error naming the record where it does not fit `hybrids` particles.
  void load(util::BinaryReader& r, std::size_t hybrids);

 private:
  std::uint64_t lastFull_ = 0;
  std::vector<double> fullPositions_;  // of the last full message
  std::vector<std::uint32_t> watched_;
  double margin_ = 0.0, interval_ = 0.0;
  bool adopted_ = false, sendAll_ = true;
};

}  // namespace cosim::pd
