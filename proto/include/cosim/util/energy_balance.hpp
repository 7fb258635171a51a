#pragma once
// EnergyBalance: the run-time stability check of a solver's energy balance.
// The energy a system stores (PD: kinetic + strain; DEM: kinetic + elastic +
// potential + what dashpots and sliding dissipated) changes only by the work
// of its external forces and prescribed motion: E - E_0 = W. Velocity Verlet
// keeps that to O(dt^2) in a stable run; when a step is above a particle's
// stable limit (e.g. the one-sided families of a PD sphere's outer shell
// under contact, which the critical step dx / c of Hartmann Eqs. 41-42 does
// not cover) the stored energy runs away from the work long before any value
// is non-finite.
#include <optional>
#include <string>
#include <utility>

namespace cosim::util {

class EnergyBalance {
 public:
  /// tolerance: the largest |stored change - work| as a share of the largest
  /// energy seen so far (stored, stored at the start or |work|); 0 = off.
  /// stored: what the stored energy is made of, for the message ("kinetic + strain").
  explicit EnergyBalance(double tolerance = 0.0, std::string stored = "kinetic + strain")
      : tolerance_(tolerance), stored_(std::move(stored)) {}

  /// Starts the balance at `stored` with `work` already done (0 on a fresh
  /// run; the checkpoint's work on a restore).
  void start(double stored, double work);
  /// Turns the check off for a run whose balance does not close by design.
  void disable() { disabled_ = true; }
  bool active() const { return tolerance_ > 0.0 && !disabled_; }

  /// Empty while the balance holds; otherwise what broke, in numbers.
  std::optional<std::string> check(double stored, double work);

 private:
  double tolerance_ = 0.0;
  std::string stored_;
  double storedAtStart_ = 0.0, scale_ = 0.0;
  bool disabled_ = false;
};

}  // namespace cosim::util
