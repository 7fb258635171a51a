#include "cosim/pd/hybrid_watch.hpp"

#include <cmath>

#include "cosim/wire/arrays.hpp"

namespace cosim::pd {

std::string HybridWatch::receive(proto::HybridForces::Reader forces, std::size_t hybrids) {
  sendAll_ = forces.getSendAll();
  if (!forces.getWatchSet() || lastFull_ == 0 || forces.getWatchBasis() != lastFull_) return "";
  const auto w = wire::view(forces.getWatched());
  const double margin = forces.getWatchMargin(), interval = forces.getWatchInterval();
  if (!(margin > 0.0) || !std::isfinite(margin) || !(interval >= 0.0) || !std::isfinite(interval))
    return "watch margin " + std::to_string(margin) + " m and interval " + std::to_string(interval) +
           " s (need a positive margin and an interval >= 0)";
  for (std::size_t q = 0; q < w.size(); ++q)
    if (w[q] >= hybrids || (q > 0 && w[q] <= w[q - 1]))
      return "watched set position " + std::to_string(w[q]) + " out of order or beyond the " +
             std::to_string(hybrids) + " hybrid particles";
  watched_.assign(w.begin(), w.end());
  margin_ = margin;
  interval_ = interval;
  adopted_ = true;
  return "";
}

const std::vector<std::uint32_t>* HybridWatch::select(std::span<const double> x, std::span<const double> v) const {
  if (!adopted_ || sendAll_ || x.size() != fullPositions_.size()) return nullptr;
  // Each hybrid within m/2 of the full message's position over DEM's drift.
  const double half = 0.5 * margin_;
  for (std::size_t k = 0; k < x.size(); k += 3) {
    const double d0 = x[k] - fullPositions_[k], d1 = x[k + 1] - fullPositions_[k + 1],
                 d2 = x[k + 2] - fullPositions_[k + 2];
    const double drift = interval_ * std::sqrt(v[k] * v[k] + v[k + 1] * v[k + 1] + v[k + 2] * v[k + 2]);
    if (std::sqrt(d0 * d0 + d1 * d1 + d2 * d2) + drift >= half) return nullptr;
  }
  return &watched_;
}

void HybridWatch::sent(bool full, std::span<const double> x, std::uint64_t serial) {
  if (!full) return;
  lastFull_ = serial;
  fullPositions_.assign(x.begin(), x.end());
  adopted_ = false;  // a new set comes for this message
}

void HybridWatch::save(util::BinaryWriter& w) const {
  w.pod(lastFull_);
  w.vec(fullPositions_);
  w.vec(watched_);
  w.pod(margin_), w.pod(interval_);
  w.pod(static_cast<std::uint8_t>(adopted_)), w.pod(static_cast<std::uint8_t>(sendAll_));
}

void HybridWatch::load(util::BinaryReader& r, std::size_t hybrids) {
  lastFull_ = r.pod<std::uint64_t>("hybrid watch");
  fullPositions_ = r.vec<double>("hybrid watch");
  watched_ = r.vec<std::uint32_t>("hybrid watch");
  margin_ = r.pod<double>("hybrid watch");
  interval_ = r.pod<double>("hybrid watch");
  adopted_ = r.pod<std::uint8_t>("hybrid watch") != 0;
  sendAll_ = r.pod<std::uint8_t>("hybrid watch") != 0;
  if (!fullPositions_.empty() && fullPositions_.size() != 3 * hybrids)
    r.fail("hybrid watch", std::to_string(fullPositions_.size()) + " positions for " + std::to_string(hybrids) +
                               " hybrid particles");
  for (const std::uint32_t k : watched_)
    if (k >= hybrids) r.fail("hybrid watch", "watched set position " + std::to_string(k) + " beyond the set");
}

}  // namespace cosim::pd
