#include "cosim/util/energy_balance.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cosim::util {

void EnergyBalance::start(double stored, double work) {
  // Work is cumulative from the start of the run: the energy stored when no
  // work had been done is what `stored` less `work` was.
  storedAtStart_ = stored - work;
  scale_ = std::max(std::abs(stored), std::abs(work));
}

std::optional<std::string> EnergyBalance::check(double stored, double work, double magnitude) {
  if (!active()) return std::nullopt;
  // The largest energy so far: a balance that closes to round-off around zero
  // work must not be judged against a vanishing scale.
  scale_ = std::max({scale_, std::abs(stored), std::abs(work), std::abs(storedAtStart_), std::abs(magnitude)});
  const double gap = std::abs((stored - storedAtStart_) - work);
  if (!(scale_ > 0.0) || gap <= tolerance_ * scale_) {
    above_ = 0;
    return std::nullopt;
  }
  if (++above_ < checks_) return std::nullopt;
  std::ostringstream s;
  s.precision(4);
  s << "energy balance broken: the stored energy (" << stored_ << ") changed by " << stored - storedAtStart_
    << " J while the external forces did " << work << " J of work; the gap " << gap << " J is "
    << 100.0 * gap / scale_ << " % of the largest energy so far (" << scale_ << " J), above params.energy_tolerance = "
    << 100.0 * tolerance_ << " %";
  if (checks_ > 1) s << " on " << checks_ << " checks in a row";
  return s.str();
}

}  // namespace cosim::util
