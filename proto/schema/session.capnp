@0xe65c8dcc6fd05640;
# Session control between the coupler (ROUTER) and a solver (DEALER).
# Every message is one Envelope. Requests carry a sequence number that grows by
# one per request on a connection; a reply names the request it answers in
# replyTo. Schemas evolve only by adding fields with new ordinals.
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

using Data = import "data.capnp";
using Gmh = import "gmh.capnp";

const protocolMajor :UInt16 = 1;
const protocolMinor :UInt16 = 5;  # 1: Advance.wantCriticalDt; 2: Advanced.aheadSeconds, aheadStartedAt;
                                  # 3: adoptCells, cellsAdopted; 4: Setup.pool; 5: Welcome.dataSegment

struct Envelope {
  seq @0 :UInt64;          # sender's sequence number (requests and replies)
  replyTo @1 :UInt64;      # seq of the request this answers; 0 for requests
  body :union {
    hello @2 :Hello;             # solver -> coupler, first message
    welcome @3 :Welcome;         # coupler -> solver, hello accepted
    setup @4 :Setup;             # coupler -> solver
    setupDone @5 :SetupDone;
    advance @6 :Advance;
    advanced @7 :Advanced;
    fieldsRequest @8 :FieldsRequest;
    fields @9 :Fields;
    checkpoint @10 :Checkpoint;
    checkpointDone @11 :CheckpointDone;
    restore @12 :Restore;
    restored @13 :Restored;
    heartbeat @14 :Heartbeat;    # both ways, never answered
    error @15 :Error;
    shutdown @16 :Shutdown;
    shutdownDone @17 :Void;
    adoptCells @18 :AdoptCells;  # coupler -> GMH worker (capability unit-cell-adoption)
    cellsAdopted @19 :CellsAdopted;
  }
}

struct Hello {
  protocolMajor @0 :UInt16;
  protocolMinor @1 :UInt16;
  solverKind @2 :Text;       # "dem", "fem", "pd", "mock" ...
  version @3 :Text;          # the binary's version string
  instance @4 :Text;         # its instance name (also its routing id)
  capabilities @5 :List(Text);
  pid @6 :UInt32;
  host @7 :Text;
}

struct Welcome {
  protocolMajor @0 :UInt16;
  protocolMinor @1 :UInt16;
  heartbeatIntervalS @2 :Float64;
  heartbeatTimeoutS @3 :Float64;
  # Shared-memory data path (capability shm-data, docs/protocol.md): when set,
  # every later request and reply travels through this segment file, and the
  # solver rings the coupler's doorbell file after each reply.
  dataSegment @4 :Text;
  doorbell @5 :Text;
  spinS @6 :Float64;         # how long a waiting end busy-waits before sleeping
}

struct Setup {
  sceneFile @0 :Text;        # for messages: errors name file:line
  sceneYaml @1 :Text;        # whole scene text (no shared filesystem needed)
  instance @2 :Text;         # which entry of solvers: is this one
  runDir @3 :Text;           # where the solver writes its own output
  inputs @4 :Data.CouplingData;  # setup-time coupling data (weight profiles ...)
  resuming @5 :Bool;         # a restore follows: keep the output files in runDir, write no setup snapshot
  sceneDir @6 :Text;         # relative paths in the scene resolve here: the user's scene file's directory
                             # (with --set, sceneFile is the effective scene in the run directory)
  pool @7 :PoolMember;       # set for a worker of a pool entry (solvers[i].pool; capability pool-member)
}

# One worker of a scene entry that declares `pool: {workers: N}`: its params
# are the entry's, and the solver takes its own share of them (a GMH worker:
# the cells of ids first_id + (index + k N) stride).
struct PoolMember {
  entry @0 :Text;            # the entry's name, whose params apply
  index @1 :UInt32;          # 0 .. size-1
  size @2 :UInt32;           # the pool's worker count; 0: not a pool member
}

struct SetupDone {
  criticalDt @0 :Float64;    # 0 when the solver has no stability limit
  outputs @1 :Data.CouplingData; # what the couplings need at time zero
  energies @2 :List(Data.NamedValue);
}

struct Advance {
  steps @0 :UInt32;          # number of sub-steps
  dt @1 :Float64;            # sub-step size
  time @2 :Float64;          # simulated time at the start of the request
  exchange @3 :UInt64;       # exchange counter (for messages and output)
  inputs @4 :Data.CouplingData;
  inputsEnd @5 :Data.CouplingData; # when present: interface data at the end of the
                                   # interval, for linear interpolation in sub-steps
  wantEnergies @6 :Bool = true;    # false: the reply may leave its energies out (they
                                   # can cost a sweep over the model, e.g. PD's bonds)
  wantCriticalDt @7 :Bool = true;  # false: the reply's criticalDt is 0, not computed (a
                                   # Hertz-aware DEM step is a sweep over the particles)
}

struct Advanced {
  time @0 :Float64;          # simulated time after the request
  step @1 :UInt64;           # total steps taken
  computeSeconds @2 :Float64; # wall time spent inside the solver's advance and energies
  criticalDt @3 :Float64;    # the solver's stable step now; 0: no limit, or not asked for
  energies @4 :List(Data.NamedValue);
  outputs @5 :Data.CouplingData;
  computeStartedAt @6 :Float64; # the solver's monotonic clock [s] when the compute began (0: not
                                # reported); on one host it is the coupler's clock too, which lets the
                                # run report tell where solvers computed at once (parallel rounds)
  aheadSeconds @7 :Float64;     # wall time the solver worked ahead after its previous advance's
                                # reply (Solver::workAhead): compute of this request done early
  aheadStartedAt @8 :Float64;   # the solver's monotonic clock [s] when that work began (0: none)
}

struct FieldsRequest {
  names @0 :List(Text);      # empty = everything the solver offers
}

struct Fields {
  time @0 :Float64;
  data @1 :Data.CouplingData;
}

struct Checkpoint { path @0 :Text; }
struct CheckpointDone { path @0 :Text; bytes @1 :UInt64; }
struct Restore { path @0 :Text; }
struct Restored { time @0 :Float64; step @1 :UInt64; }

# A GMH worker takes over unit cells of a worker the run lost: it loads them
# from that worker's checkpoint, runs the jobs they were sent since, oldest
# first, and keeps them from then on (they go into its own checkpoints).
struct AdoptCells {
  path @0 :Text;                   # the lost worker's checkpoint file holding the cells
  cellIds @1 :List(UInt32);
  jobs @2 :List(Gmh.UnitCellJobs); # one list per coarse step since that checkpoint, ids among cellIds
}
struct CellsAdopted {
  outputs @0 :Data.CouplingData;   # UnitCellResults: the answers to the last jobs list, or the
                                   # cells' states as loaded where no jobs came
}

struct Heartbeat {
  sentAtS @0 :Float64;       # sender's monotonic clock
  busy @1 :Bool;             # a request is being computed
}

struct Error {
  code @0 :Code;
  enum Code {
    malformed @0;            # bytes that are not an Envelope
    outOfOrder @1;           # sequence number not the next one
    unexpected @2;           # valid message at the wrong time (advance before setup ...)
    unsupported @3;          # a message kind this peer does not handle
    badInput @4;             # scene section, file or data rejected (message names it)
    solverFailure @5;        # the computation failed (NaN, divergence ...)
    protocolMismatch @6;
    internal @7;
  }
  message @1 :Text;
  fatal @2 :Bool;            # the sender is going to exit
}

struct Shutdown { reason @0 :Text; }
