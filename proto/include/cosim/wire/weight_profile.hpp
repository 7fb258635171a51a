#pragma once
// The Arlequin weight profile on the wire (volume.capnp WeightProfile) and
// back: the coupler sends it at setup, dem_solver and fem_solver read it, so
// all three evaluate the same util::WeightProfile.
#include "cosim/util/weight_profile.hpp"
#include "volume.capnp.h"

namespace cosim::wire {

inline void write(const util::WeightProfile& p, proto::WeightProfile::Builder out) {
  out.setKind(p.kind);
  out.setAxis(static_cast<std::uint8_t>(p.axis));
  out.setStart(p.start);
  out.setEnd(p.end);
  out.setLow(p.low);
  out.setHigh(p.high);
  out.setNodalFem(p.nodalFem);
}

inline util::WeightProfile read(proto::WeightProfile::Reader in) {
  util::WeightProfile p;
  p.kind = in.getKind().cStr();
  p.axis = in.getAxis();
  p.start = in.getStart();
  p.end = in.getEnd();
  p.low = in.getLow();
  p.high = in.getHigh();
  p.nodalFem = in.getNodalFem();
  return p;
}

}  // namespace cosim::wire
