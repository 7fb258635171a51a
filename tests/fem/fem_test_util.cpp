#include "fem_test_util.hpp"

namespace cosim::fem::test {

std::unique_ptr<Model> makeModel(Mesh mesh, const std::string& formulation, double E, double nu, double rho,
                                 const std::string& material, double hourglass) {
  MaterialParams p{E, nu, rho};
  FormulationOptions options;
  options.hourglassCoefficient = hourglass;
  return std::make_unique<Model>(std::move(mesh), MaterialRegistry::instance().create(material, p),
                                 FormulationRegistry::instance().create(formulation), options);
}

CantileverResult solveCantilever(const std::string& formulation, int nx, int ny, int nz, double P, double hourglass) {
  const double b = 0.8, L = 12.0;
  auto model = makeModel(makeBoxMesh({0, 0, 0}, {b, L, b}, {nx, ny, nz}), formulation, 1e8, 0.0, 1000.0,
                         "st-venant-kirchhoff", hourglass);
  for (Index n : model->mesh().nodeSet("ymin"))
    for (int d = 0; d < 3; ++d) model->prescribe(n, d, Prescribed::Kind::displacement, 0.0);
  model->addTraction(model->mesh().faceSet("ymax"), Vec3(0, 0, -P / (b * b)));
  State state;
  state.resize(model->numDofs());
  solveStatic(*model, state, NewtonOptions{});
  CantileverResult r;
  const auto& tip = model->mesh().nodeSet("ymax");
  for (Index n : tip) r.tipDeflection += -state.u[3 * n + 2];
  r.tipDeflection /= static_cast<double>(tip.size());
  std::vector<double> f;
  ElementEnergy en;
  model->internalForce(state.u, f, en);
  r.strainEnergy = en.strain;
  r.hourglassEnergy = en.hourglass;
  return r;
}

double timoshenkoTip(double P, double L, double b, double h, double E, double nu) {
  const double I = b * h * h * h / 12.0, A = b * h, G = E / (2.0 * (1.0 + nu));
  const double k = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
  return P * L * L * L / (3.0 * E * I) + P * L / (k * G * A);
}

}  // namespace cosim::fem::test
