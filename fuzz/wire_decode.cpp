// Fuzz target: a message as it arrives on a socket (header frame + segment
// frames) decoded by wire::InMessage::decode and then read field by field,
// everywhere, through Cap'n Proto's dynamic API: what the solver host and the
// coupler's peer session do with every frame they receive. A malformed input
// must end in MalformedMessage or a kj::Exception (both are answered as a
// malformed message by the readers), never in a crash, a leak or a hang.
//
// Input layout: byte 0 picks the number of frames (1 + b % 5); each frame but
// the last takes a 2-byte little-endian length from the input, the last the rest.
#include <kj/exception.h>
#include <zmq.hpp>

#include <cstdint>
#include <cstring>
#include <vector>

#include "cosim/wire/message.hpp"
#include "fuzz_support.hpp"
#include "fuzz_target.hpp"

namespace {

std::vector<zmq::message_t> frames(const std::uint8_t* data, std::size_t size) {
  std::vector<zmq::message_t> out;
  if (size == 0) return out;
  const std::size_t count = 1 + data[0] % 5;
  std::size_t at = 1;
  for (std::size_t i = 0; i < count; ++i) {
    std::size_t length = size - at;
    if (i + 1 < count) {
      if (at + 2 > size) break;
      length = std::min<std::size_t>(data[at] | (data[at + 1] << 8), size - at - 2);
      at += 2;
    }
    out.emplace_back(data + at, length);
    at += length;
  }
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const auto message = cosim::wire::InMessage::decode(frames(data, size));
    cosim::fuzz::readEverywhere(message.envelope());
    (void)cosim::wire::bodyName(message.envelope());
  } catch (const cosim::wire::MalformedMessage&) {
  } catch (const kj::Exception&) {
  }
  return 0;
}

namespace cosim::fuzz {

// Seeds: one message of each kind the protocol uses, with arrays, in the input layout above.
std::vector<std::vector<std::uint8_t>> seeds() {
  std::vector<std::vector<std::uint8_t>> out;
  auto add = [&](wire::OutMessage& m) {
    const auto f = m.frames();
    std::vector<std::uint8_t> bytes{static_cast<std::uint8_t>(f.size() - 1)};
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (i + 1 < f.size()) {
        bytes.push_back(static_cast<std::uint8_t>(f[i].size() & 0xff));
        bytes.push_back(static_cast<std::uint8_t>(f[i].size() >> 8));
      }
      const auto* p = static_cast<const std::uint8_t*>(f[i].data());
      bytes.insert(bytes.end(), p, p + f[i].size());
    }
    out.push_back(std::move(bytes));
  };
  const std::vector<double> values{1.0, -2.5, 3.0e-300, 4.0};
  {
    wire::OutMessage m;
    auto h = m.envelope().getBody().initHello();
    h.setProtocolMajor(1);
    h.setSolverKind("dem");
    h.setInstance("particles");
    h.initCapabilities(2).set(0, "arrays");
    add(m);
  }
  {
    wire::OutMessage m;
    m.envelope().setSeq(3);
    auto s = m.envelope().getBody().initSetup();
    s.setSceneYaml("scene: x\nsolvers: []\n");
    s.setInstance("beam");
    auto arrays = s.initInputs().initArrays(1);
    arrays[0].setName("state");
    auto list = arrays[0].initValues(static_cast<unsigned>(values.size()));
    for (unsigned i = 0; i < values.size(); ++i) list.set(i, values[i]);
    add(m);
  }
  {
    wire::OutMessage m;
    m.envelope().setSeq(4);
    auto a = m.envelope().getBody().initAdvance();
    a.setSteps(2);
    a.setDt(1e-3);
    auto forces = a.initInputs().initForces(1);
    forces[0].setZone("zone");
    forces[0].initIds(2).set(1, 7);
    forces[0].initForces(6).set(5, 1.5);
    add(m);
  }
  {
    wire::OutMessage m;
    m.envelope().setReplyTo(4);
    auto d = m.envelope().getBody().initAdvanced();
    d.setTime(0.5);
    auto jobs = d.initOutputs().initUnitCellJobs(1);
    jobs[0].initCellIds(1).set(0, 3);
    jobs[0].initStrainIncrements(9).set(4, 1e-4);
    add(m);
  }
  {
    wire::OutMessage m;
    auto e = m.envelope().getBody().initError();
    e.setMessage("scripted failure");
    add(m);
  }
  return out;
}

}  // namespace cosim::fuzz
