// Leapfrog: velocities live at half steps, v(t+dt/2) = v(t-dt/2) + dt f(t)/m,
// x(t+dt) = x(t) + dt v(t+dt/2). The forces of step t are those of the
// previous evaluation, so the whole update happens before the new forces.
#include "cosim/dem/integrate/integrator.hpp"

namespace cosim::dem {
namespace {

class Leapfrog final : public Integrator {
 public:
  void beforeForces(Particles& p, double dt, DriftWatch* watch) const override { kickAndDrift(p, dt, dt, watch); }
  void afterForces(Particles&, double) const override {}
};

const bool registered = IntegratorRegistry::add("leapfrog", [] { return std::make_unique<Leapfrog>(); });

}  // namespace
}  // namespace cosim::dem
