@0xfe8cbeacad1a2cc2;
# Surface coupling between an FE solid and DEM spheres (Cheng 2022, Sec. 5.1).
# Arrays are flat, row-major: xyz of vertex i is [3i, 3i+1, 3i+2].
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

struct TriangleMeshKinematics {
  # A coupling surface as moving triangles: every FE quad face is split into four
  # triangles around an interpolated centre vertex (DESIGN.md 6.3).
  surface @0 :Text;                  # name of the FE face set
  positions @1 :List(Float64);       # 3 per vertex, current configuration
  velocities @2 :List(Float64);      # 3 per vertex
  triangles @3 :List(UInt32);        # 3 vertex ids per triangle
  # Vertex-to-node weights in compressed rows: vertex v takes nodes
  # nodeIds[rowStart[v] .. rowStart[v+1]) with weights nodeWeights[...].
  rowStart @4 :List(UInt32);
  nodeIds @5 :List(UInt32);
  nodeWeights @6 :List(Float64);
}

struct SurfaceQuadrature {
  # Surface quadrature points for the CG-enriched force map (Cheng Eqs. 14-15).
  surface @0 :Text;
  positions @1 :List(Float64);       # 3 per point
  weights @2 :List(Float64);         # area weight per point
  nodesPerPoint @3 :UInt32;          # e.g. 4 for a bilinear quad face
  nodeIds @4 :List(UInt32);          # nodesPerPoint per point
  shapeValues @5 :List(Float64);     # nodesPerPoint per point
}

struct ContactList {
  # Contacts between spheres and a triangle wall group, as DEM reports them.
  surface @0 :Text;
  triangleIds @1 :List(UInt32);
  barycentric @2 :List(Float64);     # 3 per contact (weights of the triangle's vertices)
  points @3 :List(Float64);          # 3 per contact, contact point in space
  forces @4 :List(Float64);          # 3 per contact, force exerted ON the wall
  particleIds @5 :List(UInt32);
}
