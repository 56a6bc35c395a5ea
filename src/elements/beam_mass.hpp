// Consistent translational inertia of a beam element (Simo & Vu-Quoc 1988; rotary inertia is
// lumped to the nodes, elements/inertia.hpp). With the Lagrange shape functions I_a, the mass
// integrals M_ab = integral of I_a I_b ds (BeamElementReference::mass_shape) and the nodal
// accelerations xddot_b that the time scheme gives,
//   f_a = rhoA sum_b M_ab xddot_b,     d f_a / d u_b = c rhoA M_ab I,   c = d xddot / d u
// (c = the scheme's inertia coefficient; 1 when the accelerations are the unknowns). The kinetic
// energy and momenta of the element's translation follow from the same integrals:
//   T = 1/2 rhoA sum_ab M_ab v_a.v_b,   p = rhoA sum_ab M_ab v_b,   L = rhoA sum_ab M_ab x_a x v_b.
// Pure functions: no PETSc, no MPI, no allocation.
#pragma once

#include "elements/beam.hpp"

namespace msflex {

// Adds the inertial forces to residual (6 per node: force then moment; moments untouched) and, when
// tangent is not null, c rhoA M to its translational blocks (row-major, 6n x 6n).
void BeamConsistentInertia(const BeamElementReference &ref, double rhoA, const Vec3 *accelerations, double coefficient, double *residual, double *tangent);

// Adds the element's translational kinetic energy, linear momentum and angular momentum about the
// origin, from nodal positions and velocities.
void BeamTranslationalMomenta(const BeamElementReference &ref, double rhoA, const Vec3 *positions, const Vec3 *velocities, double *kinetic_energy,
                              Vec3 *linear_momentum, Vec3 *angular_momentum);

} // namespace msflex
