#include "cosim/dem/solver/hybrid_watch.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cosim/wire/arrays.hpp"

namespace cosim::dem {

void HybridWatch::rebuild(const DemSystem& s, std::span<const std::uint32_t> hybridIndex, std::uint64_t serial,
                          double interval) {
  margin_ = requestedMargin < 0.0 ? kWatchMarginPerSkin * s.neighbors.skin : requestedMargin;
  const double reach = s.neighbors.skin + margin_;
  // Every pair closer than r_i + r_j + skin + m, with the contact list's exclusions (PD families, bonds).
  NeighborList near;
  near.skin = reach;
  near.exclStart = s.neighbors.exclStart;
  near.exclPartner = s.neighbors.exclPartner;
  near.build(s.particles, nullptr);
  const Particles& p = s.particles;
  std::vector<std::uint8_t> paired(p.size(), 0);
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::uint32_t k = near.rowStart[i]; k < near.rowStart[i + 1]; ++k) paired[i] = paired[near.partner[k]] = 1;
  watched_.assign(hybridIndex.size(), 0);
  list_.clear();
  for (std::uint32_t k = 0; k < hybridIndex.size(); ++k) {
    const std::uint32_t i = hybridIndex[k];
    bool w = paired[i] != 0;
    for (const PlaneWall& plane : s.planes) w = w || plane.distance(p.x[i]) < p.radius[i] + reach;
    // DEM drifts the state over its interval before parking it: that drift
    // must stay well inside the m/2 the argument allows.
    w = w || interval * norm(p.v[i]) >= 0.25 * margin_;
    watched_[k] = w ? 1 : 0;
    if (w) list_.push_back(k);
  }
  // Every particle that is not a hybrid: free ones and those a scene drives.
  std::vector<std::uint8_t> hybrid(p.size(), 0);
  for (const std::uint32_t i : hybridIndex) hybrid[i] = 1;
  own_.clear();
  ownRef_.clear();
  for (std::uint32_t i = 0; i < p.size(); ++i)
    if (!hybrid[i]) own_.push_back(i), ownRef_.push_back(p.x[i]);
  planeRef_.clear();
  for (const PlaneWall& plane : s.planes) planeRef_.push_back({plane.point, plane.normal});
  basis_ = serial;
  interval_ = interval;
  built_ = rebuiltNow_ = true;
  farthest_ = 0.0;
}

void HybridWatch::checkPartial(std::uint64_t basis, std::span<const std::uint32_t> indices) const {
  if (!built_)
    throw std::invalid_argument("hybrid particles: partial states (watch set of message " + std::to_string(basis) +
                                ") before this DEM process listed any watch set; send every state first");
  if (basis != basis_)
    throw std::invalid_argument("hybrid particles: partial states rest on the watch set of message " +
                                std::to_string(basis) + ", but this DEM process holds the one of message " +
                                std::to_string(basis_));
  if (!std::equal(indices.begin(), indices.end(), list_.begin(), list_.end()))
    throw std::invalid_argument("hybrid particles: partial states of " + std::to_string(indices.size()) +
                                " particles, but the watch set of message " + std::to_string(basis_) + " lists " +
                                std::to_string(list_.size()) + " others");
}

void HybridWatch::beginInterval(const DemSystem& s, bool partial, bool stateArrived) {
  fresh_ = rebuiltNow_;
  rebuiltNow_ = false;
  if (!built_) return;
  if (stateArrived) sinceState_ = 0.0;
  partial_ = partial;
  const Particles& p = s.particles;
  intervalStart_.resize(own_.size());
  for (std::size_t q = 0; q < own_.size(); ++q) intervalStart_[q] = p.x[own_[q]];
  planeStart_.clear();
  for (const PlaneWall& plane : s.planes) planeStart_.push_back({plane.point, plane.normal});
}

namespace {

/// How far a plane moved along its normal from `point` (normal n); infinite once it turned.
double planeMove(const PlaneWall& w, const Vec3& point, const Vec3& n) {
  if (w.normal.x != n.x || w.normal.y != n.y || w.normal.z != n.z) return INFINITY;
  return std::fabs(dot(w.point - point, n));
}

}  // namespace

double HybridWatch::farthest(const DemSystem& s, std::string* who) const {
  double d = 0.0;
  const Particles& p = s.particles;
  for (std::size_t q = 0; q < own_.size(); ++q) {
    const double di = norm(p.x[own_[q]] - ownRef_[q]);
    if (di > d) {
      d = di;
      if (who) *who = "particle " + std::to_string(p.id[own_[q]]);
    }
  }
  for (std::size_t w = 0; w < s.planes.size() && w < planeRef_.size(); ++w) {
    const double dw = planeMove(s.planes[w], planeRef_[w].point, planeRef_[w].normal);
    if (dw > d) {
      d = dw;
      if (who) *who = "wall '" + s.planes[w].name + "'";
    }
  }
  return d;
}

void HybridWatch::track(const DemSystem& s, double dt) {
  if (!built_) return;
  sinceState_ += dt;
  farthest_ = std::max(farthest_, farthest(s, nullptr));
}

void HybridWatch::endInterval(const DemSystem& s) {
  if (!built_) {
    sendAll_ = true;
    return;
  }
  const double half = 0.5 * margin_;
  if (partial_ && (farthest_ >= half || sinceState_ > interval_ * (1.0 + 1e-9))) {
    std::string who;
    const double d = farthest(s, &who);
    std::ostringstream m;
    if (farthest_ >= half)
      m << "hybrid watch: " << who << " moved " << d << " m (at most " << farthest_
        << " m) from where it was at the watch set of message " << basis_ << ", beyond half the watch margin ("
        << half << " m), while PD sent only the watched states: raise params.hybrid.watch_margin or set it to 0";
    else
      m << "hybrid watch: the hybrid states drifted " << sinceState_ << " s since their last message, longer than the "
        << interval_ << " s the watch set of message " << basis_
        << " allowed for; set params.hybrid.watch_margin: 0 for this schedule";
    throw std::runtime_error(m.str());
  }
  // The next interval moves about as far as this one did: ask for every state
  // while two more such moves could pass m/2.
  double step = 0.0;
  const Particles& p = s.particles;
  for (std::size_t q = 0; q < own_.size() && q < intervalStart_.size(); ++q)
    step = std::max(step, norm(p.x[own_[q]] - intervalStart_[q]));
  for (std::size_t w = 0; w < s.planes.size() && w < planeStart_.size(); ++w)
    step = std::max(step, planeMove(s.planes[w], planeStart_[w].point, planeStart_[w].normal));
  sendAll_ = farthest_ + 2.0 * step >= half;
}

void HybridWatch::save(util::BinaryWriter& w) const {
  w.vec(watched_), w.vec(list_), w.vec(own_), w.vec(ownRef_), w.vec(intervalStart_);
  w.vec(planeRef_), w.vec(planeStart_);
  w.pod(basis_);
  for (const bool b : {built_, rebuiltNow_, fresh_, partial_, sendAll_}) w.pod(static_cast<std::uint8_t>(b));
  for (const double x : {margin_, interval_, farthest_, sinceState_}) w.pod(x);
}

void HybridWatch::load(util::BinaryReader& r, std::size_t particles, std::size_t hybrids) {
  watched_ = r.vec<std::uint8_t>("hybrid watch");
  list_ = r.vec<std::uint32_t>("hybrid watch");
  own_ = r.vec<std::uint32_t>("hybrid watch");
  ownRef_ = r.vec<Vec3>("hybrid watch");
  intervalStart_ = r.vec<Vec3>("hybrid watch");
  planeRef_ = r.vec<PlanePose>("hybrid watch");
  planeStart_ = r.vec<PlanePose>("hybrid watch");
  basis_ = r.pod<std::uint64_t>("hybrid watch");
  for (bool* b : {&built_, &rebuiltNow_, &fresh_, &partial_, &sendAll_}) *b = r.pod<std::uint8_t>("hybrid watch") != 0;
  for (double* x : {&margin_, &interval_, &farthest_, &sinceState_}) *x = r.pod<double>("hybrid watch");
  if (own_.size() != ownRef_.size() || intervalStart_.size() > own_.size() || watched_.size() > hybrids)
    r.fail("hybrid watch", "lists of inconsistent sizes");
  for (const std::uint32_t i : own_)
    if (i >= particles) r.fail("hybrid watch", "particle index " + std::to_string(i) + " beyond the system");
  for (const std::uint32_t k : list_)
    if (k >= watched_.size()) r.fail("hybrid watch", "set position " + std::to_string(k) + " beyond the set");
}

void HybridWatch::fill(proto::HybridForces::Builder out) const {
  out.setSendAll(sendAll_);
  if (!fresh_) return;
  out.setWatchSet(true);
  auto w = wire::view(out.initWatched(static_cast<unsigned>(list_.size())));
  std::copy(list_.begin(), list_.end(), w.begin());
  out.setWatchMargin(margin_);
  out.setWatchInterval(interval_);
  out.setWatchBasis(basis_);
}

}  // namespace cosim::dem
