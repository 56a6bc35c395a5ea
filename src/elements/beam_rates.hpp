// Strain rates of the beam element of elements/beam.hpp from the nodal velocities, for structural
// damping. Pure functions: no PETSc, no MPI, no allocation.
//
// With the element's local coordinates (reference node c, L = Lambda_c the section triad there)
//   rho_a = L^T (x_a - x_c),   psi_a = log(L^T Lambda_a)
// their rates for spatial nodal velocities v_a and angular velocities w_a are
//   rhodot_a = L^T (v_a - v_c - w_c x (x_a - x_c)),   psidot_a = H(psi_a)^{-1} L^T (w_a - w_c)
// (d(L^T Lambda_a) (L^T Lambda_a)^T = hat(L^T (w_a - w_c))), and at a Gauss point, with
// Gamma = E(Psi)^T rho', K = H(Psi)^T Psi',
//   Gammadot = A Psidot + E^T rhodot',   Kdot = B Psidot + H^T Psidot'
//   A = d(E^T rho')/dPsi, B = d(H^T Psi')/dPsi
// exactly as the variations of the internal-force kernel. The strain accelerations of a motion with
// nodal accelerations (a_a, wdot_a) add to the rates of (a, wdot) the change of the operator along
// the motion, d/ds [D(q + s qdot)] qdot, taken by a central difference over s = +-h with
// h = 1e-5 of the time the fastest node needs to cross the element (relative error ~1e-10).
#pragma once

#include "elements/beam.hpp"

namespace msflex {

// Strains (Gamma - Gamma_0, K - K_0) and their rates at the Gauss points.
BeamKernelStatus BeamStrainRates(const BeamElementReference &ref, const Vec3 *positions, const Mat3 *triads, const Vec3 *velocities,
                                 const Vec3 *angular_velocities, Vec3 *strain, Vec3 *curvature, Vec3 *strain_rate, Vec3 *curvature_rate);

// The strain accelerations at the Gauss points of a motion with these velocities and accelerations.
BeamKernelStatus BeamStrainAccelerations(const BeamElementReference &ref, const Vec3 *positions, const Mat3 *triads, const Vec3 *velocities,
                                         const Vec3 *angular_velocities, const Vec3 *accelerations, const Vec3 *angular_accelerations,
                                         Vec3 *strain_acceleration, Vec3 *curvature_acceleration);

} // namespace msflex
