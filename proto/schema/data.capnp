@0x85dfa25b32bdc6ef;
# The payload container that advance requests and replies carry. Each coupling
# data kind has its own typed list; a message fills only what a coupling needs.
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

using Surface = import "surface.capnp";
using Volume = import "volume.capnp";
using PdDem = import "pddem.capnp";
using Gmh = import "gmh.capnp";

struct NamedArray {
  # A generic flat array (probes, digests, solver-specific series).
  name @0 :Text;
  components @1 :UInt32;
  values @2 :List(Float64);
}

struct NamedValue {
  name @0 :Text;
  value @1 :Float64;
}

struct CouplingData {
  arrays @0 :List(NamedArray);
  meshes @1 :List(Surface.TriangleMeshKinematics);
  quadratures @2 :List(Surface.SurfaceQuadrature);
  contacts @3 :List(Surface.ContactList);
  particles @4 :List(Volume.ParticleStates);
  nodalFields @5 :List(Volume.NodalField);
  forces @6 :List(Volume.CouplingForces);
  hybridParticles @7 :List(PdDem.HybridParticles);
  hybridForces @8 :List(PdDem.HybridForces);
  unitCellJobs @9 :List(Gmh.UnitCellJobs);
  unitCellResults @10 :List(Gmh.UnitCellResults);
  weightProfiles @11 :List(Volume.WeightProfile);
}
