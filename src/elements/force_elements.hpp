// Force elements as kernels: springs, dampers and actuators on a joint's released coordinate, an
// axial spring-damper between two nodes and a six-component bushing. Pure functions: no PETSc, no
// MPI, no allocation. Conventions as in the other kernels: the residual holds internal forces with
// a plus sign and applied forces with a minus sign; tangents are with respect to the end of the
// step, columns (delta x, delta theta) per node in spin form (delta Lambda = hat(delta theta)
// Lambda) or the coordinate's increment.
//
// Two forms of every element:
//  - end point (statics, the Newmark family, the initial-acceleration problem): forces of the
//    configuration and the velocities at one instant; a damper's velocity v_{n+1} comes from the
//    scheme (dv/d increment = the scheme's velocity coefficient c_v);
//  - mid-point (mc, em): a discrete gradient, whose virtual work over the step's test quantities
//    (u, alpha, and the released test quantities p of the joints) equals exactly the change of the
//    element's stored energy plus the damper's dissipation minus the actuator's work:
//      spring  f = (V(x_{n+1}) - V(x_n)) / (x_{n+1} - x_n)   (the mean of the force over the step)
//      damper  f = c (x_{n+1} - x_n) / dt                    (dissipation c (x_{n+1} - x_n)^2 / dt >= 0)
//    so that em keeps energy - work + dissipated energy constant.
// The dissipation of a step is the damper's force times the change of the element's deflection
// over the step: exact work in the mid-point form; elsewhere the kernel's dissipation and
// actuator_work are end-point values (the force at the end of the step times the change), and the
// contributors take the trapezoidal rule (the mean of the start's and the end's) in the Newmark family.
#pragma once

#include "math/rotation.hpp"
#include "schemes/time_scheme.hpp"

#include <Eigen/Core>

namespace msflex {

using Vec6  = Eigen::Matrix<double, 6, 1>;
using Mat6  = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12, Eigen::RowMajor>;

// The force law of a spring as a function of its coordinate x (a released coordinate, or the
// length between two nodes): linear, f = stiffness (x - free_value), or tabulated, f = the
// piecewise-linear curve through (deflections[i], forces[i]) evaluated at x - free_value and
// continued beyond both ends with the end segments' slopes (deflections strictly increasing, at
// least two points). The arrays are owned elsewhere.
struct SpringCurve {
  double        stiffness   = 0.0;
  double        free_value  = 0.0;
  int           count       = 0; // 0: linear
  const double *deflections = nullptr;
  const double *forces      = nullptr;
};
// f(x) and df/dx.
double SpringForce(const SpringCurve &spring, double x, double *slope);
// Stored energy V(x) = integral of f from the free value to x.
double SpringEnergy(const SpringCurve &spring, double x);
// The mean force over [x0, x1], (V(x1) - V(x0)) / (x1 - x0) (f(x0) when x1 = x0), and its
// derivative with respect to x1; computed from the pieces of the curve, without cancellation.
double SpringMeanForce(const SpringCurve &spring, double x0, double x1, double *derivative);

// --- On a joint's released coordinate q -------------------------------------------------------
//
// The generalised force of a spring, a linear damper c and an actuator A (already weighted in
// time), in the coordinate's row of the residual:
//   end point:  r = f_s(q) + c qdot - A,                   dr/d dq = f_s'(q) + c c_v
//   mid-point:  r = (f_mean(q_n, q_n + dq) + c dq/dt - A) rho,
//               rho = dq / p,  p the released test quantity (dq for a translation, 2 tan(dq/2) for
//               an angle), so that r p = (f_mean + c dq/dt - A) dq exactly.
struct CoordinateForceStep {
  bool   midpoint         = false;
  bool   angle            = false; // the coordinate is an angle (mid-point test quantity 2 tan(dq/2))
  double start            = 0.0;   // q_n
  double increment        = 0.0;   // dq (zero in the initial-acceleration problem)
  double rate             = 0.0;   // end point: qdot at the instant of the equations
  double rate_coefficient = 0.0;   // end point: d qdot / d dq (0 in statics and for accelerations)
  double dt               = 0.0;   // mid-point only
  double actuator         = 0.0;   // A, weighted in time
};
struct CoordinateForceValues {
  double residual = 0.0, tangent = 0.0;
  // The parts of the generalised force the element exerts on the coordinate (the negatives of
  // their residual contributions): spring, damper, actuator.
  double spring_force = 0.0, damper_force = 0.0, actuator_force = 0.0;
  // Over the step (dq): the work of the damper (dissipation, >= 0 in the mid-point form) and of
  // the actuator.
  double dissipation = 0.0, actuator_work = 0.0;
};
void CoordinateForce(const SpringCurve *spring, double damping, const CoordinateForceStep &step, CoordinateForceValues *out);
// rho(dq) = dq / (2 tan(dq/2)) and its derivative (rho -> 1 as dq -> 0).
double AngleTestRatio(double increment, double *derivative);

// --- Axial spring-damper between two nodes a and b ---------------------------------------------
//
// l = |x_b - x_a|, e = (x_b - x_a)/l, tension T = f_s(l) + c ldot:
//   end point:  r_a = -T e, r_b = T e,  ldot = e . (v_b - v_a),  dv/dx = c_v I
//   mid-point:  r_b = -r_a = T e_bar,  e_bar = (d_n + d_{n+1}) / (l_n + l_{n+1}),  T = f_mean(l_n, l_{n+1}) + c (l_{n+1} - l_n)/dt
// (e_bar . (d_{n+1} - d_n) = l_{n+1} - l_n exactly, and e_bar is along the mid-point chord, so no
// moment about the mid-point configuration). Residual 12 (force, moment per node; moments zero),
// tangent 12x12 (rotation columns zero). Returns false when the nodes coincide.
struct AxialSpringValues {
  Vec12  residual;
  double length         = 0.0; // at the end of the step
  double tension        = 0.0; // T of the equations (spring and damper)
  double damper_tension = 0.0; // the damper's part of T
};
bool AxialSpringDamperEndPoint(const SpringCurve &spring, double damping, const Vec3 &x_a, const Vec3 &x_b, const Vec3 &v_a, const Vec3 &v_b,
                               double velocity_coefficient, AxialSpringValues *out, Mat12 *tangent);
bool AxialSpringDamperMidpoint(const SpringCurve &spring, double damping, const Vec3 &x_a_start, const Vec3 &x_b_start, const Vec3 &x_a, const Vec3 &x_b,
                               double dt, AxialSpringValues *out, Mat12 *tangent);

// --- Bushing between two nodes a and b ------------------------------------------------------------
//
// The bushing frame S = Lambda_a A0 follows node a (A0: its axes at the reference configuration).
// Deflections e = (d, eta):
//   d   = S^T (x_b - x_a) - d_ref                   (d_ref: the reference offset in bushing axes)
//   eta = 2 tan(theta/2) n  of  R = S^T Lambda_b A0 (the tangent-scaled relative rotation: equal
//         to the rotation vector theta n to second order; the bushing cannot turn by pi)
// Energy V = e^T K e / 2, force f = K e + C edot (K, C symmetric 6x6, bushing axes). With
//   edot = B (v_a, w_a, v_b, w_b):  ddot = S^T (v_b - v_a + (x_b - x_a) x w_a),
//                                   etadot = S(eta) S^T (w_b - w_a),   S(a) = I - hat(a)/2 + a a^T/4
// the forces on b are F = S f_d, M = S S(eta)^T f_eta, on a: -F and -(x_b - x_a) x F - M.
// Mid-point form: with S_m = (S_n + S_{n+1})/2 and the relative Cayley increment
//   g = S_n^T (I - hat(alpha_a)/2)(alpha_b - alpha_a) / (1 + alpha_a.alpha_b/4)   (R_{n+1} = cay(g) R_n)
// the increments are exactly linear in the test quantities:
//   d_{n+1} - d_n     = S_m^T (u_b - u_a + hat(dx_m) alpha_a),   dx_m = ((x_b - x_a)_n + (x_b - x_a)_{n+1})/2
//   eta_{n+1} - eta_n = S(eta_n) g / (1 - g.eta_n/4)
// and f = K (e_n + e_{n+1})/2 + C (e_{n+1} - e_n)/dt does work f . (e_{n+1} - e_n) = the change
// of V plus the dissipation, with no net force or moment about the mid-point configuration.
struct BushingNode {
  Vec3 position = Vec3::Zero();
  Mat3 rotation = Mat3::Identity();
  Vec3 velocity = Vec3::Zero(); // spatial
  Vec3 angular  = Vec3::Zero(); // spatial angular velocity
  // End point, for the tangent: d v / d x = velocity_coefficient I, d w / d theta = angular_jacobian.
  double velocity_coefficient = 0.0;
  Mat3   angular_jacobian     = Mat3::Zero();
};
struct BushingValues {
  Vec12 residual;
  Vec6  deflection   = Vec6::Zero(); // e at the end of the step
  Vec6  force        = Vec6::Zero(); // f of the equations, bushing axes
  Vec6  damper_force = Vec6::Zero(); // the damper's part of f
};
// End point: the deflection of the configuration; false when the relative rotation reaches pi.
bool BushingEndPoint(const Mat6 &stiffness, const Mat6 &damping, const Mat3 &axes, const Vec3 &reference_offset, const BushingNode &a, const BushingNode &b,
                     BushingValues *out, Mat12 *tangent);
// Mid-point: start and end configurations (rotations), the tangent-scaled increments alpha_a,
// alpha_b (cay(alpha) = Lambda_{n+1} Lambda_n^T).
bool BushingMidpoint(const Mat6 &stiffness, const Mat6 &damping, const Mat3 &axes, const Vec3 &reference_offset, const BushingNode &a_start,
                     const BushingNode &b_start, const BushingNode &a, const BushingNode &b, const Vec3 &alpha_a, const Vec3 &alpha_b, double dt,
                     BushingValues *out, Mat12 *tangent);
// The bushing's deflection e = (d, eta) of a configuration; false when the relative rotation reaches pi.
bool BushingDeflection(const Mat3 &axes, const Vec3 &reference_offset, const Vec3 &x_a, const Mat3 &rotation_a, const Vec3 &x_b, const Mat3 &rotation_b,
                       Vec6 *deflection);
// S(a) = I - hat(a)/2 + a a^T/4: d a = S(a) d theta for a tangent-scaled rotation a (eq. 17).
Mat3 CayleyTangentOperator(const Vec3 &a);

} // namespace msflex
