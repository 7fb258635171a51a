#include "cosim/coupler/analysis/reference.hpp"

#include <stdexcept>

namespace cosim::coupler {

proto::ParticleStates::Reader zoneStates(const Observation& o, const std::string& solver, const std::string& zone) {
  auto out = o.outputs.find(solver);
  if (out != o.outputs.end())
    for (auto s : out->second.getParticles())
      if (s.getZone() == zone) return s;
  throw std::runtime_error("analysis: solver '" + solver + "' sent no particle states for zone '" + zone +
                           "' (list it in that solver's params.zones)");
}

}  // namespace cosim::coupler
