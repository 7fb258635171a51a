#include "cosim/config/config_reader.hpp"

namespace cosim::config {

YAML::Node solverParams(const std::string& sceneYaml, const std::string& sceneFile, const std::string& instance) {
  const YAML::Node root = loadYamlString(sceneYaml, sceneFile);
  const YAML::Node solvers = root.IsMap() ? root["solvers"] : YAML::Node();
  if (solvers.IsSequence())
    for (const auto& s : solvers)
      if (s.IsMap() && s["name"] && s["name"].IsScalar() && s["name"].Scalar() == instance) {
        const YAML::Node params = s["params"];
        if (!params || params.IsNull()) return YAML::Node(YAML::NodeType::Map);
        return params;
      }
  throw ConfigError({sceneFile + ": no solver named '" + instance + "' under solvers"});
}

}  // namespace cosim::config
