// Every data kind the couplings need survives framing unchanged.
#include <gtest/gtest.h>

#include <cmath>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/message.hpp"

namespace cosim::wire {
namespace {

template <typename List>
void fillDoubles(List list, double base) {
  for (unsigned i = 0; i < list.size(); ++i) list.set(i, base + i * 0.5);
}
template <typename List>
void fillInts(List list, std::uint32_t base) {
  for (unsigned i = 0; i < list.size(); ++i) list.set(i, base + i);
}

InMessage roundTrip(const OutMessage& out) { return InMessage::decode(out.frames()); }

TEST(Schema, AdvanceWithEveryCouplingDataKindRoundTrips) {
  OutMessage out;
  auto env = out.envelope();
  env.setSeq(7);
  auto adv = env.getBody().initAdvance();
  adv.setSteps(3);
  adv.setDt(1e-4);
  adv.setTime(0.25);
  adv.setExchange(11);
  auto data = adv.initInputs();
  auto mesh = data.initMeshes(1)[0];
  mesh.setSurface("top");
  fillDoubles(mesh.initPositions(15), 1.0);
  fillDoubles(mesh.initVelocities(15), 2.0);
  fillInts(mesh.initTriangles(12), 0);
  fillInts(mesh.initRowStart(6), 0);
  fillInts(mesh.initNodeIds(5), 10);
  fillDoubles(mesh.initNodeWeights(5), 0.25);
  auto q = data.initQuadratures(1)[0];
  q.setNodesPerPoint(4);
  fillDoubles(q.initShapeValues(8), 0.1);
  auto contacts = data.initContacts(1)[0];
  fillInts(contacts.initTriangleIds(2), 3);
  fillDoubles(contacts.initForces(6), -1.0);
  auto particles = data.initParticles(1)[0];
  particles.setZone("arlequin");
  fillDoubles(particles.initMasses(4), 83.78);
  auto nodal = data.initNodalFields(1)[0];
  nodal.setName("displacement_increment");
  nodal.setComponents(3);
  fillDoubles(nodal.initValues(9), -0.5);
  auto forces = data.initForces(1)[0];
  forces.setTarget(proto::CouplingForces::Target::NODES);
  fillDoubles(forces.initForces(3), 4.0);
  auto hybrid = data.initHybridParticles(1)[0];
  fillDoubles(hybrid.initRadii(2), 0.0093);
  fillDoubles(hybrid.initHorizons(1), 0.03);
  fillDoubles(data.initHybridForces(1)[0].initForces(6), 5.0);
  auto jobs = data.initUnitCellJobs(1)[0];
  fillInts(jobs.initCellIds(2), 100);
  fillDoubles(jobs.initStrainIncrements(18), 1e-6);
  auto results = data.initUnitCellResults(1)[0];
  fillInts(results.initRelaxationSteps(2), 500);
  fillDoubles(results.initStresses(18), -416e3);
  auto w = data.initWeightProfiles(1)[0];
  w.setKind("half-cosine");
  w.setAxis(1);
  w.setStart(8.0);
  w.setEnd(12.0);

  const InMessage in = roundTrip(out);
  auto e = in.envelope();
  EXPECT_EQ(e.getSeq(), 7u);
  ASSERT_TRUE(e.getBody().isAdvance());
  auto a = e.getBody().getAdvance();
  EXPECT_EQ(a.getSteps(), 3u);
  EXPECT_EQ(a.getDt(), 1e-4);
  EXPECT_EQ(a.getExchange(), 11u);
  auto d = a.getInputs();
  EXPECT_EQ(std::string(d.getMeshes()[0].getSurface().cStr()), "top");
  EXPECT_EQ(view(d.getMeshes()[0].getPositions())[14], 1.0 + 14 * 0.5);
  EXPECT_EQ(view(d.getMeshes()[0].getNodeIds())[4], 14u);
  EXPECT_EQ(d.getQuadratures()[0].getNodesPerPoint(), 4u);
  EXPECT_EQ(view(d.getContacts()[0].getForces())[5], -1.0 + 2.5);
  EXPECT_EQ(view(d.getParticles()[0].getMasses())[0], 83.78);
  EXPECT_EQ(d.getNodalFields()[0].getComponents(), 3u);
  EXPECT_EQ(d.getForces()[0].getTarget(), proto::CouplingForces::Target::NODES);
  EXPECT_EQ(view(d.getHybridParticles()[0].getRadii())[1], 0.0093 + 0.5);
  EXPECT_EQ(view(d.getHybridForces()[0].getForces())[0], 5.0);
  EXPECT_EQ(view(d.getUnitCellJobs()[0].getCellIds())[1], 101u);
  EXPECT_EQ(view(d.getUnitCellResults()[0].getRelaxationSteps())[0], 500u);
  EXPECT_EQ(view(d.getUnitCellResults()[0].getStresses())[17], -416e3 + 8.5);
  EXPECT_EQ(d.getWeightProfiles()[0].getEnd(), 12.0);
}

TEST(Schema, ControlMessagesRoundTrip) {
  OutMessage out;
  auto h = out.envelope().getBody().initHello();
  h.setProtocolMajor(proto::PROTOCOL_MAJOR);
  h.setSolverKind("dem");
  h.setInstance("particles");
  auto caps = h.initCapabilities(2);
  caps.set(0, "advance");
  caps.set(1, "checkpoint");
  const InMessage in = roundTrip(out);
  auto hello = in.envelope().getBody().getHello();
  EXPECT_EQ(hello.getProtocolMajor(), proto::PROTOCOL_MAJOR);
  EXPECT_EQ(std::string(hello.getCapabilities()[1].cStr()), "checkpoint");
  EXPECT_EQ(bodyName(in.envelope()), "hello");
}

TEST(Arrays, AddFindViewAndFingerprint) {
  OutMessage out;
  auto arrays = out.envelope().getBody().initAdvanced().initOutputs().initArrays(2);
  const std::vector<double> a{1.0, -0.0, 5e-324, 1.7976931348623157e308};
  addArray(arrays, 0, "a", 2, a);
  addArray(arrays, 1, "b", 1, std::vector<double>{});
  const InMessage in = roundTrip(out);
  proto::NamedArray::Reader found;
  ASSERT_TRUE(findArray(in.envelope().getBody().getAdvanced().getOutputs().getArrays(), "a", found));
  EXPECT_EQ(found.getComponents(), 2u);
  const auto v = view(found.getValues());
  ASSERT_EQ(v.size(), a.size());
  EXPECT_EQ(fingerprint(v), fingerprint(a));
  EXPECT_TRUE(std::signbit(v[1]));
  EXPECT_FALSE(findArray(in.envelope().getBody().getAdvanced().getOutputs().getArrays(), "c", found));
  std::vector<double> flipped = a;
  flipped[1] = 0.0;  // -0.0 and 0.0 compare equal but are different bits
  EXPECT_NE(fingerprint(flipped), fingerprint(a));
}

}  // namespace
}  // namespace cosim::wire
