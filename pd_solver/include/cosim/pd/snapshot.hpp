#pragma once
// HDF5 point snapshots with an XDMF sidecar (Polyvertex topology) that
// ParaView opens directly.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "cosim/io/h5_file.hpp"
#include "cosim/io/xdmf.hpp"
#include "cosim/pd/system.hpp"

namespace cosim::pd {

class SnapshotWriter {
 public:
  /// `resuming`: keep an existing file (a restore follows, then resumeAt()).
  explicit SnapshotWriter(const std::filesystem::path& h5Path, bool resuming = false);
  /// After a restore to `step`: drops the later snapshots and continues the file.
  void resumeAt(std::uint64_t step) { xdmf_.resumeAt(file_, step); }
  /// Writes /snapshots/<step>/{position, displacement, velocity, damage,
  /// strain, von_mises} and rewrites the .xmf sidecar listing every snapshot.
  void write(const PdSystem& system);

 private:
  std::filesystem::path path_;
  cosim::io::H5File file_;
  cosim::io::XdmfTimeSeries xdmf_;
};

}  // namespace cosim::pd
