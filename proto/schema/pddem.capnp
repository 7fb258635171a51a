@0x985eb106204a2fe6;
# PD-DEM contact coupling through hybrid surface particles (Hartmann 2022, Sec. 3).
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

# The set of hybrid particles is fixed at the first message. Later messages may
# leave ids, bodyIds, referencePositions, radii and horizons empty: positions
# and velocities are then those of the first message's particles, in its
# order (PD sends the set with its setup outputs only; the coupler sends it to
# DEM until DEM's outputs carry HybridForces, which shows DEM holds it).
struct HybridParticles {
  ids @0 :List(UInt32);
  bodyIds @1 :List(UInt32);
  referencePositions @2 :List(Float64); # 3 per particle
  positions @3 :List(Float64);          # 3 per particle
  velocities @4 :List(Float64);         # 3 per particle: the velocity to drift with over the next interval
                                        # (PD's Verlet: v_{n+1/2} = v_n + dt/2 a_n, so DEM's drift ends where PD's will)
  radii @5 :List(Float64);              # quasi-radius R = (3V / 4 pi)^(1/3), Hartmann Eq. 39
  horizons @6 :List(Float64);           # per body: pairs of one family closer than this are excluded
  wantStiffness @7 :Bool;               # set by the coupler: return HybridForces.positions and .stiffness
  # Partial states (the hybrid watch, docs/protocol.md): with `partial` the
  # positions and velocities are those of the set's particles at `indices`
  # (positions in the set, the watch set DEM sent for full message
  # `watchBasis`); every other particle is farther than DEM's watch distance
  # from everything it could touch and keeps its last state in DEM.
  serial @8 :UInt64;                    # names the message: its exchange + 1 (setup 1); 0 outside exchanges
  partial @9 :Bool;
  indices @10 :List(UInt32);
  watchBasis @11 :UInt64;               # serial of the full message whose watch set `indices` is
}

# Forces of the loaded particles only: a particle not listed has no contact
# force (and no stiffness) over the interval.
struct HybridForces {
  ids @0 :List(UInt32);
  forces @1 :List(Float64);             # 3 per particle, total contact force on it
  # The force's first-order dependence on the particle's own position, so a
  # solver that sub-cycles with it can follow its motion instead of holding
  # it: f(x) = forces - K (x - positions). Empty: hold the force.
  positions @2 :List(Float64);          # 3 per particle, where `forces` was evaluated (interval mean)
  stiffness @3 :List(Float64);          # 6 per particle, K = -df/dx: xx yy zz xy xz yz
  # The hybrid watch (docs/protocol.md), a Verlet skin across the wire. After
  # a full state message DEM lists the particles within r_i + r_j + skin +
  # watchMargin of anything they could touch (`watched`, positions in the set)
  # and names that message (`watchBasis`, its serial). PD may then send the
  # watched particles' states alone while every hybrid particle stays within
  # watchMargin / 2 of where that message put it, counting the drift
  # watchInterval |v| of each state sent; DEM keeps its own particles and walls
  # within watchMargin / 2 and sets `sendAll` when they come near it. So a
  # particle left out cannot reach anything before the next full message.
  watchSet @4 :Bool;                    # this reply carries a new watch set
  watched @5 :List(UInt32);
  watchMargin @6 :Float64;
  watchInterval @7 :Float64;            # the time DEM drifts a state over (its interval)
  watchBasis @8 :UInt64;
  sendAll @9 :Bool;                     # DEM needs every particle's state in the next message
}
