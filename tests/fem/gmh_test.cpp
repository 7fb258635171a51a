// GMH loop through the solver interface (Liu 2016 Sec. 2.3, Eqs. 60-62): the
// FEM with the 'external' material sends corotational strain increments per
// material point, a test-side linear elastic "unit cell" (sigma^R += C :
// d eps^R, standing in for the DEM worker) returns corotational stresses, and
// the explicit bar wave still travels at sqrt(E / rho) within 1 %.
#include <capnp/message.h>
#include <gtest/gtest.h>

#include <cmath>

#include "cosim/fem/material/material.hpp"
#include "cosim/fem/solver/fem_solver.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::fem {
namespace {

TEST(FemGmh, ExternalStressBarWave) {
  const double E = 1e8, rho = 1000.0, L = 4.0, sigma0 = 1e4;
  const std::string yaml = R"(solvers:
  - name: bar
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [4.0, 0.01, 0.01], divisions: [400, 1, 1]}}
      material: {model: external, E: 1.0e8, nu: 0.0, density: 1000}
      formulation: one-point
      loads: [{set: xmin, traction: [1.0e4, 0, 0]}]
      integrator: {type: central-difference}
)";
  FemSolver solver;
  capnp::MallocMessageBuilder setupIn, setupOut;
  solver.setup({"gmh.yaml", yaml, "bar", "", setupIn.initRoot<proto::CouplingData>().asReader()},
               setupOut.initRoot<proto::CouplingData>());
  const double dt = 0.9 * solver.criticalDt();
  const Mat6 C = isotropicTangent(0.0, E / 2.0);  // nu = 0: lambda = 0, mu = E / 2
  const std::size_t points = solver.model().mesh().numElements();
  std::vector<double> cellStress(9 * points, 0.0);
  std::vector<Index> probe = solver.model().mesh().nodesInBox({L / 2, -1, -1}, {L / 2, 1, 1});
  ASSERT_EQ(probe.size(), 4u);
  const double c = std::sqrt(E / rho), vPlateau = sigma0 / (rho * c);
  double arrival = -1.0, vPrev = 0.0, tPrev = 0.0;
  std::size_t jobsSeen = 0;
  while (solver.time() < 0.7 * L / c) {
    capnp::MallocMessageBuilder inMsg, outMsg;
    auto in = inMsg.initRoot<proto::CouplingData>();
    auto results = in.initUnitCellResults(1)[0];
    auto ids = results.initCellIds(static_cast<unsigned>(points));
    auto stresses = results.initStresses(static_cast<unsigned>(9 * points));
    for (unsigned p = 0; p < points; ++p) ids.set(p, p);
    for (unsigned k = 0; k < 9 * points; ++k) stresses.set(k, cellStress[k]);
    wire::AdvanceRequest request;
    request.steps = 1;
    request.dt = dt;
    request.inputs = in.asReader();
    auto out = outMsg.initRoot<proto::CouplingData>();
    solver.advance(request, out);
    // The "unit cell": hypoelastic update in the corotational frame.
    const auto jobs = out.asReader().getUnitCellJobs();
    ASSERT_EQ(jobs.size(), 1u);
    const auto inc = wire::view(jobs[0].getStrainIncrements());
    ASSERT_EQ(inc.size(), 9 * points);
    jobsSeen += jobs[0].getCellIds().size();
    for (std::size_t p = 0; p < points; ++p) {
      const Mat3 d = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(inc.data() + 9 * p);
      const Mat3 ds = fromVoigtStress(C * toVoigtStrain(d));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) cellStress[9 * p + static_cast<std::size_t>(3 * i + j)] += ds(i, j);
    }
    // Between exchanges the state holds the half-step velocity v_{n+1/2}.
    double v = 0.0;
    for (Index n : probe) v += solver.state().v[3 * n] / 4.0;
    const double t = solver.time() - 0.5 * dt;
    if (arrival < 0 && v >= 0.5 * vPlateau) arrival = tPrev + (0.5 * vPlateau - vPrev) / (v - vPrev) * (t - tPrev);
    vPrev = v;
    tPrev = t;
  }
  const double expected = 0.5 * L / c;
  std::printf("[gmh] %zu unit-cell jobs, wave arrival %.6e s, expected %.6e s, error %.3f %%\n", jobsSeen, arrival,
              expected, 100.0 * std::abs(arrival - expected) / expected);
  ASSERT_GT(arrival, 0.0);
  EXPECT_LT(std::abs(arrival - expected) / expected, 0.01);
}

// One free element spinning about z (v = w e_z x (x - c)): the strain
// increment the cell gets over the first step, with the stress it returned
// (a uniaxial sigma_xx) and the element's F after it.
struct SpinningElement {
  Mat3 increment;
  std::string error;
};
SpinningElement spinOneStep(const std::string& frame) {
  const std::string yaml = R"(solvers:
  - name: block
    kind: fem
    params:
      mesh: {box: {min: [-0.5, -0.5, -0.5], max: [0.5, 0.5, 0.5], divisions: [1, 1, 1]}}
      material: {model: external, E: 1.0e6, nu: 0.2, density: 1000)" + frame + R"(}
      formulation: one-point
      initial_velocity: {gradient: {x: [0, -2.0, 0], y: [2.0, 0, 0]}}
      integrator: {type: central-difference}
)";
  SpinningElement out;
  FemSolver solver;
  capnp::MallocMessageBuilder setupIn, setupOut;
  try {
    solver.setup({"spin.yaml", yaml, "block", "", setupIn.initRoot<proto::CouplingData>().asReader()},
                 setupOut.initRoot<proto::CouplingData>());
  } catch (const std::exception& e) {
    out.error = e.what();
    return out;
  }
  capnp::MallocMessageBuilder inMsg, outMsg;
  wire::AdvanceRequest request;
  request.steps = 1;
  request.dt = 1e-3;  // 2e-3 rad of spin
  request.inputs = inMsg.initRoot<proto::CouplingData>().asReader();
  auto o = outMsg.initRoot<proto::CouplingData>();
  solver.advance(request, o);
  const auto inc = wire::view(o.asReader().getUnitCellJobs()[0].getStrainIncrements());
  out.increment = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(inc.data());
  return out;
}

TEST(FemGmh, SpatialFrameSendsTheSpinCorotationalDoesNot) {
  // Liu's corotational increments (Eqs. 60-61) see no first-order strain in
  // a spin; frame: spatial sends the spin itself, w dt = 2e-3 (skew: the cell
  // turns). Both carry the true stretch of the step, (w dt)^2 / 2 = 2e-6: the
  // explicit step moves the nodes along the tangent x + dt W x.
  const auto corot = spinOneStep("");
  ASSERT_TRUE(corot.error.empty()) << corot.error;
  EXPECT_LT(corot.increment.cwiseAbs().maxCoeff(), 3e-6);
  const auto spatial = spinOneStep(", frame: spatial");
  ASSERT_TRUE(spatial.error.empty()) << spatial.error;
  const Mat3 skew = 0.5 * (spatial.increment - spatial.increment.transpose());
  EXPECT_NEAR(skew(1, 0), 2e-3, 1e-8);
  EXPECT_NEAR(skew(0, 1), -2e-3, 1e-8);
  EXPECT_LT((0.5 * (spatial.increment + spatial.increment.transpose())).cwiseAbs().maxCoeff(), 3e-6);
  // Bad keys are named.
  const auto bad = spinOneStep(", frame: lab");
  EXPECT_NE(bad.error.find("material.frame must be corotational or spatial, not 'lab'"), std::string::npos)
      << bad.error;
}

TEST(FemGmh, FrameIsForTheExternalMaterialOnly) {
  const std::string yaml = R"(solvers:
  - name: block
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [1, 1, 1], divisions: [1, 1, 1]}}
      material: {model: st-venant-kirchhoff, E: 1.0e6, nu: 0.2, density: 1000, frame: spatial}
      integrator: {type: central-difference}
)";
  FemSolver solver;
  capnp::MallocMessageBuilder setupIn, setupOut;
  try {
    solver.setup({"svk.yaml", yaml, "block", "", setupIn.initRoot<proto::CouplingData>().asReader()},
                 setupOut.initRoot<proto::CouplingData>());
    ADD_FAILURE() << "frame on a St. Venant-Kirchhoff material was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("frame applies to model: external only"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("svk.yaml:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cosim::fem
