// HDF5 point snapshots + XDMF sidecar (Polyvertex topology).
#include <fstream>
#include <sstream>

#include "cosim/pd/snapshot.hpp"

namespace cosim::pd {

SnapshotWriter::SnapshotWriter(const std::filesystem::path& h5Path)
    : path_(h5Path), file_(cosim::io::H5File::create(h5Path)) {
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
  entries_.push_back({system.stepCount(), system.time(), n});
  writeXdmf();
}

void SnapshotWriter::writeXdmf() const {
  auto xmf = path_;
  xmf.replace_extension(".xmf");
  std::ofstream out(xmf);
  const std::string h5 = path_.filename().string();
  out << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
      << "  <Grid Name=\"pd\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const auto& e : entries_) {
    std::ostringstream gs;
    gs << h5 << ":/snapshots/" << e.step;
    const std::string g = gs.str();
    auto item = [&](const std::string& name, int cols) {
      std::ostringstream s;
      s << "<DataItem Dimensions=\"" << e.n;
      if (cols > 1) s << " " << cols;
      s << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << g << "/" << name << "</DataItem>";
      return s.str();
    };
    auto attr = [&](const std::string& name, const char* type, int cols) {
      out << "    <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\"Node\">"
          << item(name, cols) << "</Attribute>\n";
    };
    out << "   <Grid Name=\"step_" << e.step << "\" GridType=\"Uniform\">\n"
        << "    <Time Value=\"" << e.time << "\"/>\n"
        << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << e.n
        << "\" NodesPerElement=\"1\"/>\n"
        << "    <Geometry GeometryType=\"XYZ\">" << item("position", 3) << "</Geometry>\n";
    attr("displacement", "Vector", 3);
    attr("velocity", "Vector", 3);
    attr("damage", "Scalar", 1);
    attr("strain", "Tensor6", 6);
    attr("von_mises", "Scalar", 1);
    out << "   </Grid>\n";
  }
  out << "  </Grid>\n </Domain>\n</Xdmf>\n";
}

}  // namespace cosim::pd
