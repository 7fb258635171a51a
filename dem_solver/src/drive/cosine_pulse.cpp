// `kind: cosine-pulse`: Cheng 2022 Table 4, loading (b) of the wave bar:
//   v(t) = a (cos(omega t) - 1)   for 0 <= t <= 2 pi M_c / omega,   0 after
// (M_c = cycles; the layer is then held where the pulse left it). omega is
// an angular frequency in rad/s: the paper writes "kHz" for 0.49e3-1.95e3,
// which as rad/s gives pulses of 3.2-12.8 ms per cycle on a bar whose wave
// crosses 12 m in 43 ms (docs/arlequin.md).
#include <cmath>
#include <numbers>

#include "cosim/dem/drive/velocity_history.hpp"

namespace cosim::dem {
namespace {

class CosinePulse final : public VelocityHistory {
 public:
  CosinePulse(const Vec3& amplitude, double omega, double cycles)
      : a_(amplitude), omega_(omega), end_(2.0 * std::numbers::pi * cycles / omega) {}
  Vec3 velocity(double t) const override {
    if (t < 0.0 || t > end_) return {};
    return (std::cos(omega_ * t) - 1.0) * a_;
  }

 private:
  Vec3 a_;
  double omega_, end_;
};

const bool registered = VelocityHistoryRegistry::add("cosine-pulse", [](const YamlSection& entry) {
  const YamlSection s = entry.child("velocity", {"kind", "amplitude", "omega", "cycles"});
  const double omega = s.positive("omega");
  const double cycles = s.positive("cycles");
  return std::make_unique<CosinePulse>(s.vec3("amplitude"), omega, cycles);
});

}  // namespace
}  // namespace cosim::dem
