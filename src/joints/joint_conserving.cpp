// The conserving joint map of the mid-point schemes (Muñoz, Jelenić & Crisfield 2003, eq. 21–22)
// and its derivatives. Pure functions: no PETSc, no MPI, no allocation.
//
// With tangent-scaled increments (Lambda_{n+1} = cay(alpha) Lambda_n) the slave's step test
// vector is, exactly,
//   u_s     = u_m + C_t (b_{n+1} - b_n) - (hat(r_n) + hat(r_{n+1}))/2 alpha_m,   C_t = (I + hat(alpha_m)/2) Lambda_{m,n}
//   alpha_s = alpha_m + A Lambda_{m,n} alpha_R,   A = S(alpha_m)^T / (1 - alpha_m . Lambda_{m,n} alpha_R / 4)
// with S(a) = I - hat(a)/2 + a a^T/4 (so that S^T = I + hat(a)/2 + a a^T/4), b_{n+1} - b_n and
// the released tangent-scaled rotation alpha_R = W p linear in the released test quantities p.
// The geometric term of the condensed tangent differentiates Ntilde^T g at fixed g through
// alpha_m (d alpha_m = S(alpha_m) delta theta_m), r_{n+1} (the joint kinematics at the end of the
// step), p, W and the dependent secant G; the formulas are in joint_kinematics.hpp.
#include "joints/joint_kinematics.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// S(a) = I - hat(a)/2 + a a^T/4 = (S(a)^{-1})^{-1} of eq. (17): d a = S(a) delta theta for
// cay(a) varied by the spin delta theta.
Mat3 TangentScaledSpinJacobian(const Vec3 &a) { return Mat3::Identity() - 0.5 * Skew(a) + 0.25 * a * a.transpose(); }

// kappa(dphi) = dphi / tau = (dphi/2) cot(dphi/2) and its derivative; a series below |dphi/2| = 1e-2,
// where cot x - x/sin^2 x would cancel.
void SecantScale(double dphi, double *kappa, double *dkappa)
{
  const double x = 0.5 * dphi;
  if (std::abs(x) < 1e-2) {
    const double x2 = x * x;
    *kappa          = 1.0 - x2 / 3.0 - x2 * x2 / 45.0 - 2.0 * x2 * x2 * x2 / 945.0;
    *dkappa         = 0.5 * x * (-2.0 / 3.0 - 4.0 * x2 / 45.0 - 12.0 * x2 * x2 / 945.0);
    return;
  }
  const double s = std::sin(x), c = std::cos(x);
  *kappa  = x * c / s;
  *dkappa = 0.5 * (c / s - x / (s * s));
}

// sigma = int_0^1 f'(phi + s d) ds and dsigma/dd = int_0^1 s f''(phi + s d) ds of a periodic cubic
// spline: f' is quadratic and s f'' quadratic between knots, so two-point Gauss per piece is exact.
void SplineMeanSlope(const PeriodicSpline &spline, double phi, double d, double *sigma, double *dsigma)
{
  *sigma = *dsigma   = 0.0;
  const double gauss = 1.0 / std::sqrt(3.0);
  auto         piece = [&](double s0, double s1) {
    const double mid = 0.5 * (s0 + s1), half = 0.5 * (s1 - s0);
    for (double sign : {-1.0, 1.0}) {
      const double s = mid + sign * gauss * half;
      double       f, df, ddf;
      PeriodicSplineEvaluate(spline, phi + s * d, &f, &df, &ddf);
      *sigma += std::abs(half) * df;
      *dsigma += std::abs(half) * s * ddf;
    }
  };
  // Pieces between the knots strictly inside (lo, hi), taken in increasing angle: s runs from 0
  // up to 1 for d > 0 and from 1 down to 0 for d < 0.
  double s_previous = d >= 0.0 ? 0.0 : 1.0;
  if (d != 0.0) {
    const double lo = std::min(phi, phi + d), hi = std::max(phi, phi + d), first = spline.knots[0];
    for (double shift = std::floor((lo - first) / spline.period) * spline.period; first + shift < hi; shift += spline.period)
      for (int i = 0; i < spline.count; ++i) {
        const double knot = spline.knots[i] + shift;
        if (knot <= lo || knot >= hi) continue;
        const double s = (knot - phi) / d;
        piece(s_previous, s);
        s_previous = s;
      }
  }
  piece(s_previous, d >= 0.0 ? 1.0 : 0.0);
}

// The released rotation over a step: test quantities p (tau per angle, alpha_R for a free
// rotation), alpha_R = sum_c W_c p_c, and the derivatives with respect to the increments dq_d:
// dp_c/dq_d, dW_c/dq_d and d alpha_R/dq_d = sum_c (dW_c/dq_d p_c + W_c dp_c/dq_d).
struct ReleasedRotationStep {
  int    count = 0;
  double p[3]  = {0, 0, 0};
  double dp[3][3]{};
  Vec3   W[3]        = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec3   dW[3][3]    = {{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}, {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}};
  Vec3   dalpha_R[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec3   alpha_R     = Vec3::Zero();
};

ReleasedRotationStep ReleasedRotation(const JointGeometry &joint, const JointCoordinates &start, const double *increment)
{
  const int            nt = joint.num_translations;
  ReleasedRotationStep r;
  switch (joint.rotation) {
  case JointRotation::None:
    return r;
  case JointRotation::OneAxis: {
    r.count    = 1;
    r.p[0]     = 2.0 * std::tan(0.5 * increment[nt]);
    r.dp[0][0] = 1.0 + 0.25 * r.p[0] * r.p[0];
    r.W[0]     = joint.axes.col(joint.rotation_axis[0]);
    break;
  }
  case JointRotation::TwoAxes: {
    // C_{n+1} C_n^T = cay(tau2 b_{n+1}) cay(tau1 a_i), b_t = exp(phi1_t hat(a_i)) a_j (b . a_i = 0),
    // whose tangent-scaled vector is, exactly,
    //   alpha_R = tau1 a_i + tau2 b_m / cos(dphi1/2),   b_m = exp(phi1_m hat(a_i)) a_j,
    // phi1_m = phi1_n + dphi1/2 the step's mid-angle (b_{n+1} = cos h b_m + sin h a_i x b_m with
    // h = dphi1/2, and the component along a_i x b_m, tau2 (sin h - tan h cos h), vanishes). Its
    // columns W = [a_i, b_m / cos h] are the mid-point map's N = [a_i, b] to O(dt^2), so the
    // scheme stays second order; the columns taken at the end of the step (a_i + tau2 b_{n+1} x
    // a_i / 2, b_{n+1}), which give the same alpha_R, tilt the equations by O(dt) along the
    // reaction a_i x b and made the motion first order. dW_2/dphi1 = (tan h b_m + a_i x b_m) / (2 cos h).
    r.count         = 2;
    const Vec3   ai = joint.axes.col(joint.rotation_axis[0]), aj = joint.axes.col(joint.rotation_axis[1]);
    const double h = 0.5 * increment[nt], secant = 1.0 / std::cos(h);
    const Vec3   b = ExpSO3((start.q[nt] + h) * ai) * aj;
    for (int c = 0; c < 2; ++c) r.p[c] = 2.0 * std::tan(0.5 * increment[nt + c]), r.dp[c][c] = 1.0 + 0.25 * r.p[c] * r.p[c];
    r.W[0]     = ai;
    r.W[1]     = secant * b;
    r.dW[1][0] = 0.5 * secant * (std::tan(h) * b + ai.cross(b));
    break;
  }
  case JointRotation::Free: {
    // p = alpha_R = 2 tan(|omega_R|/2) omega_R/|omega_R|: d alpha_R = S(alpha_R) H(omega_R) d omega_R.
    r.count        = 3;
    const Vec3 w   = Vec3(increment[nt], increment[nt + 1], increment[nt + 2]);
    const Vec3 a   = TangentScaledFromRotationVector(w);
    const Mat3 dpw = TangentScaledSpinJacobian(a) * TangentH(w);
    for (int c = 0; c < 3; ++c) {
      r.p[c] = a(c);
      r.W[c] = Vec3::Unit(c);
      for (int d = 0; d < 3; ++d) r.dp[c][d] = dpw(c, d);
    }
    break;
  }
  }
  for (int c = 0; c < r.count; ++c) r.alpha_R += r.W[c] * r.p[c];
  for (int d = 0; d < r.count; ++d)
    for (int c = 0; c < r.count; ++c) r.dalpha_R[d] += r.dW[c][d] * r.p[c] + r.W[c] * r.dp[c][d];
  return r;
}

} // namespace

void JointDependentSecant(const JointGeometry &joint, double phi, double dphi, double *G, double *dG)
{
  double kappa, dkappa;
  SecantScale(dphi, &kappa, &dkappa);
  switch (joint.dependence) {
  case JointDependence::None:
    *G = *dG = 0.0;
    return;
  case JointDependence::Linear:
    *G  = joint.coefficient * kappa;
    *dG = joint.coefficient * dkappa;
    return;
  case JointDependence::EccentricCam: {
    // R (cos phi_{n+1} - cos phi_n) / (2 tan(dphi/2)) = -R sin(phi_n + dphi/2) cos(dphi/2)
    // = (f'(phi_n) + f'(phi_{n+1}))/2: the trapezoidal rule is exact here.
    double f0, df0, ddf0, f1, df1, ddf1;
    JointDependentTranslation(joint, phi, &f0, &df0, &ddf0);
    JointDependentTranslation(joint, phi + dphi, &f1, &df1, &ddf1);
    *G  = 0.5 * (df0 + df1);
    *dG = 0.5 * ddf1;
    return;
  }
  case JointDependence::Table: {
    double sigma, dsigma;
    SplineMeanSlope(joint.profile, phi, dphi, &sigma, &dsigma);
    *G  = sigma * kappa;
    *dG = dsigma * kappa + sigma * dkappa;
    return;
  }
  }
}

void JointConservingMap(const JointGeometry &joint, const JointCoordinates &start, const double *increment, const Mat3 &R_n, const Vec3 &alpha_m,
                        const Vec3 &r_n, const Vec3 &r_1, JointMatrix *Nt, double *p)
{
  const int nt = joint.num_translations;
  const int k  = JointNumCoordinates(joint);
  Nt->setZero();
  for (int c = 0; c < k; ++c) p[c] = 0.0;
  const Mat3 Ct         = (Mat3::Identity() + 0.5 * Skew(alpha_m)) * R_n;
  Nt->block<3, 3>(0, 0) = Mat3::Identity();
  Nt->block<3, 3>(0, 3) = -0.5 * (Skew(r_n) + Skew(r_1));
  Nt->block<3, 3>(3, 3) = Mat3::Identity();
  // Translations: b_{n+1} - b_n = A e_axis dq.
  for (int c = 0; c < nt; ++c) {
    p[c]                      = increment[c];
    Nt->block<3, 1>(0, 6 + c) = Ct * joint.axes.col(joint.translation_axis[c]);
  }
  // Released rotation: alpha_s = alpha_m + A Lambda_{m,n} W p.
  const ReleasedRotationStep rotation = ReleasedRotation(joint, start, increment);
  if (rotation.count == 0) return;
  const Vec3 beta = R_n * rotation.alpha_R;
  const Mat3 A    = (Mat3::Identity() + 0.5 * Skew(alpha_m) + 0.25 * alpha_m * alpha_m.transpose()) / (1.0 - 0.25 * alpha_m.dot(beta));
  for (int c = 0; c < rotation.count; ++c) {
    p[nt + c]                      = rotation.p[c];
    Nt->block<3, 1>(3, 6 + nt + c) = A * (R_n * rotation.W[c]);
  }
  if (joint.dependence != JointDependence::None) {
    // u_R = G tau along a_dependent, G the secant of f over the step.
    double G, dG;
    JointDependentSecant(joint, start.q[nt], increment[nt], &G, &dG);
    Nt->block<3, 1>(0, 6 + nt) += Ct * (G * joint.axes.col(joint.dependent_axis));
  }
}

void JointReleasedTestDerivative(const JointGeometry &joint, const double *increment, JointReleasedMatrix *dp_dq)
{
  const int nt = joint.num_translations;
  dp_dq->setZero();
  for (int c = 0; c < nt; ++c) (*dp_dq)(c, c) = 1.0;
  // p does not depend on the start of the step (only W does, for two axes).
  const ReleasedRotationStep rotation = ReleasedRotation(joint, JointCoordinates(), increment);
  for (int c = 0; c < rotation.count; ++c)
    for (int d = 0; d < rotation.count; ++d) (*dp_dq)(nt + c, nt + d) = rotation.dp[c][d];
}

void JointConservingGeometricStiffness(const JointGeometry &joint, const JointCoordinates &start, const double *increment, const Mat3 &R_n, const Vec3 &alpha_m,
                                       const Eigen::Matrix<double, 6, 1> &g, JointSquare *Gt)
{
  const int nt = joint.num_translations;
  const int k  = JointNumCoordinates(joint);
  Gt->setZero();
  const Mat3 S   = TangentScaledSpinJacobian(alpha_m); // d alpha_m / d theta_m
  const Mat3 R_1 = CayleySO3(alpha_m) * R_n;
  // The end offset r_{n+1} = Lambda_{m,n+1} b(q_{n+1}) and its q-derivative Lambda_{m,n+1} B (N's columns).
  JointCoordinates end = start;
  for (int c = 0; c < k; ++c) end.q[c] += increment[c];
  Vec3 r_1;
  Mat3 R_s;
  JointSlaveConfiguration(joint, end, Vec3::Zero(), R_1, &r_1, &R_s);
  JointMatrix N_end;
  JointMap(joint, end, R_1, &N_end);
  const Vec3 gf = g.head<3>(), gm = g.tail<3>();
  const Mat3 hgf = Skew(gf);
  // Rows alpha_m: g_m + (r_n + r_{n+1}) x g_f / 2.
  Gt->block<3, 3>(3, 3) = 0.5 * hgf * Skew(r_1);
  for (int c = 0; c < k; ++c) Gt->block<3, 1>(3, 6 + c) = -0.5 * hgf * N_end.block<3, 1>(0, 6 + c);
  // Rows of translations: a_c . v, v = C_t^T g_f = Lambda_{m,n}^T (I - hat(alpha_m)/2) g_f.
  const Vec3 v         = R_n.transpose() * (gf - 0.5 * alpha_m.cross(gf));
  const Mat3 dv_dtheta = 0.5 * R_n.transpose() * hgf * S;
  for (int c = 0; c < nt; ++c) Gt->block<1, 3>(6 + c, 3) = joint.axes.col(joint.translation_axis[c]).transpose() * dv_dtheta;
  // Rows of the rotation coordinates: W_c . y / den, y = Lambda_{m,n}^T S(alpha_m) g_m, den = 1 - alpha_m . beta / 4.
  const ReleasedRotationStep rotation = ReleasedRotation(joint, start, increment);
  if (rotation.count == 0) return;
  const Vec3               beta        = R_n * rotation.alpha_R;
  const double             den         = 1.0 - 0.25 * alpha_m.dot(beta);
  const Vec3               y           = R_n.transpose() * (S * gm);
  const Mat3               dy_dtheta   = R_n.transpose() * (0.5 * Skew(gm) + 0.25 * (alpha_m * gm.transpose() + alpha_m.dot(gm) * Mat3::Identity())) * S;
  const Eigen::RowVector3d dden_dtheta = -0.25 * beta.transpose() * S;
  const Vec3               alpha_body  = R_n.transpose() * alpha_m; // d den / d alpha_R = -alpha_body^T / 4
  for (int c = 0; c < rotation.count; ++c) {
    const double wy                = rotation.W[c].dot(y);
    Gt->block<1, 3>(6 + nt + c, 3) = rotation.W[c].transpose() * dy_dtheta / den - wy / (den * den) * dden_dtheta;
    for (int d = 0; d < rotation.count; ++d) {
      const double dden_dq          = -0.25 * alpha_body.dot(rotation.dalpha_R[d]);
      (*Gt)(6 + nt + c, 6 + nt + d) = rotation.dW[c][d].dot(y) / den - wy / (den * den) * dden_dq;
    }
  }
  if (joint.dependence != JointDependence::None) {
    // The angle's row also carries G a_dep . v.
    double     G, dG;
    const Vec3 a_dep = joint.axes.col(joint.dependent_axis);
    JointDependentSecant(joint, start.q[nt], increment[nt], &G, &dG);
    Gt->block<1, 3>(6 + nt, 3) += G * a_dep.transpose() * dv_dtheta;
    (*Gt)(6 + nt, 6 + nt) += dG * a_dep.dot(v);
  }
}

} // namespace msflex
