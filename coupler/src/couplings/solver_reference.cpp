#include <set>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"

namespace cosim::coupler {

namespace {

// A role key that is itself a solver kind (dem:, fem:, pd:) wants a solver of
// that kind; a mock, or a kind of the user's own, may stand in for any role.
bool roleRefusesKind(const std::string& role, const std::string& kind) {
  static const std::set<std::string> solverKinds{"dem", "fem", "pd"};
  return solverKinds.count(role) && solverKinds.count(kind) && kind != role;
}

}  // namespace

std::string requireSolverName(config::MapReader& m, const std::string& key, const std::vector<SolverSpec>& solvers) {
  const std::string name = m.requireString(key);
  if (name.empty()) return name;
  for (const auto& s : solvers) {
    if (s.name != name) continue;
    if (roleRefusesKind(key, s.kind))
      m.error(key, "'" + name + "' is a " + s.kind + " solver (line " + std::to_string(s.line) + "); the " + key +
                       " role needs a solver of kind " + key + " (roles swapped?)");
    return name;
  }
  std::string declared;
  for (const auto& s : solvers) declared += (declared.empty() ? "" : ", ") + s.name;
  m.error(key, "'" + name + "' is not a solver declared under solvers (declared: " + declared + ")");
  return name;
}

}  // namespace cosim::coupler
