// Inertia kernels for the time schemes of schemes/time_scheme.hpp. Pure functions: no PETSc,
// no MPI, no allocation. Each returns the inertial force and moment on a node (spatial) and
// their derivatives with respect to the node's step unknowns (u, omega), where
// Lambda_{n+1} = exp(hat(omega)) Lambda_n — not with respect to spins.
//
// Rotational inertia of a node with body-frame tensor J (beam sections lumped to the node by
// nodal quadrature of eq. (17), plus rigid bodies about their centres of mass):
//   Newmark family:  m_in = Lambda_{n+1} (J Wdot_{n+1} + W_{n+1} x J W_{n+1})
//   mid-point:       m_in = (Lambda_{n+1} J W_{n+1} - Lambda_n J W_n) / dt
// Point mass m whose position is x + Lambda c (a rigid body's centre of mass, offset c in the
// body frame), moving with its own algorithmic velocity; with r = Lambda c,
//   u_c = u + (Lambda_{n+1} - Lambda_n) c,  F = m * (inertial acceleration from u_c)
//   Newmark family:  force F, moment r_{n+1} x F          (virtual work at t_{n+1})
//   mid-point:       force F, moment (r_n + r_{n+1})/2 x F (the conserving map D of eq. 21)
//
// The initial-acceleration problem of the Newmark family (the equations of motion at t, with the
// configuration Lambda and the velocities of the start state; the unknowns are the accelerations
// xddot and the spatial angular acceleration wdot, so the tangents are the mass matrices):
//   rotary:          m_in = Lambda (J Wdot + W x J W),  Wdot = Lambda^T wdot,   dm/dwdot = Lambda J Lambda^T
//   offset point:    a_c = xddot + wdot x r + w x (w x r),  F = m a_c,  moment r x F
#pragma once

#include "schemes/time_scheme.hpp"

#include <Eigen/Core>

namespace msflex {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;

// residual: inertial moment (3); tangent: d/d omega (3x3); update: W_{n+1}, Wdot_{n+1}, a_{n+1}.
// Newmark family with `prescribed_spin`: W_{n+1} and Wdot_{n+1} are that prescribed rotation's own
// (they do not vary with omega) instead of the scheme's from omega.
void RotationalInertia(const TimeScheme &scheme, const Mat3 &inertia, const Mat3 &rotation_start, const Vec3 &omega, const MotionState &start, Vec3 *moment,
                       Mat3 *tangent, MotionUpdate *update);

// The incremental rotation omega of a step and what follows from it: Lambda_{n+1} = exp(hat omega)
// Lambda_n, H(omega), and the mid-point schemes' alpha = 2 tan(|omega|/2) omega/|omega| with
// d alpha/d omega (as the State keeps them per node, so the kernel need not form them again).
struct RotationIncrement {
  Vec3 omega;
  Mat3 rotation, tangent;
  Vec3 scaled;
  Mat3 scaled_derivative;
};
void RotationalInertia(const TimeScheme &scheme, const Mat3 &inertia, const Mat3 &rotation_start, const RotationIncrement &increment, const MotionState &start,
                       Vec3 *moment, Mat3 *tangent, MotionUpdate *update, const MotionUpdate *prescribed_spin = nullptr);

// residual: (force, moment) on the node (6); tangent: d/d(u, omega) (6x6); update: the point's motion.
// Mid-point family (the centre of mass moves with its own algorithmic velocity, which the
// conserving scheme keeps consistent with the node); the Newmark family uses
// RigidOffsetMassInertia below.
void OffsetPointMassInertia(const TimeScheme &scheme, double mass, const Vec3 &offset, const Mat3 &rotation_start, const Vec3 &u, const Vec3 &omega,
                            const MotionState &start, Vec6 *residual, Mat6 *tangent, MotionUpdate *update);

// Newmark family: the centre of mass as a point of the node's rigid frame. Its acceleration follows
// from the node's algorithmic motion (translation a, material angular velocity W and acceleration
// Wdot, all of the scheme at t_{n+1}) instead of being integrated as a point of its own:
//   a_c = a + Lambda_{n+1} (Wdot x c + W x (W x c)),   F = m a_c,   moment r_{n+1} x F.
// Together with the rotary inertia about the centre of mass (RotationalInertia) this is the rigid
// body's Newton-Euler equations about the node, J_o = J_c - m hat(c)^2, which Newmark integrates
// with the Simo & Vu-Quoc update: a body spinning about a held node with its centre of mass away
// from it keeps the scheme's stability (integrating the centre of mass as an independent Newmark
// point does not: its trajectory leaves the sphere the joint allows and the energy grows).
// residual (6) and tangent d/d(u, omega) (6x6); `node_acceleration` is the node's translational
// acceleration at t_{n+1}, the scheme's from its increment u (d a / d u = the scheme's
// InertiaCoefficient, the tangent's) or a prescribed motion's own; `rotation` is the node's
// start-of-step material rotational motion; with `prescribed_spin` the node's W and Wdot at t_{n+1}
// are that prescribed rotation's own (as for RotationalInertia).
void RigidOffsetMassInertia(const TimeScheme &scheme, double mass, const Vec3 &offset, const Mat3 &rotation_start, const Vec3 &omega,
                            const Vec3 &node_acceleration, const MotionState &rotation, Vec6 *residual, Mat6 *tangent,
                            const MotionUpdate *prescribed_spin = nullptr);

// Initial-acceleration problem: rotary inertia of a node with body-frame tensor J, rotation Lambda
// and body angular velocity W; moment and d moment / d wdot.
void InitialRotationalInertia(const Mat3 &inertia, const Mat3 &rotation, const Vec3 &body_angular_velocity, const Vec3 &angular_acceleration, Vec3 *moment,
                              Mat3 *tangent);

// Initial-acceleration problem: point mass at the spatial offset r from a node moving with spatial
// angular velocity w; (force, moment) on the node and its derivative d/d(xddot, wdot).
void InitialOffsetPointMassInertia(double mass, const Vec3 &offset, const Vec3 &angular_velocity, const Vec3 &acceleration, const Vec3 &angular_acceleration,
                                   Vec6 *residual, Mat6 *tangent);

} // namespace msflex
