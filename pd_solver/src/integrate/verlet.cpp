// Explicit time integration of a PdSystem.
//
// Hartmann 2022 Eq. 44 is leapfrog; its extracted position line carries a
// spurious "+ a dt^2" term. We use the standard form x_{n+1} = x_n +
// v_{n+1/2} dt, written as velocity Verlet (two half kicks around a drift),
// which is algebraically the same leapfrog but keeps v at full steps for
// energies and output.
#ifdef _OPENMP
#include <omp.h>
#endif

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "cosim/pd/system.hpp"

namespace cosim::pd {

double PdSystem::criticalTimeStep() const {
  // Hartmann 2022 Eqs. 41-42 take dt = h / c with the spacing h as the
  // characteristic length and c = sqrt(K / rho), and note that the length is
  // not obvious. A PD body's highest frequency is set by its horizon, not its
  // spacing (every partner within delta stiffens a particle): measured by
  // power iteration (tests/pd/test_stability.cpp), the Verlet limit 2 / omega_max
  // is 0.50-0.82 delta / c_p (c_p the P-wave speed, Material::cflWaveSpeed)
  // over PMB and LPS, nu from -0.3 to 0.48, delta from 1 to 4 h, cubes and
  // spheres, all influence functions, with and without surface correction,
  // while h / sqrt(K / rho) lay up to 84 % above it (delta = h), 51 % at
  // delta = 1.5 h and 5 % at delta = 2 h (nu = 0.25). 0.45 delta / c_p is below every one.
  constexpr double kHorizonFraction = 0.45;
  double dt = std::numeric_limits<double>::infinity();
  if (!measuredStep_.empty()) {
    for (const double m : measuredStep_) dt = std::min(dt, m);
    return dt;
  }
  for (const auto& b : bodies_) dt = std::min(dt, kHorizonFraction * b.horizon / b.spec.material.cflWaveSpeed());
  return dt;
}

void PdSystem::addLinearisedChange(const LinearisedCoupling& c, std::vector<double>& f) const {
  // First-order change of a contact force as its particle moves away from
  // where DEM evaluated it: df = -K (x - x_F). The result is clamped so it
  // never points against the evaluated force: a contact pushes, it cannot pull.
  const std::size_t i = c.particle;
  const auto& k = c.stiffness;
  double dx[3];
  for (int a = 0; a < 3; ++a)
    dx[a] = particles_.reference[3 * i + a] + particles_.displacement[3 * i + a] - c.position[a];
  const double df[3] = {-(k[0] * dx[0] + k[3] * dx[1] + k[4] * dx[2]),
                        -(k[3] * dx[0] + k[1] * dx[1] + k[5] * dx[2]),
                        -(k[4] * dx[0] + k[5] * dx[1] + k[2] * dx[2])};
  const double* held = &coupling_[3 * i];
  double along = 0.0;
  for (int a = 0; a < 3; ++a) along += (held[a] + df[a]) * held[a];
  const double keep = along > 0.0 ? 1.0 : 0.0;
  for (int a = 0; a < 3; ++a) f[3 * i + a] += keep * df[a] - (1.0 - keep) * held[a];
}

void PdSystem::computeExternal() {
  auto& f = particles_.externalForce;
  const auto& m = particles_.mass;
  const long n = static_cast<long>(particles_.size());
  for (long il = 0; il < n; ++il) {
    const auto i = static_cast<std::size_t>(il);
    for (int a = 0; a < 3; ++a) f[3 * i + a] = coupling_[3 * i + a] + m[i] * gravity_[a];
  }
  for (const auto& c : linearised_) addLinearisedChange(c, f);
  for (const auto& load : loads_) {
    double vol = 0.0;
    for (const auto i : load.particles) vol += particles_.volume[i];
    for (const auto i : load.particles)
      for (int a = 0; a < 3; ++a) f[3 * i + a] += load.force[a] * particles_.volume[i] / vol;
  }
}

bool PdSystem::sharesBodiesOut() const {
  // Many bodies of similar size (a pack of PD spheres): one body per thread.
  // A body of a few thousand particles is too small to share its own bond
  // loops out, and its regions' barriers would cost more than they save.
  // Bodies are independent, so the results do not change with the split.
  int threads = 1;
#ifdef _OPENMP
  threads = omp_get_max_threads();
#endif
  std::size_t largest = 0;
  for (const auto& body : bodies_) largest = std::max(largest, body.end - body.begin);
  return threads > 1 && bodies_.size() >= 2 * static_cast<std::size_t>(threads) &&
         largest * bodies_.size() <= 2 * particles_.size();
}

void PdSystem::computeInternal() {
  const bool perBody = sharesBodiesOut();
  const long nb = static_cast<long>(bodies_.size());
#pragma omp parallel for schedule(dynamic, 1) if (perBody)
  for (long b = 0; b < nb; ++b) {
    Body& body = bodies_[static_cast<std::size_t>(b)];
    body.model->breakBonds(context(static_cast<std::size_t>(b)), body.bonds);
    body.model->computeForces(context(static_cast<std::size_t>(b)), particles_.internalForce);
  }
}

void PdSystem::computeForces() {
  computeInternal();
  computeExternal();
}

void PdSystem::applyConstraints() { constrain(particles_.velocity); }

void PdSystem::driftVelocity(double dt, std::size_t i, double out[3]) const {
  const auto& p = particles_;
  for (std::size_t a = 0; a < 3; ++a) {
    const std::size_t q = 3 * i + a;
    out[a] = p.velocity[q] + 0.5 * dt * (p.internalForce[q] + p.externalForce[q]) / p.mass[i];
  }
  constrainParticle(i, out);
}

void PdSystem::constrainParticle(std::size_t i, double* v) const {
  for (std::uint32_t e = constraintOffset_[i]; e < constraintOffset_[i + 1]; ++e)
    constrainEntry(bcs_[constraintEntry_[e].first], constraintEntry_[e].second, v);
}

void PdSystem::constrainEntry(const BoundaryCondition& bc, std::size_t q, double* v) {
  switch (bc.type) {
    case Constraint::Fixed:
      for (int a = 0; a < 3; ++a) v[a] = 0.0;
      break;
    case Constraint::Velocity:
      for (int a = 0; a < 3; ++a) v[a] = bc.velocity[a];
      break;
    case Constraint::NormalOnly: {
      // Motion along the local surface normal only is suppressed.
      const double* n = &bc.normals[3 * q];
      const double vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
      for (int a = 0; a < 3; ++a) v[a] -= vn * n[a];
      break;
    }
  }
}

void PdSystem::constrain(std::vector<double>& v) const {
  for (const auto& bc : bcs_)
    for (std::size_t q = 0; q < bc.particles.size(); ++q) constrainEntry(bc, q, &v[3 * bc.particles[q]]);
}

// Kicks, drift and the external force are O(n) streams, microseconds even
// for 10^5 particles; they stay serial so a step has as few OpenMP barriers
// as possible (the bond loops of the models are the parallel part).
void PdSystem::beginStep(double dt) {
  // v_{n+1/2} = v_n + dt/2 a_n and x_{n+1} = x_n + dt v_{n+1/2}, written
  // into the spare buffers (the same arithmetic as in place) and
  // swapped in: the state before stays whole without a copy.
  auto& p = particles_;
  const std::size_t n3 = p.velocity.size();
  beforeVelocity_.resize(n3);
  beforeDisplacement_.resize(n3);
  beforeInternal_.resize(n3);
  const double h = 0.5 * dt;
  for (std::size_t q = 0; q < n3; ++q)
    beforeVelocity_[q] = p.velocity[q] + h * (p.internalForce[q] + p.externalForce[q]) / p.mass[q / 3];
  constrain(beforeVelocity_);
  for (std::size_t q = 0; q < n3; ++q) beforeDisplacement_[q] = p.displacement[q] + dt * beforeVelocity_[q];
  p.velocity.swap(beforeVelocity_);
  p.displacement.swap(beforeDisplacement_);
  p.internalForce.swap(beforeInternal_);
  computeInternal();
}

void PdSystem::completeStep(double dt) {
  time_ += dt;
  ++step_;
  // computeExternal writes every value: the old ones are kept by a swap.
  auto& p = particles_;
  externalPrev_.swap(p.externalForce);
  p.externalForce.resize(externalPrev_.size());
  computeExternal();
  // Work of external forces by the trapezoidal rule over the drift,
  // dW = (f_n + f_{n+1}) / 2 . v_{n+1/2} dt, then the second half kick, in
  // one pass.
  auto& v = p.velocity;
  const auto& fe = p.externalForce;
  const auto& fi = p.internalForce;
  const double h = 0.5 * dt;
  double w = 0.0;
  for (std::size_t q = 0; q < v.size(); ++q) {
    w += 0.5 * (externalPrev_[q] + fe[q]) * v[q] * dt;
    v[q] += h * (fi[q] + fe[q]) / p.mass[q / 3];
  }
  work_ += w;
  applyConstraints();
  aheadDt_ = 0.0;
}

bool PdSystem::lookAhead(double dt) {
  if (aheadDt_ > 0.0) return aheadDt_ == dt;
  for (std::size_t b = 0; b < bodies_.size(); ++b)
    if (bodies_[b].model->mayBreakBonds(context(b))) return false;
  beginStep(dt);
  aheadDt_ = dt;
  return true;
}

void PdSystem::completeLookAhead() {
  if (!(aheadDt_ > 0.0)) throw std::logic_error("PdSystem::completeLookAhead without a pending lookAhead");
  completeStep(aheadDt_);
}

void PdSystem::cancelLookAhead() {
  if (!(aheadDt_ > 0.0)) return;
  auto& p = particles_;
  p.velocity.swap(beforeVelocity_);
  p.displacement.swap(beforeDisplacement_);
  p.internalForce.swap(beforeInternal_);
  aheadDt_ = 0.0;
}

void PdSystem::stepStaggered(double dt) {
  // Hartmann 2022 Eq. 47 (Eq. 46: u_n -> u^{Coupling}_{n+1} -> u_{n+1}) with
  // leapfrog velocities at half steps. First the coupling (and body/applied)
  // forces kick and move the particles, then the PD forces are evaluated at
  // those updated positions and kick again. Read literally, Eq. 47's position
  // lines drift twice with the full velocity; we read each position line as
  // moving by its own kick's increment, x^C = x_n + dt (v^C - v_{n-1/2}) and
  // x_{n+1} = x^C + dt (v_{n+1/2} - v^C) + dt v_{n-1/2}, so the total is
  // x_{n+1} = x_n + dt v_{n+1/2} and without coupling forces the scheme is
  // exactly the leapfrog of Eq. 44.
  // Each half is one pass over the particles: kick, the particle's
  // constraints, move and work (the same arithmetic, and the work summed in
  // the same order, as separate passes over all particles). The pass runs on
  // every step of the fine solver, so it reads through unaliased pointers,
  // calls the constraints only for constrained particles and skips the work
  // terms and the first kick of particles without external force (each is
  // exactly zero: the state and the work are bitwise the same, up to the
  // sign of a zero). The second pass finds v^C in the velocities; only the
  // kicked particles keep v_{n-1/2} aside (for the others it is v^C).
  const std::size_t n = particles_.size();
  computeExternal();
  velocityBefore_.resize(3 * n);
  double* __restrict v = particles_.velocity.data();
  double* __restrict u = particles_.displacement.data();
  double* __restrict vOld = velocityBefore_.data();
  const double* __restrict m = particles_.mass.data();
  const double* __restrict fe = particles_.externalForce.data();
  const std::uint32_t* constrained = constraintOffset_.data();
  double w = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    double* vi = v + 3 * i;
    const double* fei = fe + 3 * i;
    const bool loaded = fei[0] != 0.0 || fei[1] != 0.0 || fei[2] != 0.0;
    const bool bound = constrained[i] != constrained[i + 1];
    // A free particle without external force neither kicks nor moves here.
    if (!loaded && !bound) continue;
    for (std::size_t a = 0; a < 3; ++a) vOld[3 * i + a] = vi[a];
    for (std::size_t a = 0; a < 3; ++a) vi[a] += dt * fei[a] / m[i];
    if (bound) constrainParticle(i, vi);
    for (std::size_t a = 0; a < 3; ++a) {
      const double du = dt * (vi[a] - vOld[3 * i + a]);
      u[3 * i + a] += du;
      if (loaded) w += fei[a] * du;
    }
  }
  computeInternal();
  const double* __restrict fi = particles_.internalForce.data();
  for (std::size_t i = 0; i < n; ++i) {
    double* vi = v + 3 * i;
    const double* fei = fe + 3 * i;
    const bool loaded = fei[0] != 0.0 || fei[1] != 0.0 || fei[2] != 0.0;
    const bool bound = constrained[i] != constrained[i + 1];
    double before[3], coupled[3];  // v_{n-1/2} and v^C
    for (std::size_t a = 0; a < 3; ++a) {
      coupled[a] = vi[a];
      before[a] = loaded || bound ? vOld[3 * i + a] : vi[a];
    }
    for (std::size_t a = 0; a < 3; ++a) vi[a] += dt * fi[3 * i + a] / m[i];
    if (bound) constrainParticle(i, vi);
    for (std::size_t a = 0; a < 3; ++a) {
      const double du = dt * (vi[a] - coupled[a]) + dt * before[a];
      u[3 * i + a] += du;
      if (loaded) w += fei[a] * du;
    }
  }
  work_ += w;
  time_ += dt;
  ++step_;
}

Energies PdSystem::energies() const {
  Energies e;
  const auto& v = particles_.velocity;
  for (std::size_t i = 0; i < particles_.size(); ++i)
    e.kinetic += 0.5 * particles_.mass[i] *
                 (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  // Strain energies body by body like the forces, summed in body order so the
  // total does not depend on the thread count.
  std::vector<double> strain(bodies_.size(), 0.0);
  const bool perBody = sharesBodiesOut();
  const long nb = static_cast<long>(bodies_.size());
#pragma omp parallel for schedule(dynamic, 1) if (perBody)
  for (long b = 0; b < nb; ++b) {
    const auto q = static_cast<std::size_t>(b);
    strain[q] = bodies_[q].model->strainEnergy(context(q));
  }
  for (const double s : strain) e.strain += s;
  e.externalWork = work_;
  return e;
}

}  // namespace cosim::pd
