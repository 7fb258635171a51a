#pragma once
// Measures of a DEM state: energies, coordination, porosity, Love-Weber
// stress, and the Hertz-aware critical time step.
#include <array>
#include <span>

#include "cosim/dem/dem_system.hpp"

namespace cosim::dem {

struct Energies {
  double translational = 0.0, rotational = 0.0;
  double elastic = 0.0;    // contact springs (normal + tangential), particles and walls
  double potential = 0.0;  // gravity, relative to the origin
  double dissipated = 0.0;
  double externalWork = 0.0;
  double kinetic() const { return translational + rotational; }
  /// Conserved in exact arithmetic: kinetic + elastic + potential + dissipated - external work.
  double balance() const { return kinetic() + elastic + potential + dissipated - externalWork; }
};

Energies energies(const DemSystem& s);
/// Mean number of particle-particle contacts per particle, 2 C / N.
double coordinationNumber(const DemSystem& s);
/// Cauchy stress (tension positive), row-major 3x3, over volume V (Love-Weber):
/// sigma = 1/V [ -sum_c f_c (x) d_c + sum_w f_w (x) b_w - sum_p m_p v_p (x) v_p ] with
/// d_c = x_i - x_j for particle pairs and, for wall contacts (plane and triangle),
/// f_w the wall's force on the particle and b_w the branch from the particle centre
/// to the contact point on the wall surface (Liu 2016 Eq. 54 with the kinetic part).
/// V is the volume the walls bound (or the periodic cell); wall terms use the
/// forces of the last force evaluation.
std::array<double, 9> loveWeberStress(const DemSystem& s, double volume);
double solidVolume(const DemSystem& s);
/// Unbalanced-force index (Liu 2016 Eq. 57, after Ng):
/// I_uf = sqrt(mean_p |f_unbalanced|^2) / sqrt(mean_c |f_contact|^2), where the
/// unbalanced force is the net force without the mass-damping term. 0 without contacts.
double unbalancedForceIndex(const DemSystem& s);
/// Dynamic relaxation: advances with the system's mass damping until
/// I_uf < tolerance (checked every `every` steps) or maxSteps; returns the steps taken.
long relax(DemSystem& s, double dt, double tolerance, long maxSteps, long every = 10);
/// Largest stable step: sqrt(m*/k) for linear springs; for Hertz the smaller of
/// the Rayleigh step and the Hertz contact time at twice the fastest speed / pi;
/// with bonds also sqrt(w_i m_i / (2 k sum_b w_b)) over each particle's bonds.
double criticalTimeStep(const DemSystem& s);
/// The bonded springs' part of it: the smallest sqrt(w_i m_i / (2 k sum_b w_b)); 0 without bonds.
double bondCriticalStep(const DemSystem& s);
/// The step the contacts of driven particles allow when another solver
/// integrates them under the forces returned to it (hybrid PD particles, whose
/// mass rho V the hybrid material's density gives): the Hertz contact time at
/// twice the fastest speed / pi, or sqrt(m*/k); 0 for none or at rest.
double criticalTimeStep(const DemSystem& s, std::span<const std::uint32_t> integratedElsewhere);

/// The fine-scale critical step of Liu 2016 Eqs. 63-64 at the current contacts:
/// each particle's translational and rotational frequencies from the stiffness
/// of all its contacts, omega_n = sqrt(k_n / m) and omega_theta =
/// sqrt(5 k_t / (2 m)) (k_n the normal tangent stiffness summed over its
/// contacts, k_t the tangential), omega_max the largest of either over the
/// particles, xi = c / (2 omega_max) for the mass damping -c m v, and
/// dt_cr = 2 / omega_max (sqrt(1 + xi^2) - xi). All 0 without contacts.
struct FineTimeStep {
  double omegaN = 0.0, omegaTheta = 0.0, omegaMax = 0.0, dampingFraction = 0.0, criticalDt = 0.0;
};
FineTimeStep fineTimeStep(const DemSystem& s);

}  // namespace cosim::dem
