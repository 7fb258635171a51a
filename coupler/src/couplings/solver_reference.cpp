#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"

namespace cosim::coupler {

std::string requireSolverName(config::MapReader& m, const std::string& key, const std::vector<SolverSpec>& solvers) {
  const std::string name = m.requireString(key);
  if (name.empty()) return name;
  for (const auto& s : solvers)
    if (s.name == name) return name;
  std::string declared;
  for (const auto& s : solvers) declared += (declared.empty() ? "" : ", ") + s.name;
  m.error(key, "'" + name + "' is not a solver declared under solvers (declared: " + declared + ")");
  return name;
}

}  // namespace cosim::coupler
