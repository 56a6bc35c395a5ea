#include "elements/force_elements.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// The segment of a tabulated curve used at deflection y: the one containing y, or an end segment
// beyond the table.
int CurveSegment(const SpringCurve &s, double y)
{
  const int i = (int)(std::upper_bound(s.deflections, s.deflections + s.count, y) - s.deflections) - 1;
  return std::min(std::max(i, 0), s.count - 2);
}

double CurveSlope(const SpringCurve &s, int i) { return (s.forces[i + 1] - s.forces[i]) / (s.deflections[i + 1] - s.deflections[i]); }

double CurveValue(const SpringCurve &s, double y, double *slope)
{
  const int    i = CurveSegment(s, y);
  const double k = CurveSlope(s, i);
  if (slope) *slope = k;
  return s.forces[i] + k * (y - s.deflections[i]);
}

// Integral of the tabulated curve over [a, b], a <= b, piece by piece (each piece: its length
// times the value at its middle, exact for a linear piece).
double CurveIntegral(const SpringCurve &s, double a, double b)
{
  double sum = 0.0, left = a;
  while (left < b) {
    const int    i     = CurveSegment(s, left);
    const double right = (i + 1 < s.count - 1 && s.deflections[i + 1] < b) ? s.deflections[i + 1] : b;
    // right > left: deflections[i + 1] > left whenever left lies in segment i (not the last).
    sum += (right - left) * CurveValue(s, 0.5 * (left + right), nullptr);
    left = right;
  }
  return sum;
}

} // namespace

double SpringForce(const SpringCurve &spring, double x, double *slope)
{
  if (spring.count == 0) {
    if (slope) *slope = spring.stiffness;
    return spring.stiffness * (x - spring.free_value);
  }
  return CurveValue(spring, x - spring.free_value, slope);
}

double SpringEnergy(const SpringCurve &spring, double x)
{
  const double y = x - spring.free_value;
  if (spring.count == 0) return 0.5 * spring.stiffness * y * y;
  return y >= 0.0 ? CurveIntegral(spring, 0.0, y) : -CurveIntegral(spring, y, 0.0);
}

double SpringMeanForce(const SpringCurve &spring, double x0, double x1, double *derivative)
{
  if (spring.count == 0) {
    *derivative = 0.5 * spring.stiffness;
    return spring.stiffness * (0.5 * (x0 + x1) - spring.free_value);
  }
  const double y0 = x0 - spring.free_value, y1 = x1 - spring.free_value;
  // Within one piece the mean is the value at the middle, exactly.
  if (CurveSegment(spring, y0) == CurveSegment(spring, y1)) {
    double       slope;
    const double mean = CurveValue(spring, 0.5 * (y0 + y1), &slope);
    *derivative       = 0.5 * slope;
    return mean;
  }
  const double lo = std::min(y0, y1), hi = std::max(y0, y1);
  const double mean = CurveIntegral(spring, lo, hi) / (hi - lo);
  *derivative       = (CurveValue(spring, y1, nullptr) - mean) / (y1 - y0);
  return mean;
}

double AngleTestRatio(double increment, double *derivative)
{
  // rho = h cot h with h = dq/2; d rho / d dq = (cot h - h / sin^2 h) / 2.
  const double h = 0.5 * increment;
  if (std::abs(h) < 1e-3) {
    const double h2 = h * h;
    *derivative     = 0.5 * h * (-2.0 / 3.0 - h2 * (4.0 / 45.0 + h2 * 12.0 / 945.0));
    return 1.0 - h2 * (1.0 / 3.0 + h2 * (1.0 / 45.0 + h2 * 2.0 / 945.0));
  }
  const double s = std::sin(h), c = std::cos(h);
  *derivative = 0.5 * (c / s - h / (s * s));
  return h * c / s;
}

void CoordinateForce(const SpringCurve *spring, double damping, const CoordinateForceStep &step, CoordinateForceValues *out)
{
  *out            = CoordinateForceValues{};
  const double q1 = step.start + step.increment;
  if (!step.midpoint) {
    double spring_force = 0.0, spring_slope = 0.0;
    if (spring) spring_force = SpringForce(*spring, q1, &spring_slope);
    const double damper_force = damping * step.rate;
    out->residual             = spring_force + damper_force - step.actuator;
    out->tangent              = spring_slope + damping * step.rate_coefficient;
    out->spring_force         = -spring_force;
    out->damper_force         = -damper_force;
    out->actuator_force       = step.actuator;
    out->dissipation          = damper_force * step.increment;
    out->actuator_work        = step.actuator * step.increment;
    return;
  }
  double spring_force = 0.0, spring_derivative = 0.0;
  if (spring) spring_force = SpringMeanForce(*spring, step.start, q1, &spring_derivative);
  const double damper_force = damping * step.increment / step.dt;
  double       rho = 1.0, rho_derivative = 0.0;
  if (step.angle) rho = AngleTestRatio(step.increment, &rho_derivative);
  const double force  = spring_force + damper_force - step.actuator;
  out->residual       = force * rho;
  out->tangent        = (spring_derivative + damping / step.dt) * rho + force * rho_derivative;
  out->spring_force   = -spring_force;
  out->damper_force   = -damper_force;
  out->actuator_force = step.actuator;
  out->dissipation    = damper_force * step.increment;
  out->actuator_work  = step.actuator * step.increment;
}

namespace {

// The tangent of a pair residual (-f at a, f at b) with f a function of d = x_b - x_a only: with
// block = df/dd, the 12 x 12 tangent (a's and b's positions at rows and columns 0 and 6, the
// rotations untouched) is [block, -block; -block, block].
void SetPairTangent(const Mat3 &block, Mat12 *tangent)
{
  tangent->setZero();
  tangent->block<3, 3>(0, 0) = block;
  tangent->block<3, 3>(0, 6) = -block;
  tangent->block<3, 3>(6, 0) = -block;
  tangent->block<3, 3>(6, 6) = block;
}

} // namespace

bool AxialSpringDamperEndPoint(const SpringCurve &spring, double damping, const Vec3 &x_a, const Vec3 &x_b, const Vec3 &v_a, const Vec3 &v_b,
                               double velocity_coefficient, AxialSpringValues *out, Mat12 *tangent)
{
  const Vec3   d = x_b - x_a;
  const double l = d.norm();
  if (!(l > 0.0)) return false;
  const Vec3   e = d / l, dv = v_b - v_a;
  double       k;
  const double spring_tension = SpringForce(spring, l, &k);
  const double rate           = e.dot(dv);
  out->length                 = l;
  out->damper_tension         = damping * rate;
  out->tension                = spring_tension + out->damper_tension;
  out->residual.setZero();
  out->residual.segment<3>(0) = -out->tension * e;
  out->residual.segment<3>(6) = out->tension * e;
  if (!tangent) return true;
  // dT/dx_b = k e + c [(I - e e^T) dv / l + c_v e];  d(T e)/dx_b = e dT^T + T (I - e e^T) / l.
  const Mat3 P     = Mat3::Identity() - e * e.transpose();
  const Vec3 dT    = k * e + damping * (P * dv / l + velocity_coefficient * e);
  const Mat3 block = e * dT.transpose() + out->tension * P / l;
  SetPairTangent(block, tangent);
  return true;
}

bool AxialSpringDamperMidpoint(const SpringCurve &spring, double damping, const Vec3 &x_a_start, const Vec3 &x_b_start, const Vec3 &x_a, const Vec3 &x_b,
                               double dt, AxialSpringValues *out, Mat12 *tangent)
{
  const Vec3   d0 = x_b_start - x_a_start, d1 = x_b - x_a;
  const double l0 = d0.norm(), l1 = d1.norm();
  if (!(l0 > 0.0) || !(l1 > 0.0)) return false;
  const double sum   = l0 + l1;
  const Vec3   e_bar = (d0 + d1) / sum, e1 = d1 / l1;
  double       mean_derivative;
  const double mean   = SpringMeanForce(spring, l0, l1, &mean_derivative);
  out->length         = l1;
  out->damper_tension = damping * (l1 - l0) / dt;
  out->tension        = mean + out->damper_tension;
  out->residual.setZero();
  out->residual.segment<3>(0) = -out->tension * e_bar;
  out->residual.segment<3>(6) = out->tension * e_bar;
  if (!tangent) return true;
  // dT/dd_1 = (f_mean' + c/dt) e_1;  d e_bar / d d_1 = I/(l0 + l1) - (d0 + d1) e_1^T / (l0 + l1)^2.
  const Vec3 dT    = (mean_derivative + damping / dt) * e1;
  const Mat3 de    = Mat3::Identity() / sum - (d0 + d1) * e1.transpose() / (sum * sum);
  const Mat3 block = e_bar * dT.transpose() + out->tension * de;
  SetPairTangent(block, tangent);
  return true;
}

Mat3 CayleyTangentOperator(const Vec3 &a) { return Mat3::Identity() - 0.5 * Skew(a) + 0.25 * a * a.transpose(); }

namespace {

// eta = 2 tan(theta/2) n of a rotation R: from R = cay(eta), (R - R^T)/2 = 4 hat(eta)/(4 + |eta|^2)
// and 1 + tr R = 16/(4 + |eta|^2), so eta = 4 unskew((R - R^T)/2) / (1 + tr R).
bool TangentScaledOfRotation(const Mat3 &R, Vec3 *eta)
{
  const double denominator = 1.0 + R.trace();
  if (!(denominator > 1e-12)) return false;
  *eta = 4.0 * Unskew(R) / denominator;
  return eta->allFinite();
}

} // namespace

bool BushingDeflection(const Mat3 &axes, const Vec3 &reference_offset, const Vec3 &x_a, const Mat3 &rotation_a, const Vec3 &x_b, const Mat3 &rotation_b,
                       Vec6 *deflection)
{
  const Mat3 S = rotation_a * axes;
  Vec3       eta;
  if (!TangentScaledOfRotation(S.transpose() * rotation_b * axes, &eta)) return false;
  deflection->head<3>() = S.transpose() * (x_b - x_a) - reference_offset;
  deflection->tail<3>() = eta;
  return true;
}

namespace {

using Mat6x12 = Eigen::Matrix<double, 6, 12, Eigen::RowMajor>;

// The strain operator B of the bushing: delta e = B (delta x_a, delta theta_a, delta x_b, delta theta_b).
Mat6x12 BushingOperator(const Mat3 &S, const Mat3 &S_eta, const Vec3 &dx)
{
  Mat6x12    B        = Mat6x12::Zero();
  const Mat3 ST       = S.transpose();
  const Mat3 SES      = S_eta * ST;
  B.block<3, 3>(0, 0) = -ST;
  B.block<3, 3>(0, 3) = ST * Skew(dx);
  B.block<3, 3>(0, 6) = ST;
  B.block<3, 3>(3, 3) = -SES;
  B.block<3, 3>(3, 9) = SES;
  return B;
}

// d(S(eta) u)/d eta and d(S(eta)^T f)/d eta.
Mat3 CayleyOperatorApplyJacobian(const Vec3 &eta, const Vec3 &u) { return 0.5 * Skew(u) + 0.25 * (eta * u.transpose() + eta.dot(u) * Mat3::Identity()); }
Mat3 CayleyOperatorTransposeApplyJacobian(const Vec3 &eta, const Vec3 &f)
{
  return -0.5 * Skew(f) + 0.25 * (eta * f.transpose() + eta.dot(f) * Mat3::Identity());
}

} // namespace

bool BushingEndPoint(const Mat6 &stiffness, const Mat6 &damping, const Mat3 &axes, const Vec3 &reference_offset, const BushingNode &a, const BushingNode &b,
                     BushingValues *out, Mat12 *tangent)
{
  Vec6 e;
  if (!BushingDeflection(axes, reference_offset, a.position, a.rotation, b.position, b.rotation, &e)) return false;
  const Mat3                   S     = a.rotation * axes;
  const Vec3                   dx    = b.position - a.position;
  const Vec3                   eta   = e.tail<3>();
  const Mat3                   S_eta = CayleyTangentOperator(eta);
  const Mat6x12                B     = BushingOperator(S, S_eta, dx);
  Eigen::Matrix<double, 12, 1> V;
  V << a.velocity, a.angular, b.velocity, b.angular;
  const Vec6 edot   = B * V;
  out->deflection   = e;
  out->damper_force = damping * edot;
  out->force        = stiffness * e + out->damper_force;
  out->residual     = B.transpose() * out->force;
  if (!tangent) return true;
  const Vec3 f_d = out->force.head<3>(), f_eta = out->force.tail<3>();
  const Vec3 F = S * f_d, m = S * S_eta.transpose() * f_eta;
  const Mat3 SES = S_eta * S.transpose();
  // The velocities' dependence on the configuration (scheme) and the operator's at fixed velocities.
  Mat12 Vq             = Mat12::Zero();
  Vq.block<3, 3>(0, 0) = a.velocity_coefficient * Mat3::Identity();
  Vq.block<3, 3>(3, 3) = a.angular_jacobian;
  Vq.block<3, 3>(6, 6) = b.velocity_coefficient * Mat3::Identity();
  Vq.block<3, 3>(9, 9) = b.angular_jacobian;
  const Vec3 y = b.velocity - a.velocity + dx.cross(a.angular), z = b.angular - a.angular;
  const Mat3 Ju          = CayleyOperatorApplyJacobian(eta, S.transpose() * z);
  Mat6x12    Bdot        = Mat6x12::Zero();
  Bdot.block<3, 3>(0, 0) = S.transpose() * Skew(a.angular);
  Bdot.block<3, 3>(0, 3) = S.transpose() * Skew(y);
  Bdot.block<3, 3>(0, 6) = -S.transpose() * Skew(a.angular);
  Bdot.block<3, 3>(3, 3) = -Ju * SES + SES * Skew(z);
  Bdot.block<3, 3>(3, 9) = Ju * SES;
  // Geometric part: d(B^T f)/d(configuration) at fixed f.
  const Mat3 SJ = S * CayleyOperatorTransposeApplyJacobian(eta, f_eta) * SES;
  const Mat3 hF = Skew(F), hm = Skew(m);
  Mat12      G        = Mat12::Zero();
  G.block<3, 3>(0, 3) = hF;
  G.block<3, 3>(3, 0) = -hF;
  G.block<3, 3>(3, 6) = hF;
  G.block<3, 3>(3, 3) = Skew(dx) * hF + hm + SJ;
  G.block<3, 3>(3, 9) = -SJ;
  G.block<3, 3>(6, 3) = -hF;
  G.block<3, 3>(9, 3) = -hm - SJ;
  G.block<3, 3>(9, 9) = SJ;
  *tangent            = G + B.transpose() * (stiffness * B + damping * (B * Vq + Bdot));
  return true;
}

bool BushingMidpoint(const Mat6 &stiffness, const Mat6 &damping, const Mat3 &axes, const Vec3 &reference_offset, const BushingNode &a_start,
                     const BushingNode &b_start, const BushingNode &a, const BushingNode &b, const Vec3 &alpha_a, const Vec3 &alpha_b, double dt,
                     BushingValues *out, Mat12 *tangent)
{
  Vec6 e0, e1;
  if (!BushingDeflection(axes, reference_offset, a_start.position, a_start.rotation, b_start.position, b_start.rotation, &e0)) return false;
  if (!BushingDeflection(axes, reference_offset, a.position, a.rotation, b.position, b.rotation, &e1)) return false;
  const Mat3 S0 = a_start.rotation * axes, S1 = a.rotation * axes, Sm = 0.5 * (S0 + S1);
  const Vec3 dx0 = b_start.position - a_start.position, dx1 = b.position - a.position, dxm = 0.5 * (dx0 + dx1);
  out->deflection   = e1;
  out->damper_force = damping * (e1 - e0) / dt;
  out->force        = stiffness * (0.5 * (e0 + e1)) + out->damper_force;
  const Vec3 f_d = out->force.head<3>(), f_eta = out->force.tail<3>();
  // Translation: F = S_m f_d on b.
  const Vec3 F = Sm * f_d;
  // Rotation: the relative Cayley increment g and the exact map of eta's increment.
  const Vec3   eta0   = e0.tail<3>();
  const Mat3   S_eta0 = CayleyTangentOperator(eta0);
  const double D      = 1.0 + 0.25 * alpha_a.dot(alpha_b);
  const Vec3   z      = alpha_b - alpha_a;
  const Mat3   Q      = Mat3::Identity() - 0.5 * Skew(alpha_a);
  const Vec3   c      = Q * z / D;
  const Vec3   g      = S0.transpose() * c;
  const double E      = 1.0 - 0.25 * g.dot(eta0);
  if (!(std::abs(D) > 1e-12) || !(std::abs(E) > 1e-12)) return false;
  const Vec3 SEf              = S_eta0.transpose() * f_eta;
  const Vec3 y                = SEf / E;
  const Mat3 P                = (Mat3::Identity() + 0.5 * Skew(alpha_a)) * S0;
  const Vec3 M                = P * y / D;
  out->residual.segment<3>(0) = -F;
  out->residual.segment<3>(3) = -dxm.cross(F) - M;
  out->residual.segment<3>(6) = F;
  out->residual.segment<3>(9) = M;
  if (!tangent) return true;
  // delta f = (K/2 + C/dt) B_{n+1} delta q.
  const Mat3                         S_eta1 = CayleyTangentOperator(e1.tail<3>());
  const Mat6x12                      B1     = BushingOperator(S1, S_eta1, dx1);
  const Mat6x12                      df     = (0.5 * stiffness + damping / dt) * B1;
  const Eigen::Matrix<double, 3, 12> df_d = df.topRows<3>(), df_eta = df.bottomRows<3>();
  // F: delta F = -hat(S_1 f_d) delta theta_a / 2 + S_m delta f_d.
  Eigen::Matrix<double, 3, 12> dF = Sm * df_d;
  dF.block<3, 3>(0, 3) += -0.5 * Skew(S1 * f_d);
  // M in terms of delta alpha_a, delta alpha_b and delta f_eta.
  const Eigen::RowVector3d     dD_da = 0.25 * alpha_b.transpose(), dD_db = 0.25 * alpha_a.transpose();
  const Mat3                   dc_da = (0.5 * Skew(z) - Q) / D - c * dD_da / D;
  const Mat3                   dc_db = Q / D - c * dD_db / D;
  const Mat3                   dg_da = S0.transpose() * dc_da, dg_db = S0.transpose() * dc_db;
  const double                 E2    = 4.0 * E * E;
  const Mat3                   dy_da = SEf * (eta0.transpose() * dg_da) / E2, dy_db = SEf * (eta0.transpose() * dg_db) / E2;
  const Mat3                   dM_da = -0.5 * Skew(S0 * y) / D + P * dy_da / D - M * dD_da / D;
  const Mat3                   dM_db = P * dy_db / D - M * dD_db / D;
  Eigen::Matrix<double, 3, 12> dM    = P * S_eta0.transpose() * df_eta / (E * D);
  dM.block<3, 3>(0, 3) += dM_da * CayleyTangentOperator(alpha_a);
  dM.block<3, 3>(0, 9) += dM_db * CayleyTangentOperator(alpha_b);
  // delta(dx_m x F) = -hat(F) (delta x_b - delta x_a)/2 + hat(dx_m) delta F.
  Eigen::Matrix<double, 3, 12> dMoment = Skew(dxm) * dF;
  dMoment.block<3, 3>(0, 0) += 0.5 * Skew(F);
  dMoment.block<3, 3>(0, 6) -= 0.5 * Skew(F);
  tangent->setZero();
  tangent->block<3, 12>(0, 0) = -dF;
  tangent->block<3, 12>(3, 0) = -dMoment - dM;
  tangent->block<3, 12>(6, 0) = dF;
  tangent->block<3, 12>(9, 0) = dM;
  return true;
}

} // namespace msflex
