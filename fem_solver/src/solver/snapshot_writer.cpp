#include "cosim/fem/solver/snapshot_writer.hpp"


namespace cosim::fem {

SnapshotWriter::SnapshotWriter(const std::filesystem::path& h5Path, const Model& model, bool resuming)
    : file_(io::H5File::createOrKeep(h5Path, resuming)),
      nodes_(model.numNodes()),
      elements_(model.mesh().numElements()),
      xdmf_(h5Path, "fem", {"Hexahedron", "/mesh/topology", 8, model.mesh().numElements()}, "position",
            {{"displacement", "displacement", 3},
             {"velocity", "velocity", 3},
             {"stress", "stress", 6, io::XdmfTimeSeries::Center::cell},
             {"strain", "strain", 6, io::XdmfTimeSeries::Center::cell}}) {
  if (file_.exists("/mesh/topology")) return;  // a resumed run's file
  const Mesh& mesh = model.mesh();
  std::vector<std::uint32_t> topology;
  topology.reserve(8 * elements_);
  for (const Hex& h : mesh.elements) topology.insert(topology.end(), h.begin(), h.end());
  file_.writeArray("/mesh/coordinates", mesh.X, 3);
  file_.writeArray("/mesh/topology", topology, 8);
  file_.setAttribute("/mesh", "formulation", model.formulation().name());
  file_.setAttribute("/mesh", "material", model.material().name());
  file_.flush();
}

void SnapshotWriter::write(const Model& model, const State& state) {
  const std::string g = "/snapshots/" + std::to_string(state.step);
  std::vector<double> x(model.mesh().X);
  for (std::size_t d = 0; d < x.size(); ++d) x[d] += state.u[d];
  // Element averages of Cauchy stress sigma = F S F^T / J and Green strain (Voigt xx yy zz xy yz xz).
  const int np = model.formulation().pointsPerElement();
  std::vector<MaterialPointState> pts(static_cast<std::size_t>(np));
  std::vector<double> stress(6 * elements_), strain(6 * elements_);
  for (std::size_t e = 0; e < elements_; ++e) {
    model.formulation().pointStates(e, model.gather(e, state.u), pts.data());
    Mat3 s = Mat3::Zero(), eps = Mat3::Zero();
    for (const auto& p : pts) {
      s += p.F * p.S * p.F.transpose() / p.F.determinant();
      eps += 0.5 * (p.F.transpose() * p.F - Mat3::Identity());
    }
    s /= np;
    eps /= np;
    const double sv[6] = {s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(1, 2), s(0, 2)};
    const double ev[6] = {eps(0, 0), eps(1, 1), eps(2, 2), eps(0, 1), eps(1, 2), eps(0, 2)};
    std::copy(sv, sv + 6, stress.begin() + static_cast<long>(6 * e));
    std::copy(ev, ev + 6, strain.begin() + static_cast<long>(6 * e));
  }
  file_.writeArray(g + "/position", x, 3);
  file_.writeArray(g + "/displacement", state.u, 3);
  file_.writeArray(g + "/velocity", state.v, 3);
  file_.writeArray(g + "/stress", stress, 6);
  file_.writeArray(g + "/strain", strain, 6);
  file_.setAttribute(g, "time", state.time);
  file_.flush();
  xdmf_.addStep(state.step, state.time, nodes_);
}

}  // namespace cosim::fem
