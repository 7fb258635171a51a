// `kind: constant`: v(t) = value (a driven indenter, a moving boundary layer).
#include "cosim/dem/drive/velocity_history.hpp"

namespace cosim::dem {
namespace {

class ConstantVelocity final : public VelocityHistory {
 public:
  explicit ConstantVelocity(const Vec3& v) : v_(v) {}
  Vec3 velocity(double) const override { return v_; }

 private:
  Vec3 v_;
};

const bool registered = VelocityHistoryRegistry::add(
    "constant", [](const YamlSection& entry) {
      return std::make_unique<ConstantVelocity>(entry.child("velocity", {"kind", "value"}).vec3("value"));
    });

}  // namespace
}  // namespace cosim::dem
