@0xf2c0990e879921be;
# Arlequin volume coupling (Cheng 2022, Sec. 5.2, App. B).
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

struct ParticleStates {
  # Particles in a coupling zone (or a whole assembly).
  zone @0 :Text;
  ids @1 :List(UInt32);
  positions @2 :List(Float64);       # 3 per particle
  velocities @3 :List(Float64);      # 3 per particle
  displacements @4 :List(Float64);   # 3 per particle, from the reference configuration
  masses @5 :List(Float64);
  radii @6 :List(Float64);
  forces @7 :List(Float64);          # 3 per particle: mean total force over the last interval (DEM)
}

struct NodalField {
  # A field on FE nodes: displacement increments, velocities, forces ...
  name @0 :Text;
  components @1 :UInt32;
  nodeIds @2 :List(UInt32);          # empty = all nodes in order
  values @3 :List(Float64);          # components per node
}

struct CouplingForces {
  # Forces a coupling applies to one side (penalty forces of Cheng Eqs. 31-32,
  # mapped contact forces of Eqs. 14-16).
  zone @0 :Text;
  target @1 :Target;
  enum Target { particles @0; nodes @1; }
  ids @2 :List(UInt32);
  forces @3 :List(Float64);          # 3 per id
}

struct WeightProfile {
  # Arlequin weight w(x); DEM is weighted by w, FEM by 1 - w (Cheng Eq. 25).
  kind @0 :Text;                     # "half-cosine", "linear"
  axis @1 :UInt8;                    # 0 = x, 1 = y, 2 = z
  start @2 :Float64;                 # w = 1 on the DEM side of start
  end @3 :Float64;                   # w = 0 beyond end
  low @4 :Float64 = 0.0;             # w at end, inside the closed zone
  high @5 :Float64 = 1.0;            # w at start, inside the closed zone
  nodalFem @6 :Bool = false;         # FEM interpolates nodal w (else w at its quadrature points)
}
