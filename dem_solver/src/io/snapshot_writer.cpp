#include "cosim/dem/io/snapshot_writer.hpp"

#include <filesystem>

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
      file_(io::H5File::create(h5Path)),
      xdmf_(h5Path, "particles", {}, "positions",
            {{"radius", "radii", 1},
             {"velocity", "velocities", 3},
             {"angular_velocity", "angular_velocities", 3},
             {"id", "ids", 1, io::XdmfTimeSeries::Center::node, true}}) {
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
  xdmf_.addStep(s.step, s.time, p.size());
}

}  // namespace cosim::dem
