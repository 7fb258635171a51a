#include "cosim/dem/walls/plane_wall.hpp"

namespace cosim::dem {

void PlaneWall::move(double dt) {
  if (mode == Mode::fixed) return;
  if (mode == Mode::servo) {
    // Particles push the wall along -normal; compressive load = -force . normal.
    const double load = -dot(force, normal);
    // Too little load: move towards the particles (+normal), too much: back off.
    velocity = servoGain * (servoStress * servoArea - load) * normal;
  }
  point += velocity * dt;
}

}  // namespace cosim::dem
