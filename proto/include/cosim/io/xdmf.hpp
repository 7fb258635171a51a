#pragma once
// The XDMF sidecar of an HDF5 file that holds one group per snapshot
// (/snapshots/<step>): a temporal collection of grids that ParaView opens
// directly. Every solver describes its snapshots once (topology, geometry,
// fields) and adds steps; the sidecar is rewritten atomically each time, so a
// crash leaves the last complete one.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cosim::io {

class H5File;

class XdmfTimeSeries {
 public:
  enum class Center { node, cell };

  struct Field {
    std::string name;         // as ParaView shows it
    std::string dataset;      // inside the snapshot group, e.g. "velocity"
    int components = 1;       // 1 scalar, 3 vector, 6 symmetric tensor, 9 tensor
    Center center = Center::node;
    bool integer = false;     // stored as 32-bit unsigned integers
  };

  struct Topology {
    std::string type = "Polyvertex";  // or "Hexahedron" ...
    std::string dataset;              // absolute connectivity dataset; empty for Polyvertex
    int nodesPerCell = 1;
    std::size_t cells = 0;            // fixed cell count (0: one cell per point, for Polyvertex)
  };

  /// geometry: the dataset inside each snapshot group with the point positions (n x 3).
  XdmfTimeSeries(std::filesystem::path h5Path, std::string gridName, Topology topology, std::string geometry,
                 std::vector<Field> fields);

  /// Records snapshot /snapshots/<step> with `points` points and rewrites the sidecar.
  void addStep(std::uint64_t step, double time, std::size_t points);
  /// A resumed run: drops the snapshots in `file` after `step` (the run
  /// writes them again), adopts the ones before it and rewrites the sidecar.
  void resumeAt(H5File& file, std::uint64_t step);
  const std::filesystem::path& path() const { return xmfPath_; }

 private:
  struct Step {
    std::uint64_t step;
    double time;
    std::size_t points;
  };
  void write() const;
  /// The <Grid> element of one step.
  std::string grid(const Step& s) const;
  std::filesystem::path xmfPath_;
  std::string h5Name_;
  std::string gridName_;
  Topology topology_;
  std::string geometry_;
  std::vector<Field> fields_;
  std::vector<Step> steps_;
  std::string grids_;  // the steps' <Grid> elements, formatted once each
};

}  // namespace cosim::io
