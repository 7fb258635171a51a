#pragma once
// Reading CouplingForces (volume.capnp) on the solver side: every entry aimed
// at one target (particles, nodes) is checked (3 values per id, ids that
// exist, finite values) and handed over force by force; several entries
// (couplings, zones) simply add up in the caller.
#include <cmath>
#include <string>

#include "cosim/wire/arrays.hpp"
#include "cosim/wire/solver.hpp"
#include "volume.capnp.h"

namespace cosim::wire {

/// Calls add(id, force) (force: 3 doubles) for every force of the entries in
/// lists whose target is `target`; ids must be below count. `what` names the
/// receivers in messages ("particle", "node"). Throws SolverError (BAD_INPUT)
/// naming the zone and the id.
template <typename Add>
void forEachCouplingForce(capnp::List<proto::CouplingForces>::Reader lists, proto::CouplingForces::Target target,
                          std::size_t count, const std::string& what, Add&& add) {
  using Code = proto::Error::Code;
  for (auto entry : lists) {
    if (entry.getTarget() != target) continue;
    const std::string zone = entry.getZone().cStr();
    const auto ids = view(entry.getIds());
    const auto values = view(entry.getForces());
    if (values.size() != 3 * ids.size())
      throw SolverError(Code::BAD_INPUT, "coupling forces '" + zone + "': " + std::to_string(values.size()) +
                                             " values for " + std::to_string(ids.size()) + " " + what + "s");
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (ids[k] >= count)
        throw SolverError(Code::BAD_INPUT, "coupling forces '" + zone + "': " + what + " " + std::to_string(ids[k]) +
                                               " does not exist");
      const double* f = values.data() + 3 * k;
      if (!std::isfinite(f[0]) || !std::isfinite(f[1]) || !std::isfinite(f[2]))
        throw SolverError(Code::BAD_INPUT, "coupling forces '" + zone + "': non-finite force on " + what + " " +
                                               std::to_string(ids[k]));
      add(ids[k], f);
    }
  }
}

}  // namespace cosim::wire
