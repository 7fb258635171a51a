#include "cosim/dem/io/snapshot_writer.hpp"

#include <filesystem>
#include <fstream>

#include "cosim/dem/measure/measures.hpp"

namespace cosim::dem {
namespace {

std::vector<double> flat(const std::vector<Vec3>& v) {
  std::vector<double> out(3 * v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    out[3 * i] = v[i].x;
    out[3 * i + 1] = v[i].y;
    out[3 * i + 2] = v[i].z;
  }
  return out;
}

}  // namespace

SnapshotWriter::SnapshotWriter(const std::string& h5Path)
    : h5Path_(h5Path),
      xmfPath_(std::filesystem::path(h5Path).replace_extension(".xmf").string()),
      file_(io::H5File::create(h5Path)) {
  series_ = std::make_unique<io::SeriesWriter>(file_);
}

SnapshotWriter::~SnapshotWriter() = default;

void SnapshotWriter::write(const DemSystem& s) {
  const Particles& p = s.particles;
  const std::string g = "/snapshots/" + std::to_string(s.step);
  file_.group(g);
  file_.setAttribute(g, "time", s.time);
  file_.writeArray(g + "/positions", flat(p.x), 3);
  file_.writeArray(g + "/velocities", flat(p.v), 3);
  file_.writeArray(g + "/angular_velocities", flat(p.omega), 3);
  file_.writeArray(g + "/radii", p.radius, 1);
  file_.writeArray(g + "/ids", p.id, 1);
  const Energies e = energies(s);
  series_->append("time", s.time);
  series_->append("step", static_cast<double>(s.step));
  series_->append("kinetic", e.kinetic());
  series_->append("elastic", e.elastic);
  series_->append("potential", e.potential);
  series_->append("dissipated", e.dissipated);
  series_->append("external_work", e.externalWork);
  series_->append("coordination", coordinationNumber(s));
  series_->flush();
  entries_.push_back({s.step, s.time, p.size()});
  writeXdmf();
}

void SnapshotWriter::writeXdmf() const {
  const std::string h5 = std::filesystem::path(h5Path_).filename().string();
  std::ofstream x(xmfPath_);
  x << "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
       "  <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Entry& e : entries_) {
    const std::string g = h5 + ":/snapshots/" + std::to_string(e.step);
    const std::string n = std::to_string(e.count);
    x << "   <Grid Name=\"step" << e.step << "\" GridType=\"Uniform\">\n"
      << "    <Time Value=\"" << e.time << "\"/>\n"
      << "    <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n << "\" NodesPerElement=\"1\"/>\n"
      << "    <Geometry GeometryType=\"XYZ\">\n"
      << "     <DataItem Dimensions=\"" << n << " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << g
      << "/positions</DataItem>\n    </Geometry>\n";
    const auto attr = [&](const char* name, const char* type, const char* dims, const char* path, const char* num) {
      x << "    <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\"Node\">\n"
        << "     <DataItem Dimensions=\"" << n << dims << "\" NumberType=\"" << num << "\" Precision=\""
        << (num[0] == 'F' ? 8 : 4) << "\" Format=\"HDF\">" << g << path << "</DataItem>\n    </Attribute>\n";
    };
    attr("radius", "Scalar", "", "/radii", "Float");
    attr("velocity", "Vector", " 3", "/velocities", "Float");
    attr("angular_velocity", "Vector", " 3", "/angular_velocities", "Float");
    attr("id", "Scalar", "", "/ids", "UInt");
    x << "   </Grid>\n";
  }
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
}

}  // namespace cosim::dem
