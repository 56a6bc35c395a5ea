// External loads as kernels: residual contributions r = -f (forces enter the residual with a minus
// sign) and their tangents in spin form, columns = spatial variations (delta x, delta theta) of the
// end-of-step configuration, with delta Lambda = hat(delta theta) Lambda. Pure functions: no PETSc,
// no MPI, no allocation.
//
// A load's value over a step is w0 f(t_n) + w1 f(t_{n+1}) with the weights of the time scheme
// (schemes/step_equations.hpp): (0, 1) in statics and the Newmark family, (1/2, 1/2) in the
// mid-point family.
#pragma once

#include "elements/beam.hpp"

#include <Eigen/Core>

namespace msflex {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;

// Consistent dead line load q (force per unit reference length, global axes) on a beam element:
//   r_a -= integral of I_a q ds = nodal_length_a q          (no tangent: the load is dead)
void BeamLineLoad(const BeamElementReference &ref, const Vec3 &force_per_length, double *residual);

// Nodal load: dead force and moment (global axes) and a follower force and moment given in the
// node's body frame, each at both ends of the step,
//   f = w0 (f_dead,n + Lambda_n f0_n) + w1 (f_dead,n+1 + Lambda_{n+1} f0_{n+1})   (likewise the moment)
//   r = -(f, m),   dr/d theta_{n+1} = w1 (hat(Lambda_{n+1} f0_{n+1}), hat(Lambda_{n+1} m0_{n+1}))
// since d(Lambda f0) = -hat(Lambda f0) delta theta.
struct NodalLoadValues {
  Vec3 dead_force_start = Vec3::Zero(), dead_moment_start = Vec3::Zero();         // global axes, at t_n
  Vec3 dead_force_end = Vec3::Zero(), dead_moment_end = Vec3::Zero();             // global axes, at t_{n+1}
  Vec3 follower_force_start = Vec3::Zero(), follower_moment_start = Vec3::Zero(); // body frame, at t_n
  Vec3 follower_force_end = Vec3::Zero(), follower_moment_end = Vec3::Zero();     // body frame, at t_{n+1}
};
void NodalLoadForces(const NodalLoadValues &load, double weight_start, double weight_end, const Mat3 &rotation_start, const Mat3 &rotation_end, Vec6 *residual,
                     Mat6 *tangent);

// Weight F (global, already weighted in time) of a point at offset r = Lambda c from a node, with
// the lever arm of the scheme's virtual work arm = a0 r_n + a1 r_{n+1} ((0, 1) at t_{n+1},
// (1/2, 1/2) in the mid-point family, (1, 0) in the initial-acceleration problem):
//   r = -(F, arm x F),   dr/d theta_{n+1} = (0, -a1 hat(F) hat(r_{n+1}))
// since d(-arm x F) = hat(F) d arm and d r_{n+1} = -hat(r_{n+1}) delta theta.
void OffsetPointWeight(const Vec3 &weight, const Vec3 &offset_start, const Vec3 &offset_end, double arm_weight_start, double arm_weight_end, Vec6 *residual,
                       Mat6 *tangent);

} // namespace msflex
