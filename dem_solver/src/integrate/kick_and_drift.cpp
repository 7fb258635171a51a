#include "cosim/dem/integrate/integrator.hpp"
#include "cosim/dem/lane_batch.hpp"
#include "cosim/dem/parallel.hpp"

namespace cosim::dem {

namespace {

// Spheres to be turned, collected by the kick-and-drift loop (branchy) and
// turned together in one loop without branches, which the compiler
// vectorises: the turn is most of the opening pass's arithmetic (about 50
// operations and three divisions per sphere), and in a packing every sphere
// turns every step. Lanes hold the sphere's index, its rotation vector, and
// the turned orientation.
struct TurnBatch : LaneBatch<64> {
  Lane<std::uint32_t> sphere;
  Lane<double> px, py, pz, qw, qx, qy, qz;

  /// Writes sphere i into the next lane; it stays there only if `keep`.
  void offer(bool keep, std::size_t i, const Vec3& phi) {
    sphere[count] = static_cast<std::uint32_t>(i);
    px[count] = phi.x, py[count] = phi.y, pz[count] = phi.z;
    keepIf(keep);
  }
};

// The small-angle turn of every lane (rotated()'s Taylor branch, bit for bit);
// a lane whose turn is large gets a value that turnAll() does not use.
COSIM_DEM_SIMD_CLONES void smallTurns(TurnBatch& b, const Quat* q) {
  const std::size_t count = b.count;
#pragma GCC ivdep
  for (std::size_t e = 0; e < count; ++e) {
    const Vec3 phi{b.px[e], b.py[e], b.pz[e]};
    double c, s;
    smallTurn(norm2(phi), c, s);
    const Quat t = turned(q[b.sphere[e]], phi, c, s);
    b.qw[e] = t.w, b.qx[e] = t.x, b.qy[e] = t.y, b.qz[e] = t.z;
  }
}

// Turns the batch's spheres: the vectorised small-angle turn, and for the
// rare large turn the exact sine and cosine (rotated()).
void turnAll(TurnBatch& b, Quat* q) {
  smallTurns(b, q);
  for (std::size_t e = 0; e < b.count; ++e) {
    const Vec3 phi{b.px[e], b.py[e], b.pz[e]};
    Quat& qi = q[b.sphere[e]];
    if (norm2(phi) < kSmallTurn2) [[likely]] qi = {b.qw[e], b.qx[e], b.qy[e], b.qz[e]};
    else qi = rotated(qi, phi);
  }
  b.count = 0;
}

}  // namespace

void kickAndDrift(Particles& p, double dtKick, double dt, DriftWatch* watch) {
  const std::size_t n = p.size();
  const std::uint8_t* driven = p.driven.data();
  const double *weight = p.weight.data(), *invMass = p.invMass.data(), *invInertia = p.invInertia.data();
  const Vec3 *f = p.f.data(), *torque = p.torque.data();
  Vec3 *x = p.x.data(), *v = p.v.data(), *omega = p.omega.data();
  Quat* q = p.q.data();
  bool beyond = false;
#pragma omp parallel if (n > kParallelMin) reduction(|| : beyond)
  {
    TurnBatch batch;
#pragma omp for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      if (driven[i]) continue;
      kick(weight[i], invMass[i], invInertia[i], f[i], torque[i], dtKick, v[i], omega[i]);
      x[i] += dt * v[i];
      if (watch) beyond |= watch->exceededBy(i, x[i]);  // or-ed, no branch on the rare answer
      // Most spheres of a dilute flow have never turned (no contact yet): their
      // orientations are neither read nor written (rotated() would return q).
      const Vec3 phi = dt * omega[i];
      batch.offer(norm2(phi) != 0.0, i, phi);
      if (batch.full()) turnAll(batch, q);
    }
    turnAll(batch, q);
  }
  if (watch) {
    watch->checked = true;
    watch->beyond = beyond;
  }
}

}  // namespace cosim::dem
