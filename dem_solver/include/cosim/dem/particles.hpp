#pragma once
// Sphere storage as structure-of-arrays: one contiguous array per quantity so
// the force and integration loops stream through memory.
#include <cstdint>
#include <string>
#include <vector>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

class Particles {
 public:
  std::size_t size() const { return radius.size(); }
  /// Appends a sphere at rest; mass and inertia follow from radius and density.
  std::size_t add(const Vec3& position, double r, double density, std::uint16_t materialId = 0);
  void reserve(std::size_t n);
  /// What makes sphere i unusable ("" when nothing): a non-finite position or
  /// velocity, a radius, mass or inertia that is not positive and finite.
  /// Scene input and restored checkpoints are checked with it.
  std::string defectOf(std::size_t i) const;
  void clearForces();

  std::vector<Vec3> x;        // centre positions [m]
  std::vector<Vec3> v;        // velocities [m/s]
  std::vector<Vec3> omega;    // angular velocities [rad/s]
  std::vector<Quat> q;        // orientations
  std::vector<Vec3> f;        // total force of the current step [N]
  std::vector<Vec3> torque;   // total torque [N m]
  std::vector<Vec3> fExt;     // external force supplied from outside [N]
  std::vector<double> radius, mass, invMass, inertia, invInertia;
  std::vector<double> weight;  // Arlequin weight w (Cheng Eq. 26); 1 outside coupling zones
  std::vector<std::uint16_t> material;
  std::vector<std::uint8_t> driven;  // 1: kinematics set from outside, not integrated; 2: also parked (hybrid_watch.hpp)
  std::vector<std::uint32_t> id;     // stable external id
};

}  // namespace cosim::dem
