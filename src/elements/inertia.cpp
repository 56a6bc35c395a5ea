#include "elements/inertia.hpp"

namespace msflex {

void RotationalInertia(const TimeScheme &scheme, const Mat3 &J, const Mat3 &rotation_start, const Vec3 &omega, const MotionState &start, Vec3 *moment,
                       Mat3 *tangent, MotionUpdate *update)
{
  RotationIncrement increment;
  increment.omega    = omega;
  increment.rotation = ExpSO3(omega) * rotation_start;
  increment.tangent  = TangentH(omega);
  if (scheme.Midpoint()) TangentScaledIncrement(omega, &increment.scaled, &increment.scaled_derivative);
  RotationalInertia(scheme, J, rotation_start, increment, start, moment, tangent, update);
}

void RotationalInertia(const TimeScheme &scheme, const Mat3 &J, const Mat3 &rotation_start, const RotationIncrement &increment, const MotionState &start,
                       Vec3 *moment, Mat3 *tangent, MotionUpdate *update, const MotionUpdate *prescribed_spin)
{
  const Vec3 &omega = increment.omega;
  const Mat3 &R_new = increment.rotation;
  const Mat3 &H     = increment.tangent;
  if (scheme.Midpoint()) {
    const Vec3 &alpha   = increment.scaled;
    const Mat3 &dalpha  = increment.scaled_derivative;
    *update             = AdvanceMotion(scheme, start, rotation_start.transpose() * alpha);
    const Vec3 momentum = R_new * (J * update->velocity);
    *moment             = (momentum - rotation_start * (J * start.velocity)) / scheme.dt;
    if (tangent) *tangent = (-Skew(momentum) * H + R_new * J * (scheme.VelocityCoefficient() * rotation_start.transpose() * dalpha)) / scheme.dt;
    return;
  }
  *update          = prescribed_spin ? *prescribed_spin : AdvanceMotion(scheme, start, rotation_start.transpose() * omega);
  const Vec3 &W    = update->velocity;
  const Vec3  JW   = J * W;
  const Vec3  body = J * update->acceleration + W.cross(JW);
  *moment          = R_new * body;
  if (tangent) {
    *tangent = -Skew(*moment) * H;
    if (!prescribed_spin) {
      const Mat3 dbody_dtheta = scheme.InertiaCoefficient() * J + scheme.VelocityCoefficient() * (Skew(W) * J - Skew(JW));
      *tangent += R_new * dbody_dtheta * rotation_start.transpose();
    }
  }
}

void OffsetPointMassInertia(const TimeScheme &scheme, double mass, const Vec3 &offset, const Mat3 &rotation_start, const Vec3 &u, const Vec3 &omega,
                            const MotionState &start, Vec6 *residual, Mat6 *tangent, MotionUpdate *update)
{
  const Mat3 R_new = ExpSO3(omega) * rotation_start;
  const Vec3 r_old = rotation_start * offset, r_new = R_new * offset;
  *update      = AdvanceMotion(scheme, start, u + r_new - r_old);
  const Vec3 F = mass * update->acceleration;
  // Lever arm of the virtual work: r_{n+1} (Newmark family) or the mid-point (r_n + r_{n+1})/2.
  const Vec3   arm        = scheme.Midpoint() ? Vec3(0.5 * (r_old + r_new)) : r_new;
  const double arm_weight = scheme.Midpoint() ? 0.5 : 1.0; // d arm / d r_new
  residual->head<3>()     = F;
  residual->tail<3>()     = arm.cross(F);
  if (!tangent) return;
  const Mat3 dr_domega       = -Skew(r_new) * TangentH(omega);
  const Mat3 dF_du           = mass * scheme.InertiaCoefficient() * Mat3::Identity();
  const Mat3 dF_domega       = dF_du * dr_domega;
  tangent->block<3, 3>(0, 0) = dF_du;
  tangent->block<3, 3>(0, 3) = dF_domega;
  tangent->block<3, 3>(3, 0) = Skew(arm) * dF_du;
  tangent->block<3, 3>(3, 3) = Skew(arm) * dF_domega - arm_weight * Skew(F) * dr_domega;
}

void RigidOffsetMassInertia(const TimeScheme &scheme, double mass, const Vec3 &offset, const Mat3 &rotation_start, const Vec3 &omega,
                            const Vec3 &node_acceleration, const MotionState &rotation, Vec6 *residual, Mat6 *tangent, const MotionUpdate *prescribed_spin)
{
  const Mat3         R_new = ExpSO3(omega) * rotation_start;
  const MotionUpdate spin  = prescribed_spin ? *prescribed_spin : AdvanceMotion(scheme, rotation, rotation_start.transpose() * omega);
  const Vec3        &c = offset, &W = spin.velocity, &Wdot = spin.acceleration;
  const Vec3         Wc = W.cross(c);
  const Vec3         y  = Wdot.cross(c) + W.cross(Wc); // body-frame acceleration of the centre relative to the node
  const Vec3         r  = R_new * c;
  const Vec3         F  = mass * (node_acceleration + R_new * y);
  residual->head<3>()   = F;
  residual->tail<3>()   = r.cross(F);
  if (!tangent) return;
  // d(R y) = -hat(R y) H d omega + R dy,  dy = [-hat(c) ca + (-hat(W x c) - hat(W) hat(c)) cv] R_n^T d omega.
  const Mat3 H = TangentH(omega);
  // A prescribed spin (W, Wdot) does not vary with omega.
  const double ca = scheme.InertiaCoefficient(), spin_ca = prescribed_spin ? 0.0 : ca, spin_cv = prescribed_spin ? 0.0 : scheme.VelocityCoefficient();
  const Mat3   dy_domega     = (-Skew(c) * spin_ca + (-Skew(Wc) - Skew(W) * Skew(c)) * spin_cv) * rotation_start.transpose();
  const Mat3   dF_du         = mass * ca * Mat3::Identity();
  const Mat3   dF_domega     = mass * (-Skew(R_new * y) * H + R_new * dy_domega);
  const Mat3   dr_domega     = -Skew(r) * H;
  tangent->block<3, 3>(0, 0) = dF_du;
  tangent->block<3, 3>(0, 3) = dF_domega;
  tangent->block<3, 3>(3, 0) = Skew(r) * dF_du;
  tangent->block<3, 3>(3, 3) = Skew(r) * dF_domega - Skew(F) * dr_domega;
}

void InitialRotationalInertia(const Mat3 &inertia, const Mat3 &rotation, const Vec3 &body_angular_velocity, const Vec3 &angular_acceleration, Vec3 *moment,
                              Mat3 *tangent)
{
  const Vec3 &W = body_angular_velocity;
  *moment       = rotation * (inertia * (rotation.transpose() * angular_acceleration) + W.cross(inertia * W));
  if (tangent) *tangent = rotation * inertia * rotation.transpose();
}

void InitialOffsetPointMassInertia(double mass, const Vec3 &offset, const Vec3 &angular_velocity, const Vec3 &acceleration, const Vec3 &angular_acceleration,
                                   Vec6 *residual, Mat6 *tangent)
{
  const Vec3 &r = offset, &w = angular_velocity;
  const Vec3  F       = mass * (acceleration + angular_acceleration.cross(r) + w.cross(w.cross(r)));
  residual->head<3>() = F;
  residual->tail<3>() = r.cross(F);
  if (!tangent) return;
  const Mat3 hr              = Skew(r);
  tangent->block<3, 3>(0, 0) = mass * Mat3::Identity();
  tangent->block<3, 3>(0, 3) = -mass * hr;
  tangent->block<3, 3>(3, 0) = mass * hr;
  tangent->block<3, 3>(3, 3) = -mass * hr * hr;
}

} // namespace msflex
