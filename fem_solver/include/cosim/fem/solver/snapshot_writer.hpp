#pragma once
// HDF5 snapshots of the FE state (positions, displacement, velocity, element
// Cauchy stress and Green strain) with an XDMF sidecar (Hexahedron topology)
// that ParaView opens directly (DESIGN.md 6.5).
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cosim/fem/model/model.hpp"
#include "cosim/fem/time/integrator.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/io/xdmf.hpp"

namespace cosim::fem {

class SnapshotWriter {
 public:
  /// `resuming`: keep an existing file (a restore follows, then resumeAt()).
  SnapshotWriter(const std::filesystem::path& h5Path, const Model& model, bool resuming = false);
  void write(const Model& model, const State& state);
  /// After a restore to `step`: drops the later snapshots and continues the file.
  void resumeAt(std::uint64_t step) { xdmf_.resumeAt(file_, step); }
  const std::filesystem::path& xdmfPath() const { return xdmf_.path(); }

 private:
  io::H5File file_;
  std::size_t nodes_ = 0, elements_ = 0;
  io::XdmfTimeSeries xdmf_;
};

}  // namespace cosim::fem
