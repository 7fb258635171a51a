#pragma once
// Prescribed particle motion: a drive moves the particles of a zone with a
// velocity history v(t) instead of integrating them (a displacement-controlled
// boundary layer, e.g. the loaded end of Cheng 2022's wave bar, Table 4). A
// history kind is one file that registers itself by the name a scene uses:
//
//   drives:
//     - {zone: left, velocity: {kind: cosine-pulse, amplitude: [0, 0.05, 0], omega: 1950, cycles: 1}}
#include <memory>
#include <string>
#include <vector>

#include "cosim/dem/registry.hpp"
#include "cosim/dem/solver/yaml_section.hpp"
#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

class VelocityHistory {
 public:
  virtual ~VelocityHistory() = default;
  /// The prescribed velocity at time t [m/s].
  virtual Vec3 velocity(double t) const = 0;
};

/// A factory gets the `drives:` entry and reads its `velocity:` map with the
/// keys of its kind (`entry.child("velocity", {"kind", ...})`), so an unknown
/// key is an error naming file, line and key.
using VelocityHistoryRegistry = cosim::Registry<VelocityHistory, const YamlSection&>;

/// One `drives:` entry: the particles of a named zone follow the history.
struct DriveSpec {
  std::string zone;
  std::shared_ptr<const VelocityHistory> history;
};

}  // namespace cosim::dem
