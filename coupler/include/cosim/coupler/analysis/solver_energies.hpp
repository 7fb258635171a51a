#pragma once
// The energies each solver reported with its latest reply, as couplings and
// analyses read them (views into the replies the coupler keeps).
#include <initializer_list>
#include <map>
#include <string>

#include "data.capnp.h"

namespace cosim::coupler {

using SolverEnergies = std::map<std::string, capnp::List<proto::NamedValue>::Reader>;

/// The sum of the named energies one solver reported; names it did not report count 0.
inline double sumEnergies(const SolverEnergies& energies, const std::string& solver,
                          std::initializer_list<const char*> names) {
  const auto it = energies.find(solver);
  if (it == energies.end()) return 0.0;
  double sum = 0.0;
  for (auto e : it->second)
    for (const char* n : names)
      if (e.getName() == n) sum += e.getValue();
  return sum;
}

}  // namespace cosim::coupler
