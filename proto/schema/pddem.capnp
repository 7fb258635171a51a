@0x985eb106204a2fe6;
# PD-DEM contact coupling through hybrid surface particles (Hartmann 2022, Sec. 3).
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

struct HybridParticles {
  ids @0 :List(UInt32);
  bodyIds @1 :List(UInt32);
  referencePositions @2 :List(Float64); # 3 per particle
  positions @3 :List(Float64);          # 3 per particle
  velocities @4 :List(Float64);         # 3 per particle
  radii @5 :List(Float64);              # quasi-radius R = (3V / 4 pi)^(1/3), Hartmann Eq. 39
  horizons @6 :List(Float64);           # per body: pairs of one family closer than this are excluded
}

struct HybridForces {
  ids @0 :List(UInt32);
  forces @1 :List(Float64);             # 3 per particle, total contact force on it
}
