// Master–slave kinematics of a joint (Muñoz, Jelenić & Crisfield 2003, §2–3). Pure functions: no
// PETSc, no MPI, no allocation.
//
// A joint relates a slave node to a master node through released coordinates q (translations
// along joint axes, rotation angles about joint axes, or a free rotation), all in the master's
// body frame, which is the global frame at the reference configuration:
//   x_s = x_m + Lambda_m b(q),   b(q) = d0 + A t(q)                                  (eq. 1)
//   Lambda_s = Lambda_m C(q)
// d0 is the reference offset of the slave from the master, A = [a1 a2 a3] the joint axes, t(q)
// the released translation in joint axes (with a dependent part f(phi) - f(0) along one axis for
// screw, rack-and-pinion and cam joints, eq. 9), and C(q) the released rotation:
//   one axis:   C = exp(phi hat(a_i))
//   two axes:   C = exp(phi1 hat(a_i)) exp(phi2 hat(a_j))        (a Cardan joint)
//   free:       C = exp(hat(omega_R)) C_n                        (q = incremental rotation vector)
// Spin variations (delta Lambda = hat(delta theta) Lambda) give eq. (6)/(11):
//   delta x_s     = delta x_m - hat(Lambda_m b) delta theta_m + Lambda_m B delta q,   B = db/dq
//   delta theta_s = delta theta_m + Lambda_m Omega delta q,  hat(Omega dq) = dC C^T
//   N = [[I, -hat(Lambda_m b), Lambda_m B], [0, I, Lambda_m Omega]]          (6 x (6 + k))
// and the geometric term of the condensed tangent, at fixed slave residual g = (g_f, g_m):
//   d(N^T g) / d(theta_m, q), nonzero in the (theta_m, q) rows and columns.
// The mid-point schemes use instead the conserving map Ntilde of eq. (21)–(22), its geometric
// term d(Ntilde^T g)/d(x_m, theta_m, q) and the derivative of its released test quantities
// (declared below, implemented in joint_conserving.cpp).
#pragma once

#include "math/rotation.hpp"

#include <Eigen/Core>

namespace msflex {

constexpr int kJointMaxReleased = 6;

enum class JointRotation { None, OneAxis, TwoAxes, Free };
enum class JointDependence { None, Linear, EccentricCam, Table };

// A periodic C^2 cubic spline f(phi) of period `period` through samples (knots[i], values[i]),
// knots increasing in [knots[0], knots[0] + period) (the profile of a general cam; the second
// derivatives come from PeriodicSplineSecondDerivatives). The arrays are owned elsewhere.
struct PeriodicSpline {
  double        period = 2.0 * 3.14159265358979323846;
  int           count  = 0;
  const double *knots  = nullptr;
  const double *values = nullptr;
  const double *second = nullptr;
};
// f, f', f'' of the spline at phi (any real phi: the spline repeats with its period).
void PeriodicSplineEvaluate(const PeriodicSpline &spline, double phi, double *f, double *df, double *ddf);
// Second derivatives that make the periodic spline through (knots, values) C^2. Returns false when
// the knots are not strictly increasing within one period or there are fewer than 3.
bool PeriodicSplineSecondDerivatives(double period, int count, const double *knots, const double *values, double *second);

struct JointGeometry {
  Mat3 axes   = Mat3::Identity(); // columns a1, a2, a3 (master body frame)
  Vec3 offset = Vec3::Zero();     // d0: slave minus master position at the reference configuration
  // Released translations: along axes translation_axis[0..n_translations).
  int           num_translations    = 0;
  int           translation_axis[3] = {0, 1, 2};
  JointRotation rotation            = JointRotation::None;
  int           rotation_axis[2]    = {0, 1}; // OneAxis: [0]; TwoAxes: [0] then [1]
  // Dependent translation along axis `dependent_axis`: f(phi) - f(0), phi the (single) rotation.
  JointDependence dependence     = JointDependence::None;
  int             dependent_axis = 0;
  double          coefficient    = 0.0; // Linear: f = c phi (screw pitch, pinion radius); EccentricCam: f = R cos(phi)
  PeriodicSpline  profile;              // Table
};

// Number of released coordinates: translations, then rotation coordinates (1, 2 or 3).
int JointNumCoordinates(const JointGeometry &joint);

// The dependent function and its first two derivatives at phi.
void JointDependentTranslation(const JointGeometry &joint, double phi, double *f, double *df, double *ddf);

struct JointCoordinates {
  double q[kJointMaxReleased] = {0, 0, 0, 0, 0, 0}; // translations, then angles (or omega_R for a free rotation)
  Mat3   free_rotation_start  = Mat3::Identity();   // C_n of a free rotation
};

using JointMatrix = Eigen::Matrix<double, 6, 6 + kJointMaxReleased, Eigen::RowMajor>;
using JointSquare = Eigen::Matrix<double, 6 + kJointMaxReleased, 6 + kJointMaxReleased, Eigen::RowMajor>;

// Slave position and rotation from the master's and the released coordinates.
void JointSlaveConfiguration(const JointGeometry &joint, const JointCoordinates &q, const Vec3 &master_position, const Mat3 &master_rotation,
                             Vec3 *slave_position, Mat3 *slave_rotation);

// The released rotation's step, C(q_start + dq) C(q_start)^T, from the increments dq without
// forming q_start + dq: that sum rounds to eps |q|, and a coordinate that has turned far (a shaft
// at 130 rad: 3e-14 rad) would make the slave's spin a staircase in dq, whose steps the inertia
// turns into a residual floor (1e-7 N m at dt = 1e-3) that Newton cannot pass.
Mat3 JointRotationStep(const JointGeometry &joint, const JointCoordinates &start, const double *increment);
// C(q): the slave's rotation relative to the master.
Mat3 JointReleasedRotation(const JointGeometry &joint, const JointCoordinates &q);
// b(q_start + dq) - b(q_start), the slave's offset in the master frame over the step, from dq
// alone for the same reason (a slider 2 km along: q + dq rounds to 4.5e-13 m): translations
// A dq, a linear dependent translation c dphi, a cam R (cos(phi + dphi) - cos phi) =
// -2 R sin(phi + dphi/2) sin(dphi/2), a periodic profile from its argument reduced first.
Vec3 JointOffsetStep(const JointGeometry &joint, const JointCoordinates &start, const double *increment);
// b(q): the slave's offset in the master frame.
Vec3 JointOffset(const JointGeometry &joint, const JointCoordinates &q);

// N (first 6 + k columns used): slave spin variations from (delta x_m, delta theta_m, delta q).
void JointMap(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &master_rotation, JointMatrix *N);

// The slave's accelerations that N leaves out, (dN/dt) (v_m, w_m, qdot): with r = R_m b(q) and the
// relative spin s = R_m Omega(q) qdot (spatial),
//   a_s = a_m + wdot_m x r + R_m B qddot + [w_m x (w_m x r) + 2 w_m x (R_m B qdot) + R_m a_dep f''(phi) qdot_phi^2]
//   wdot_s = wdot_m + R_m Omega qddot + [w_m x s + R_m (dOmega/dt) qdot]
// the brackets returned (translation, then rotation): the centripetal and Coriolis terms, a
// dependent translation's curvature, and for two axes (dOmega/dt) qdot = qdot_1 qdot_2 a_i x Omega_2.
// A free rotation's coordinates are zero at the start of a step, where H(q) = I + hat(q)/2 + ...
// gives (dOmega/dt) qdot = hat(qdot) qdot / 2 = 0; the term is evaluated there (the
// initial-acceleration problem, its only caller). w_m spatial, qdot the coordinates' rates.
Eigen::Matrix<double, 6, 1> JointVelocityProductAcceleration(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &master_rotation,
                                                             const Vec3 &master_angular_velocity, const double *rates);

// d(N^T g)/d(x_m, theta_m, q) at fixed g (first 6 + k rows and columns used).
void JointGeometricStiffness(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &master_rotation, const Eigen::Matrix<double, 6, 1> &g,
                             JointSquare *G);

// The conserving map of the mid-point schemes (eq. 21–22): with tangent-scaled increments
// alpha (Lambda_{n+1} = cay(alpha) Lambda_n), the slave's step test vector follows exactly
//   u_s     = u_m + C_t (b_{n+1} - b_n) + D alpha_m,   C_t = (I + hat(alpha_m)/2) Lambda_{m,n},
//                                                       D = -(hat(r_n) + hat(r_{n+1}))/2, r = Lambda_m b
//   alpha_s = alpha_m + A beta,   beta = Lambda_{m,n} alpha_R,  A = (I + hat(alpha_m)/2 + alpha_m alpha_m^T/4) / (1 - alpha_m.beta/4)
// where alpha_R is the tangent-scaled released rotation (C_{n+1} C_n^T = cay(alpha_R)) and
// b_{n+1} - b_n is linear in the released test quantities p: translations dq, and per rotation
// coordinate tau = 2 tan(dphi/2) (dependent translation: the secant G of JointDependentSecant),
// or alpha_R itself for a free rotation. Ntilde (6 x (6 + k)) maps (u_m, alpha_m, p) to
// (u_s, alpha_s); `released_test` returns p. Since the map is exact, the work and the momenta of
// the slave's forces carry over to the master and the released coordinates.
// `start` holds q_n (a free rotation's coordinates are zero at the start of a step, its C_n in
// free_rotation_start), `increment` the released increments dq of the step (the rotation vector
// omega_R of a free rotation, |omega_R| < pi; |dphi| < pi), offset_start and offset_end
// r_n = (x_s - x_m)_n and r_{n+1} = (x_s - x_m)_{n+1}. A joint to the ground takes the identity
// and zero for the master's rotation and alpha.
void JointConservingMap(const JointGeometry &joint, const JointCoordinates &start, const double *increment, const Mat3 &master_rotation_start,
                        const Vec3 &master_alpha, const Vec3 &offset_start, const Vec3 &offset_end, JointMatrix *Ntilde, double *released_test);

// The secant of a dependent translation over a step from phi_n by dphi, with tau = 2 tan(dphi/2):
//   G(dphi) = (f(phi_n + dphi) - f(phi_n)) / tau,   dG/d(dphi),
// evaluated without cancellation for small steps (G -> f'(phi_n), dG -> f''(phi_n)/2):
//   linear f = c phi:      G = c kappa,  kappa(dphi) = (dphi/2) cot(dphi/2)
//   eccentric f = R cos:   G = (f'(phi_n) + f'(phi_{n+1}))/2,   dG = f''(phi_{n+1})/2
//   spline:                G = sigma kappa, sigma = int_0^1 f'(phi_n + s dphi) ds,
//                          dsigma/d(dphi) = int_0^1 s f''(phi_n + s dphi) ds
// (the spline's integrals by two-point Gauss between the knots crossed, exact for a cubic).
void JointDependentSecant(const JointGeometry &joint, double phi_start, double dphi, double *G, double *dG_ddphi);

using JointReleasedMatrix = Eigen::Matrix<double, kJointMaxReleased, kJointMaxReleased, Eigen::RowMajor>;

// dp/dq (first k rows and columns used): the derivative of the released test quantities of
// JointConservingMap with respect to the released increments. Diagonal 1 for a translation and
// 1 + tau^2/4 = sec^2(dphi/2) for an angle; for a free rotation the block
//   d alpha_R / d omega_R = S(alpha_R) H(omega_R),   S(a) = I - hat(a)/2 + a a^T/4
// (from S(a)^{-1} d a = d theta = H(omega) d omega, eq. 4 and 17).
void JointReleasedTestDerivative(const JointGeometry &joint, const double *increment, JointReleasedMatrix *dp_dq);

// The geometric term of the condensed tangent of the mid-point schemes: d(Ntilde^T g)/d(x_m, theta_m, q)
// at fixed slave residual g = (g_f, g_m) (the rows conjugate to (u_m, alpha_m, p), first 6 + k
// rows and columns used), with the columns of JointGeometricStiffness: delta x_m, delta theta_m
// the spatial spin of the master's END rotation Lambda_{m,n+1}, and delta q the increments of the
// released coordinates (omega_R of a free rotation). The inputs are those of JointConservingMap
// less the offsets, which the kernel rebuilds at the end of the step from the joint kinematics:
//   Lambda_{m,n+1} = cay(alpha_m) Lambda_{m,n},  r_{n+1} = Lambda_{m,n+1} b(q_n + dq),
//   d alpha_m = S(alpha_m) delta theta_m,  S(a) = I - hat(a)/2 + a a^T/4,
//   d r_{n+1} = -hat(r_{n+1}) delta theta_m + Lambda_{m,n+1} B delta q.
// With v = C_t^T g_f = Lambda_{m,n}^T (I - hat(alpha_m)/2) g_f, y = Lambda_{m,n}^T S(alpha_m) g_m and
// den = 1 - alpha_m.beta/4, the rows of Ntilde^T g are
//   (u_m)          g_f                                   (constant: zero rows)
//   (alpha_m)      g_m + (r_n + r_{n+1}) x g_f / 2
//   (translation)  a_c . v
//   (rotation c)   W_c . y / den  (+ G a_dep . v on the angle of a dependent translation)
// where alpha_R = W p (W = [a] for one axis, [a_i, b_m / cos(dphi_1/2)], b_m = exp(phi_1 hat(a_i)) a_j
// at the step's mid-angle, for two axes, I for a free rotation), and their derivatives are
//   d(alpha_m row)     = hat(g_f) hat(r_{n+1}) delta theta_m / 2 - hat(g_f) Lambda_{m,n+1} B delta q / 2
//   d(translation row) = a_c^T Lambda_{m,n}^T hat(g_f) S(alpha_m) delta theta_m / 2
//   d(rotation row c)  = [W_c^T dy/d alpha_m / den + (W_c . y) beta^T / (4 den^2)] S(alpha_m) delta theta_m
//                        + sum_d [dW_c/dq_d . y / den + (W_c . y)(Lambda_{m,n}^T alpha_m) . (d alpha_R/dq_d) / (4 den^2)] delta q_d
//                        (+ G a_dep^T Lambda_{m,n}^T hat(g_f) S(alpha_m) delta theta_m / 2 + dG (a_dep . v) delta phi)
//   dy/d alpha_m = Lambda_{m,n}^T (hat(g_m)/2 + (alpha_m g_m^T + (alpha_m . g_m) I)/4).
// The x_m columns are zero (Ntilde does not depend on the master's position).
//
// Chains: the kernel differentiates one joint's map only. For a slave whose master is itself a
// slave, the assembler composes exactly as for JointGeometricStiffness, deepest joint first:
//  - rows: the master's expansion ROWS (built with the master's own conserving map) for the
//    (u_m, alpha_m) rows, identity for the free released coordinates; columns: the master's
//    expansion COLUMNS (built with N, since delta theta_m is an exact variation of the master's end
//    rotation), identity for the free released coordinates;
//  - the master's joint then sees, besides its own slave residual, what this joint passes on:
//    g_master += Ntilde_m^T g (the first 6 columns of this joint's conserving map, not of N), and
//    its own conserving geometric term is evaluated with that sum.
// alpha_m of a slave master is its own tangent-scaled increment (cay(alpha_m) = Lambda_{m,n+1} Lambda_{m,n}^T),
// so d alpha_m = S(alpha_m) delta theta_m holds whatever the master is.
void JointConservingGeometricStiffness(const JointGeometry &joint, const JointCoordinates &start, const double *increment, const Mat3 &master_rotation_start,
                                       const Vec3 &master_alpha, const Eigen::Matrix<double, 6, 1> &g, JointSquare *G);

} // namespace msflex
