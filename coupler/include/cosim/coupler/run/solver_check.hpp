#pragma once
// Each solver's section of a scene checked by the solver itself, before a run
// starts it for real: the coupler writes the setup message the run would send
// and the solver's binary sets up from it (`BINARY --check FILE`) in a scratch
// run directory, then exits. So `coupler check` finds what only a solver can
// judge (its params, meshes, particle and cell files) and `coupler run` refuses
// such a scene before any process starts.
#include <filesystem>
#include <string>
#include <vector>

#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"

namespace cosim::coupler {

/// The setup message of solver `s`: the scene, where it runs and writes, and
/// the inputs the couplings staged for it.
void fillSetup(proto::Setup::Builder setup, const Scene& scene, const SolverSpec& s, InputAssembler& inputs,
               const std::filesystem::path& runDir, bool resuming);

/// Checks every solver the coupler starts (not those attached by hand), all
/// at once, in run directories under `scratch` (removed afterwards). Returns
/// one problem per solver that refused its section, naming the solver and
/// carrying the solver's own message.
std::vector<std::string> checkSolverParams(const Scene& scene, const std::filesystem::path& scratch);

}  // namespace cosim::coupler
