#pragma once
// Infinite plane wall: particles live on the side its unit normal points to.
// Fixed, velocity-driven, or a stress-controlled servo that moves along its
// normal until the particles push on it with the target stress.
#include <cstdint>
#include <string>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

struct PlaneWall {
  enum class Mode { fixed, velocity, servo };
  std::string name;
  Vec3 point;
  Vec3 normal{0.0, 0.0, 1.0};  // unit, towards the particles
  Vec3 velocity;
  Mode mode = Mode::fixed;
  std::uint16_t material = 0;
  double servoStress = 0.0;  // target compressive stress [Pa] (servo)
  double servoArea = 1.0;    // area the stress acts on [m^2]
  double servoGain = 0.0;    // velocity per unit force error [m/(N s)]
  // Accumulated over the last force evaluation: force and torque (about point)
  // the particles exert on the wall.
  Vec3 force, torque;
  double stiffness = 0.0;  // servo walls: summed normal tangent stiffness S_n of their contacts [N/m]

  /// Signed distance of x from the plane (positive on the particle side).
  double distance(const Vec3& x) const { return dot(x - point, normal); }
  /// Moves the wall over one step (servo: velocity from the force error).
  void move(double dt);
  /// A servo's load error shrinks each step by the factor 1 - G dt k (G the
  /// gain, k the contacts' stiffness against the wall): above 1 the wall
  /// overshoots its target every step, above 2 the error grows.
  double servoLoopGain(double dt) const { return mode == Mode::servo ? servoGain * dt * stiffness : 0.0; }
};

}  // namespace cosim::dem
