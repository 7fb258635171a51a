#pragma once
// A GMH worker (Liu, Sun, Fish 2016 Sec. 2.3.3 steps iii-iv): many periodic
// unit cells in one dem_solver process, each with its own DemSystem, keyed by
// the cell id the FEM side gives its quadrature point. Scene params:
//
//   params:
//     unit_cells:
//       file: cell500.ckpt        # from dem_prepare_cell; copied into every cell
//       first_id: 0               # cells first_id + k stride, k = 0 .. count - 1
//       count: 8
//       stride: 1                 # 2 with two workers (first_id 0 and 1) interleaves
//                                 # them, so a band of busy cells loads both alike
//       variants: [cell500_s2.ckpt, cell500_s3.ckpt]    # optional: cells prepared with other seeds;
//                                 # each cell starts from file or one of these, picked by a hash of its
//                                 # id (the same on every worker, whatever the stride)
//       weakened: {file: cell500_weak.ckpt, ids: [5]}   # optional: these ids start from another file
//       dt: 1.0e-7                # pseudo-time step; default dt_factor * the smallest critical step of the files
//       dt_factor: 0.5
//       tolerance: 0.01           # unbalanced-force index (Liu Eq. 57)
//       max_steps: 20000          # relaxation budget per job
//       load_steps: 100           # steps over which an increment is applied
//       min_coordination: 2.0
//       mass_damping: 1.0e5       # optional override of the file's c [1/s]
//       on_failure: stop          # or continue (below)
//
// A job whose cell does not relax within the budget, or ends with fewer
// contacts than min_coordination, fails: with on_failure: stop (the default)
// the advance fails and the error reply names every such cell with its I_uf,
// steps, porosity and coordination; with continue the cell's stress goes back
// as it stands, flagged in UnitCellResults.failed, and the gmh coupling
// reports the job (a cell that lost its skeleton in a dilating band carries
// almost no stress; the coarse problem may compact it again).
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cosim/dem/cell/unit_cell.hpp"
#include "data.capnp.h"
#include "session.capnp.h"

namespace cosim::dem {

/// One worker's share of a pool entry's cells (`solvers[i].pool`): of the
/// entry's ids first_id + k stride (k < count), those with k = index mod size.
struct PoolShare {
  std::uint32_t index = 0, size = 1;
};

class UnitCellWorker {
 public:
  /// From params.unit_cells; every other params key is refused (a worker holds only cells).
  /// Relative cell files resolve against `baseDir` (empty: sceneFile's directory), then as given.
  static std::unique_ptr<UnitCellWorker> fromParams(const YAML::Node& params, const std::string& sceneFile,
                                                    const std::string& baseDir = "", PoolShare share = {});
  /// Answers every UnitCellJobs list in inputs with a UnitCellResults list in outputs.
  void answer(proto::CouplingData::Reader inputs, proto::CouplingData::Builder outputs);
  /// Takes over cells of a worker the run lost (session.capnp AdoptCells):
  /// loads them from its checkpoint, runs the jobs they were sent since, and
  /// writes the results of the last jobs (or the cells as loaded, without
  /// jobs). The cells relax with this worker's settings, which must be the
  /// lost worker's, so their answers are those the lost worker would have given.
  void adopt(proto::AdoptCells::Reader request, proto::CouplingData::Builder outputs);
  /// The state of every cell it holds, without a job: its setup reply, which
  /// tells the coupler the cell ids this worker owns and their initial stresses.
  void report(proto::CouplingData::Builder outputs) const;
  /// All cells with their full states and the settings, in one file.
  std::uint64_t checkpoint(const std::string& path) const;
  /// nullptr when the file is not a worker checkpoint (a plain dem checkpoint).
  static std::unique_ptr<UnitCellWorker> restore(const std::string& path);

  std::size_t size() const { return cells_.size(); }
  const std::vector<std::uint32_t>& ids() const { return ids_; }
  DemSystem& cell(std::uint32_t id);
  const RelaxSettings& settings() const { return relax_; }
  /// Coarse time and steps the worker has been advanced through (its cells run in pseudo time).
  double time = 0.0;
  std::uint64_t steps = 0;

  UnitCellWorker(RelaxSettings relax) : relax_(relax) {}
  void add(std::uint32_t id, DemSystem cell);

 private:
  void writeFineTimeStep(proto::CouplingData::Builder outputs) const;
  /// Runs one jobs list into rows; appends the cells that failed to `failures`.
  void run(proto::UnitCellJobs::Reader jobs, proto::UnitCellResults::Builder results, std::string& failures);
  void refuseFailures(const std::string& failures) const;
  RelaxSettings relax_;
  std::vector<std::uint32_t> ids_;
  std::vector<std::unique_ptr<DemSystem>> cells_;
  std::map<std::uint32_t, std::size_t> index_;
};

}  // namespace cosim::dem
