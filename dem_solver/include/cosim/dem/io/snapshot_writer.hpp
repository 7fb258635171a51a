#pragma once
// Particle snapshots in one HDF5 file (/snapshots/<step>/{positions, velocities,
// radii, masses, angular_velocities, ids}, the contacts under
// /snapshots/<step>/contacts, energies under /series) with an XDMF sidecar
// (Polyvertex topology, one grid per snapshot in a temporal collection) that
// ParaView opens directly. The contacts are what the coarse-grained stress and
// boundary-force density need (coupler's cg_fields tool, Cheng 2022 Sec. 4).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "cosim/dem/dem_system.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/io/xdmf.hpp"

namespace cosim::dem {

/// Every contact of the current state, flat xyz per row. Pair forces act on
/// the first particle; wall forces are those the wall (plane or triangle
/// group) exerts on the particle, at the contact point on the wall surface.
struct ContactSnapshot {
  std::vector<std::uint32_t> pairs;  // i j per contact
  std::vector<double> pairPoints, pairForces;
  std::vector<std::uint32_t> wallParticles;
  std::vector<double> wallPoints, wallForces;
  std::size_t pairCount() const { return pairs.size() / 2; }
  std::size_t wallCount() const { return wallParticles.size(); }
};

/// Reads the contacts of the last force evaluation. Pair and triangle forces
/// are the stored ones; plane-wall forces are not stored by the system, so
/// they are re-evaluated from the stored tangential history with dt = 0
/// (which leaves the history as it is), at the current velocities.
ContactSnapshot contactSnapshot(const DemSystem& system);

class SnapshotWriter {
 public:
  /// h5Path ends in .h5; the sidecar is the same path with .xmf.
  /// `resuming`: keep an existing file (a restore follows, then resumeAt()).
  explicit SnapshotWriter(const std::string& h5Path, bool resuming = false);
  ~SnapshotWriter();
  void write(const DemSystem& system);
  /// After a restore to `step`: drops the later snapshots and series rows and continues the file.
  void resumeAt(std::uint64_t step);
  std::string xdmfPath() const { return xdmf_.path().string(); }

 private:
  std::string h5Path_;
  io::H5File file_;
  std::unique_ptr<io::SeriesWriter> series_;
  io::XdmfTimeSeries xdmf_;
};

}  // namespace cosim::dem
