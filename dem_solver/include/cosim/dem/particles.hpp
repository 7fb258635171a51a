#pragma once
// Sphere storage as structure-of-arrays: one contiguous array per quantity so
// the force and integration loops stream through memory.
#include <cstdint>
#include <string>
#include <vector>

#include "cosim/dem/vec3.hpp"

namespace cosim::dem {

/// Forces on the spheres supplied from outside (a coupling's) [N], zero
/// unless added. Written only through add() and clear(), so any() is true
/// whenever one is not zero, and the force loop reads none of them in a run
/// without any (a dilute step is bound by memory traffic).
class ExternalForces {
 public:
  std::size_t size() const { return f_.size(); }
  const Vec3& operator[](std::size_t i) const { return f_[i]; }
  const Vec3* data() const { return f_.data(); }
  const std::vector<Vec3>& values() const { return f_; }
  bool any() const { return any_; }
  void add(std::size_t i, const Vec3& f) {
    f_[i] += f;
    any_ = true;
  }
  /// Every force back to zero.
  void clear();
  /// A zero force for a sphere appended to the set.
  void append() { f_.push_back({}); }
  void reserve(std::size_t n) { f_.reserve(n); }
  /// Takes stored forces (a restored checkpoint).
  void restore(std::vector<Vec3> values);

 private:
  std::vector<Vec3> f_;
  bool any_ = false;
};

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
  ExternalForces fExt;        // external force supplied from outside [N]
  std::vector<double> radius, mass, invMass, inertia, invInertia;
  std::vector<double> weight;  // Arlequin weight w (Cheng Eq. 26); 1 outside coupling zones
  std::vector<std::uint16_t> material;
  std::vector<std::uint8_t> driven;  // 1: kinematics set from outside, not integrated; 2: also parked (hybrid_watch.hpp)
  std::vector<std::uint32_t> id;     // stable external id
};

}  // namespace cosim::dem
