#include "cosim/io/xdmf.hpp"

#include "cosim/io/h5_file.hpp"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace cosim::io {
namespace {

const char* attributeType(int components) {
  switch (components) {
    case 1: return "Scalar";
    case 3: return "Vector";
    case 6: return "Tensor6";
    case 9: return "Tensor";
    default: throw std::invalid_argument("XDMF has no attribute type with " + std::to_string(components) + " components");
  }
}

std::string dataItem(std::size_t rows, int cols, bool integer, const std::string& source) {
  std::ostringstream s;
  s << "<DataItem Dimensions=\"" << rows;
  if (cols > 1) s << ' ' << cols;
  s << "\" NumberType=\"" << (integer ? "UInt" : "Float") << "\" Precision=\"" << (integer ? 4 : 8)
    << "\" Format=\"HDF\">" << source << "</DataItem>";
  return s.str();
}

}  // namespace

XdmfTimeSeries::XdmfTimeSeries(std::filesystem::path h5Path, std::string gridName, Topology topology,
                               std::string geometry, std::vector<Field> fields)
    : xmfPath_(std::filesystem::path(h5Path).replace_extension(".xmf")),
      h5Name_(h5Path.filename().string()),
      gridName_(std::move(gridName)),
      topology_(std::move(topology)),
      geometry_(std::move(geometry)),
      fields_(std::move(fields)) {
  for (const auto& f : fields_) (void)attributeType(f.components);
}

void XdmfTimeSeries::addStep(std::uint64_t step, double time, std::size_t points) {
  steps_.push_back({step, time, points});
  grids_ += grid(steps_.back());
  write();
}

void XdmfTimeSeries::resumeAt(H5File& file, std::uint64_t step) {
  // The snapshots after the checkpoint are written again; the file is rewritten
  // without them (a killed writer may have left them unreadable, see H5File::rewriteWithout).
  std::vector<std::string> later;
  for (const std::string& name : file.children("/snapshots"))
    if (!name.empty() && name.find_first_not_of("0123456789") == std::string::npos && std::stoull(name) > step)
      later.push_back("/snapshots/" + name);
  file.rewriteWithout(later);
  steps_.clear();
  for (const std::string& name : file.children("/snapshots")) {
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string group = "/snapshots/" + name;
    const auto shape = file.exists(group + "/" + geometry_) ? file.shape(group + "/" + geometry_) : std::vector<std::size_t>{};
    steps_.push_back({std::stoull(name), file.attribute(group, "time", 0.0), shape.empty() ? 0 : shape[0]});
  }
  std::sort(steps_.begin(), steps_.end(), [](const Step& a, const Step& b) { return a.step < b.step; });
  grids_.clear();
  for (const auto& s : steps_) grids_ += grid(s);
  file.flush();
  write();
}

std::string XdmfTimeSeries::grid(const Step& s) const {
  std::ostringstream out;
  out << std::setprecision(17);
  const std::string group = h5Name_ + ":/snapshots/" + std::to_string(s.step) + "/";
  const std::size_t cells = topology_.cells ? topology_.cells : s.points;
  out << "   <Grid Name=\"step " << s.step << "\" GridType=\"Uniform\">\n"
      << "    <Time Value=\"" << s.time << "\"/>\n"
      << "    <Topology TopologyType=\"" << topology_.type << "\" NumberOfElements=\"" << cells << "\"";
  if (topology_.dataset.empty())
    out << " NodesPerElement=\"" << topology_.nodesPerCell << "\"/>\n";
  else
    out << ">" << dataItem(cells, topology_.nodesPerCell, true, h5Name_ + ":" + topology_.dataset) << "</Topology>\n";
  out << "    <Geometry GeometryType=\"XYZ\">" << dataItem(s.points, 3, false, group + geometry_) << "</Geometry>\n";
  for (const auto& f : fields_) {
    const bool cell = f.center == Center::cell;
    out << "    <Attribute Name=\"" << f.name << "\" AttributeType=\"" << attributeType(f.components)
        << "\" Center=\"" << (cell ? "Cell" : "Node") << "\">"
        << dataItem(cell ? cells : s.points, f.components, f.integer, group + f.dataset) << "</Attribute>\n";
  }
  out << "   </Grid>\n";
  return out.str();
}

// The whole sidecar goes to a temporary file renamed over the old one, so a
// crash leaves the last complete sidecar. Each step's grid is formatted once
// (grids_): formatting every step again on every snapshot made a run with
// snapshots every step quadratic in time (3200 snapshots of 2 spheres: over
// 60 s); what is left per snapshot is one write of the text.
void XdmfTimeSeries::write() const {
  const auto tmp = std::filesystem::path(xmfPath_.string() + ".tmp");
  {
    std::ofstream out(tmp);
    out << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
        << "  <Grid Name=\"" << gridName_ << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n"
        << grids_ << "  </Grid>\n </Domain>\n</Xdmf>\n";
    if (!out) throw std::runtime_error(tmp.string() + ": cannot write the XDMF sidecar");
  }
  std::filesystem::rename(tmp, xmfPath_);
}

}  // namespace cosim::io
