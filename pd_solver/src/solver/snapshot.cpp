// HDF5 point snapshots + XDMF sidecar (Polyvertex topology).
#include <sstream>

#include "cosim/pd/snapshot.hpp"

namespace cosim::pd {

SnapshotWriter::SnapshotWriter(const std::filesystem::path& h5Path, bool resuming)
    : path_(h5Path),
      file_(cosim::io::H5File::createOrKeep(h5Path, resuming)),
      xdmf_(h5Path, "pd", {}, "position",
            {{"displacement", "displacement", 3},
             {"velocity", "velocity", 3},
             {"damage", "damage", 1},
             {"strain", "strain", 6},
             {"von_mises", "von_mises", 1}}) {
  file_.setAttribute("/", "solver", "pd_solver");
  file_.setAttribute("/", "units", "SI (m, kg, s, N, Pa)");
}

void SnapshotWriter::write(const PdSystem& system) {
  const auto& p = system.particles();
  const std::size_t n = p.size();
  std::ostringstream gs;
  gs << "/snapshots/" << system.stepCount();
  const std::string g = gs.str();
  file_.group(g);
  std::vector<double> x(3 * n);
  for (std::size_t q = 0; q < 3 * n; ++q) x[q] = p.reference[q] + p.displacement[q];
  file_.writeArray(g + "/position", x, 3);
  file_.writeArray(g + "/reference", p.reference, 3);
  file_.writeArray(g + "/displacement", p.displacement, 3);
  file_.writeArray(g + "/velocity", p.velocity, 3);
  file_.writeArray(g + "/damage", system.damageField(), 1);
  const auto corr = system.correspondenceFields();
  file_.writeArray(g + "/strain", corr.greenLagrange, 6);
  file_.writeArray(g + "/von_mises", corr.vonMises, 1);
  file_.writeArray(g + "/body", p.body, 1);
  file_.setAttribute(g, "time", system.time());
  file_.flush();
  xdmf_.addStep(system.stepCount(), system.time(), n);
}

}  // namespace cosim::pd
