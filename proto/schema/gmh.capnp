@0xe4cf483702d1d458;
# Hierarchical FEM x DEM (GMH, Liu 2016): one unit cell per quadrature point.
using Cxx = import "/capnp/c++.capnp";
$Cxx.namespace("cosim::proto");

struct UnitCellJobs {
  cellIds @0 :List(UInt32);
  strainIncrements @1 :List(Float64);   # 9 per cell, row-major, in the cells' frame: corotational
                                        # (Liu Eq. 60) or, where FEM's material says frame: spatial,
                                        # the whole increment log(F_n+1 F_n^-1), spin included
  dt @2 :Float64;                       # coarse time step the increment spans
  positions @3 :List(Float64);          # 3 per cell: its quadrature point's reference position
                                        # (the nonlocal operator's neighbour sets, Liu Eqs. 58-59)
}

struct UnitCellResults {
  cellIds @0 :List(UInt32);
  stresses @1 :List(Float64);           # 9 per cell, Cauchy stress in the cells' frame (Liu Eq. 44b)
  porosities @2 :List(Float64);
  coordinationNumbers @3 :List(Float64);
  unbalancedForceIndices @4 :List(Float64); # Liu Eq. 57
  relaxationSteps @5 :List(UInt32);
  failed @6 :List(Bool);                # per cell: the job ended outside the worker's relaxation settings
                                        # (I_uf above the tolerance after the budget, or Z below
                                        # min_coordination) and the stress is the cell's as it stands.
                                        # Only a worker with on_failure: continue answers such a job;
                                        # otherwise the advance fails naming the cells. Empty: none failed.
}

# The NamedArray every worker reply carries (Liu 2016 Eqs. 63-66): [relaxation
# dt, Eq. 63 critical step, omega_max, xi, omega_n, omega_theta] of its
# tightest cell; the gmh coupling reports the fine/coarse step relation from it.
const fineTimeStepArray :Text = "fine_time_step";
