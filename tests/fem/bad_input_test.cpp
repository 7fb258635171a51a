// Bad input gives errors that name the element, set or dof.
#include <gtest/gtest.h>

#include <cmath>

#include "fem_test_util.hpp"

namespace cosim::fem {
namespace {

template <class Ex, class F>
std::string messageOf(F&& f) {
  try {
    f();
  } catch (const Ex& e) {
    return e.what();
  }
  return "<no exception>";
}

TEST(FemBadInput, InvertedElementIsNamed) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {3, 1, 1}, {3, 1, 1});
  std::swap(mesh.elements[1][0], mesh.elements[1][4]);  // turns element 1 inside out
  std::swap(mesh.elements[1][1], mesh.elements[1][5]);
  std::swap(mesh.elements[1][2], mesh.elements[1][6]);
  std::swap(mesh.elements[1][3], mesh.elements[1][7]);
  for (const char* f : {"full", "incompatible-modes", "one-point"}) {
    const std::string msg = messageOf<InputError>([&] { test::makeModel(mesh, f, 1e8, 0.3, 1000.0); });
    EXPECT_NE(msg.find("element 1 is inverted"), std::string::npos) << msg;
  }
}

TEST(FemBadInput, DegenerateElementIsNamed) {
  Mesh mesh = makeBoxMesh({0, 0, 0}, {2, 1, 1}, {2, 1, 1});
  for (Index n : {mesh.elements[0][4], mesh.elements[0][5], mesh.elements[0][6], mesh.elements[0][7]})
    mesh.X[3 * n + 2] = 0.0;  // flattens element 0
  const std::string msg = messageOf<InputError>([&] { test::makeModel(mesh, "full", 1e8, 0.3, 1000.0); });
  EXPECT_NE(msg.find("element 0"), std::string::npos) << msg;
}

TEST(FemBadInput, MissingSetIsNamed) {
  const Mesh mesh = makeBoxMesh({0, 0, 0}, {1, 1, 1}, {1, 1, 1});
  const std::string msg = messageOf<InputError>([&] { mesh.nodeSet("clamp", "boundary[0].set"); });
  EXPECT_NE(msg.find("'clamp'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("boundary[0].set"), std::string::npos) << msg;
}

TEST(FemBadInput, UnknownNamesListTheKnownOnes) {
  const std::string msg = messageOf<InputError>([&] { FormulationRegistry::instance().create("q8"); });
  EXPECT_NE(msg.find("'q8'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("one-point"), std::string::npos) << msg;
  const std::string msg2 = messageOf<InputError>([&] { MaterialRegistry::instance().create("clay", MaterialParams{1, 0, 1}); });
  EXPECT_NE(msg2.find("st-venant-kirchhoff"), std::string::npos) << msg2;
}

TEST(FemBadInput, UnconstrainedStaticModelIsSingular) {
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {2, 1, 1}, {2, 1, 1}), "full", 1e8, 0.3, 1000.0);
  model->addTraction(model->mesh().faceSet("xmax"), Vec3(1e3, 0, 0));
  State state;
  state.resize(model->numDofs());
  const std::string msg = messageOf<SolveError>([&] { solveStatic(*model, state, NewtonOptions{}); });
  EXPECT_NE(msg.find("singular"), std::string::npos) << msg;
  EXPECT_NE(msg.find("node"), std::string::npos) << msg;
}

TEST(FemBadInput, NaNIsReportedWithTheNode) {
  auto model = test::makeModel(makeBoxMesh({0, 0, 0}, {2, 1, 1}, {2, 1, 1}), "one-point", 1e8, 0.3, 1000.0);
  model->couplingForce()[3 * 5 + 1] = std::nan("");
  auto integrator = makeCentralDifference(*model, {});
  State state;
  state.resize(model->numDofs());
  integrator->initialise(state);
  const std::string msg = messageOf<SolveError>([&] { integrator->step(state, 1e-6); });
  EXPECT_NE(msg.find("node 5"), std::string::npos) << msg;
}

TEST(FemBadInput, MaterialConstantsChecked) {
  const std::string msg = messageOf<InputError>([&] { MaterialRegistry::instance().create("neo-hookean", MaterialParams{1e8, 0.5, 1000}); });
  EXPECT_NE(msg.find("nu"), std::string::npos) << msg;
}

}  // namespace
}  // namespace cosim::fem
