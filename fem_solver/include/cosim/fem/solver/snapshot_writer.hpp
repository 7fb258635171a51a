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

namespace cosim::fem {

class SnapshotWriter {
 public:
  SnapshotWriter(const std::filesystem::path& h5Path, const Model& model);
  void write(const Model& model, const State& state);
  const std::filesystem::path& xdmfPath() const { return xdmf_; }

 private:
  void writeXdmf() const;
  io::H5File file_;
  std::filesystem::path xdmf_;
  std::string h5Name_;
  std::size_t nodes_ = 0, elements_ = 0;
  std::vector<std::pair<std::uint64_t, double>> steps_;
};

}  // namespace cosim::fem
