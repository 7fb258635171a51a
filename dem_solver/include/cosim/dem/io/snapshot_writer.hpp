#pragma once
// Particle snapshots in one HDF5 file (/snapshots/<step>/{positions, velocities,
// radii, angular_velocities, ids}, energies under /series) with an XDMF
// sidecar (Polyvertex topology, one grid per snapshot in a temporal
// collection) that ParaView opens directly.
#include <memory>
#include <string>
#include <vector>

#include "cosim/dem/dem_system.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/io/xdmf.hpp"

namespace cosim::dem {

class SnapshotWriter {
 public:
  /// h5Path ends in .h5; the sidecar is the same path with .xmf.
  explicit SnapshotWriter(const std::string& h5Path);
  ~SnapshotWriter();
  void write(const DemSystem& system);
  std::string xdmfPath() const { return xdmf_.path().string(); }

 private:
  std::string h5Path_;
  io::H5File file_;
  std::unique_ptr<io::SeriesWriter> series_;
  io::XdmfTimeSeries xdmf_;
};

}  // namespace cosim::dem
