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
  /// checks: how many checks in a row must find the gap above the tolerance.
  /// A contact that starts inside a step makes a gap of the order of its
  /// own small energy at the first check, which the following checks
  /// shrink; an unstable integration keeps it.
  explicit EnergyBalance(double tolerance = 0.0, std::string stored = "kinetic + strain", int checks = 1)
      : tolerance_(tolerance), stored_(std::move(stored)), checks_(checks) {}

  /// Starts the balance at `stored` with `work` already done (0 on a fresh
  /// run; the checkpoint's work on a restore).
  void start(double stored, double work);
  /// Turns the check off for a run whose balance does not close by design.
  void disable() { disabled_ = true; }
  bool active() const { return tolerance_ > 0.0 && !disabled_; }

  /// Empty while the balance holds; otherwise what broke, in numbers.
  /// magnitude: the size of the energies involved where the stored total
  /// can stay small while its parts are large (potential energy turned
  /// into kinetic and dissipated); it joins the scale the gap is judged against.
  std::optional<std::string> check(double stored, double work, double magnitude = 0.0);

 private:
  double tolerance_ = 0.0;
  std::string stored_;
  int checks_ = 1, above_ = 0;  // checks needed, and found above the tolerance in a row
  double storedAtStart_ = 0.0, scale_ = 0.0;
  bool disabled_ = false;
};

}  // namespace cosim::util
