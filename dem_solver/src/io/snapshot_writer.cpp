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

void append(std::vector<double>& out, const Vec3& v) { out.insert(out.end(), {v.x, v.y, v.z}); }

void pairContacts(const DemSystem& s, ContactSnapshot& c) {
  const Particles& p = s.particles;
  const NeighborList& nl = s.neighbors;
  for (std::size_t i = 0; i + 1 < nl.rowStart.size(); ++i)
    for (std::uint32_t k = nl.rowStart[i]; k < nl.rowStart[i + 1]; ++k) {
      if (!nl.touching[k]) continue;
      // The contact point of the force loop: mid-overlap on the centre line.
      const Vec3 d = s.pairVector(i, k);
      const double dist = norm(d);
      const double overlap = p.radius[i] + p.radius[nl.partner[k]] - dist;
      c.pairs.insert(c.pairs.end(), {static_cast<std::uint32_t>(i), nl.partner[k]});
      append(c.pairPoints, p.x[i] - ((p.radius[i] - 0.5 * overlap) / dist) * d);
      append(c.pairForces, s.pairForce[k].force);
    }
}

void planeContacts(const DemSystem& s, ContactSnapshot& c) {
  const Particles& p = s.particles;
  for (std::size_t w = 0; w < s.planes.size(); ++w) {
    const PlaneWall& wall = s.planes[w];
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double dist = wall.distance(p.x[i]);
      const double overlap = p.radius[i] - dist;
      if (overlap <= 0.0) continue;
      // The force loop's evaluation (DemSystem::gatherForces) with dt = 0 on a copy of the history.
      Vec3 shear = w < s.planeShear.size() && i < s.planeShear[w].size() ? s.planeShear[w][i] : Vec3{};
      const Vec3 ci = -(p.radius[i] - 0.5 * overlap) * wall.normal;
      const Vec3 vrel = p.v[i] + cross(p.omega[i], ci) - wall.velocity;
      double lost = 0.0;
      const Vec3 f = s.contactLaw().force(wall.normal, overlap, vrel, p.radius[i], p.mass[i],
                                          s.materials.pair(p.material[i], wall.material), 0.0, shear, lost);
      c.wallParticles.push_back(static_cast<std::uint32_t>(i));
      append(c.wallPoints, p.x[i] - dist * wall.normal);
      append(c.wallForces, p.weight[i] * f);
    }
  }
}

void meshContacts(const DemSystem& s, ContactSnapshot& c) {
  for (const TriangleWallGroup& m : s.meshes)
    for (const TriangleContact& tc : m.contacts) {
      const auto& tri = m.triangles[tc.triangle];
      c.wallParticles.push_back(tc.particle);
      append(c.wallPoints, tc.bary[0] * m.vertices[tri[0]] + tc.bary[1] * m.vertices[tri[1]] +
                               tc.bary[2] * m.vertices[tri[2]]);
      append(c.wallForces, -1.0 * tc.force);  // stored as the force on the wall
    }
}

}  // namespace

ContactSnapshot contactSnapshot(const DemSystem& system) {
  ContactSnapshot c;
  pairContacts(system, c);
  planeContacts(system, c);
  meshContacts(system, c);
  return c;
}

SnapshotWriter::SnapshotWriter(const std::string& h5Path, bool resuming)
    : h5Path_(h5Path),
      file_(io::H5File::createOrKeep(h5Path, resuming)),
      xdmf_(h5Path, "particles", {}, "positions",
            {{"radius", "radii", 1},
             {"velocity", "velocities", 3},
             {"angular_velocity", "angular_velocities", 3},
             {"id", "ids", 1, io::XdmfTimeSeries::Center::node, true}}) {
  series_ = std::make_unique<io::SeriesWriter>(file_);
}

SnapshotWriter::~SnapshotWriter() = default;

void SnapshotWriter::resumeAt(std::uint64_t step) {
  // Every series row belongs to a snapshot: keep the rows of the steps kept.
  std::size_t rows = 0;
  if (file_.exists("/series/step"))
    for (double s : file_.readArray("/series/step")) rows += s <= static_cast<double>(step) ? 1 : 0;
  xdmf_.resumeAt(file_, step);  // rewrites the file: before the series adopt its datasets
  series_->resumeAt(rows);
}

void SnapshotWriter::write(const DemSystem& s) {
  const Particles& p = s.particles;
  const std::string g = "/snapshots/" + std::to_string(s.step);
  file_.group(g);
  file_.setAttribute(g, "time", s.time);
  file_.writeArray(g + "/positions", flat(p.x), 3);
  file_.writeArray(g + "/velocities", flat(p.v), 3);
  file_.writeArray(g + "/angular_velocities", flat(p.omega), 3);
  file_.writeArray(g + "/radii", p.radius, 1);
  file_.writeArray(g + "/masses", p.mass, 1);
  file_.writeArray(g + "/ids", p.id, 1);
  // Contact points of periodic images lie a cell away from one partner: readers that need
  // branch vectors (the CG stress) must know.
  file_.setAttribute(g, "periodic", s.cell.enabled ? 1.0 : 0.0);
  const ContactSnapshot c = contactSnapshot(s);
  file_.group(g + "/contacts");
  file_.writeArray(g + "/contacts/pairs", c.pairs, 2);
  file_.writeArray(g + "/contacts/pair_points", c.pairPoints, 3);
  file_.writeArray(g + "/contacts/pair_forces", c.pairForces, 3);
  file_.writeArray(g + "/contacts/wall_particles", c.wallParticles, 1);
  file_.writeArray(g + "/contacts/wall_points", c.wallPoints, 3);
  file_.writeArray(g + "/contacts/wall_forces", c.wallForces, 3);
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
