#include "joints/joint_kinematics.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace msflex {

void PeriodicSplineEvaluate(const PeriodicSpline &s, double phi, double *f, double *df, double *ddf)
{
  // Reduce to [knots[0], knots[0] + period) and find the interval [k_i, k_{i+1}).
  double x = std::fmod(phi - s.knots[0], s.period);
  if (x < 0) x += s.period;
  x += s.knots[0];
  const int    i    = std::max(0, (int)(std::upper_bound(s.knots, s.knots + s.count, x) - s.knots) - 1);
  const int    next = (i + 1) % s.count;
  const double left = s.knots[i], right = (next == 0) ? s.knots[0] + s.period : s.knots[next];
  const double h = right - left, t = (x - left) / h, u = 1.0 - t;
  const double Mi = s.second[i], Mj = s.second[next], fi = s.values[i], fj = s.values[next];
  // f = u f_i + t f_j + h^2/6 [(u^3 - u) M_i + (t^3 - t) M_j]
  *f   = u * fi + t * fj + h * h / 6.0 * ((u * u * u - u) * Mi + (t * t * t - t) * Mj);
  *df  = (fj - fi) / h + h / 6.0 * (-(3.0 * u * u - 1.0) * Mi + (3.0 * t * t - 1.0) * Mj);
  *ddf = u * Mi + t * Mj;
}

bool PeriodicSplineSecondDerivatives(double period, int count, const double *knots, const double *values, double *second)
{
  if (count < 3 || !(period > 0)) return false;
  for (int i = 1; i < count; ++i)
    if (!(knots[i] > knots[i - 1])) return false;
  if (!(knots[count - 1] < knots[0] + period)) return false;
  // h_{i-1}/6 M_{i-1} + (h_{i-1} + h_i)/3 M_i + h_i/6 M_{i+1} = (f_{i+1} - f_i)/h_i - (f_i - f_{i-1})/h_{i-1}, cyclic.
  auto h = [&](int i) { // length of interval i (from knot i to knot i + 1)
    const int j = (i + 1) % count;
    return (j == 0 ? knots[0] + period : knots[j]) - knots[i];
  };
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(count, count);
  Eigen::VectorXd b(count);
  for (int i = 0; i < count; ++i) {
    const int    prev = (i + count - 1) % count, next = (i + 1) % count;
    const double hp = h(prev), hi = h(i);
    A(i, prev) += hp / 6.0;
    A(i, i) += (hp + hi) / 3.0;
    A(i, next) += hi / 6.0;
    b(i) = (values[next] - values[i]) / hi - (values[i] - values[prev]) / hp;
  }
  const Eigen::VectorXd M = A.partialPivLu().solve(b);
  for (int i = 0; i < count; ++i) second[i] = M(i);
  return true;
}

int JointNumCoordinates(const JointGeometry &joint)
{
  static const int rotation_coordinates[] = {0, 1, 2, 3};
  return joint.num_translations + rotation_coordinates[(int)joint.rotation];
}

void JointDependentTranslation(const JointGeometry &joint, double phi, double *f, double *df, double *ddf)
{
  switch (joint.dependence) {
  case JointDependence::None:
    *f = *df = *ddf = 0.0;
    return;
  case JointDependence::Linear:
    *f   = joint.coefficient * phi;
    *df  = joint.coefficient;
    *ddf = 0.0;
    return;
  case JointDependence::EccentricCam:
    *f   = joint.coefficient * std::cos(phi);
    *df  = -joint.coefficient * std::sin(phi);
    *ddf = -joint.coefficient * std::cos(phi);
    return;
  case JointDependence::Table:
    PeriodicSplineEvaluate(joint.profile, phi, f, df, ddf);
    return;
  }
}

namespace {

// b(q) = d0 + A t(q) and B = db/dq (3 x k).
void Offset(const JointGeometry &joint, const JointCoordinates &q, Vec3 *b, Eigen::Matrix<double, 3, kJointMaxReleased> *B, double *ddf)
{
  const int nt = joint.num_translations;
  Vec3      t  = Vec3::Zero();
  B->setZero();
  for (int k = 0; k < nt; ++k) {
    t(joint.translation_axis[k]) += q.q[k];
    B->col(k) = joint.axes.col(joint.translation_axis[k]);
  }
  *ddf = 0.0;
  if (joint.dependence != JointDependence::None) {
    double f, df, f0, df0, ddf0;
    JointDependentTranslation(joint, q.q[nt], &f, &df, ddf);
    JointDependentTranslation(joint, 0.0, &f0, &df0, &ddf0);
    t(joint.dependent_axis) += f - f0;
    B->col(nt) += df * joint.axes.col(joint.dependent_axis);
  }
  *b = joint.offset + joint.axes * t;
}

// C(q) and Omega (3 x k, rotation columns only; translation columns zero).
void Rotation(const JointGeometry &joint, const JointCoordinates &q, Mat3 *C, Eigen::Matrix<double, 3, kJointMaxReleased> *Omega)
{
  const int nt = joint.num_translations;
  Omega->setZero();
  switch (joint.rotation) {
  case JointRotation::None:
    *C = Mat3::Identity();
    return;
  case JointRotation::OneAxis: {
    const Vec3 a   = joint.axes.col(joint.rotation_axis[0]);
    *C             = ExpSO3(q.q[nt] * a);
    Omega->col(nt) = a;
    return;
  }
  case JointRotation::TwoAxes: {
    const Vec3 ai = joint.axes.col(joint.rotation_axis[0]), aj = joint.axes.col(joint.rotation_axis[1]);
    const Mat3 Ei      = ExpSO3(q.q[nt] * ai);
    *C                 = Ei * ExpSO3(q.q[nt + 1] * aj);
    Omega->col(nt)     = ai;
    Omega->col(nt + 1) = Ei * aj;
    return;
  }
  case JointRotation::Free: {
    const Vec3 w(q.q[nt], q.q[nt + 1], q.q[nt + 2]);
    *C                        = ExpSO3(w) * q.free_rotation_start;
    Omega->block<3, 3>(0, nt) = TangentH(w);
    return;
  }
  }
}

// b, B = db/dq, d^2 f/dphi^2 of a dependent translation, C and Omega at the coordinates q.
struct JointTerms {
  Vec3                                        b;
  Mat3                                        C;
  Eigen::Matrix<double, 3, kJointMaxReleased> B, Omega;
  double                                      ddf;
};
JointTerms EvaluateTerms(const JointGeometry &joint, const JointCoordinates &q)
{
  JointTerms terms;
  Offset(joint, q, &terms.b, &terms.B, &terms.ddf);
  Rotation(joint, q, &terms.C, &terms.Omega);
  return terms;
}

} // namespace

void JointSlaveConfiguration(const JointGeometry &joint, const JointCoordinates &q, const Vec3 &master_position, const Mat3 &master_rotation,
                             Vec3 *slave_position, Mat3 *slave_rotation)
{
  const JointTerms terms = EvaluateTerms(joint, q);
  *slave_position        = master_position + master_rotation * terms.b;
  *slave_rotation        = master_rotation * terms.C;
}

Vec3 JointOffset(const JointGeometry &joint, const JointCoordinates &q)
{
  Vec3                                        b;
  Eigen::Matrix<double, 3, kJointMaxReleased> B;
  double                                      ddf;
  Offset(joint, q, &b, &B, &ddf);
  return b;
}

Vec3 JointOffsetStep(const JointGeometry &joint, const JointCoordinates &start, const double *increment)
{
  const int nt = joint.num_translations;
  Vec3      dt = Vec3::Zero();
  for (int k = 0; k < nt; ++k) dt(joint.translation_axis[k]) += increment[k];
  const double phi = start.q[nt], dphi = increment[nt];
  switch (joint.dependence) {
  case JointDependence::None:
    break;
  case JointDependence::Linear:
    dt(joint.dependent_axis) += joint.coefficient * dphi;
    break;
  case JointDependence::EccentricCam:
    dt(joint.dependent_axis) += -2.0 * joint.coefficient * std::sin(phi + 0.5 * dphi) * std::sin(0.5 * dphi);
    break;
  case JointDependence::Table: {
    // The start's angle reduced to one period exactly (fmod is exact), so that adding dphi rounds
    // to eps times the period, not eps |phi|.
    const double reduced = std::fmod(phi, joint.profile.period);
    double       f_end, f_start, df, ddf;
    PeriodicSplineEvaluate(joint.profile, reduced + dphi, &f_end, &df, &ddf);
    PeriodicSplineEvaluate(joint.profile, reduced, &f_start, &df, &ddf);
    dt(joint.dependent_axis) += f_end - f_start;
    break;
  }
  }
  return joint.axes * dt;
}

Mat3 JointReleasedRotation(const JointGeometry &joint, const JointCoordinates &q)
{
  Mat3                                        C;
  Eigen::Matrix<double, 3, kJointMaxReleased> Omega;
  Rotation(joint, q, &C, &Omega);
  return C;
}

// One axis a: exp(dq a). Two axes (C = exp(q_1 a_i) exp(q_2 a_j)):
//   C' C^T = exp(q_1' a_i) exp(dq_2 a_j) exp(-q_1' a_i) exp(dq_1 a_i) = exp(dq_2 Omega_2') exp(dq_1 a_i),
//   Omega_2' = exp(q_1' a_i) a_j = exp(dq_1 a_i) (exp(q_1 a_i) a_j).
// Free (C = exp(w) C_n, w = 0 at the start): exp(w + dw) exp(w)^T.
Mat3 JointRotationStep(const JointGeometry &joint, const JointCoordinates &start, const double *increment)
{
  const int nt = joint.num_translations;
  switch (joint.rotation) {
  case JointRotation::None:
    return Mat3::Identity();
  case JointRotation::OneAxis:
    return ExpSO3(increment[nt] * joint.axes.col(joint.rotation_axis[0]));
  case JointRotation::TwoAxes: {
    const Vec3 ai = joint.axes.col(joint.rotation_axis[0]), aj = joint.axes.col(joint.rotation_axis[1]);
    const Mat3 first_step = ExpSO3(increment[nt] * ai);
    const Vec3 Omega2     = first_step * (ExpSO3(start.q[nt] * ai) * aj);
    return ExpSO3(increment[nt + 1] * Omega2) * first_step;
  }
  case JointRotation::Free: {
    const Vec3 w(start.q[nt], start.q[nt + 1], start.q[nt + 2]), dw(increment[nt], increment[nt + 1], increment[nt + 2]);
    return w == Vec3::Zero() ? ExpSO3(dw) : Mat3(ExpSO3(w + dw) * ExpSO3(w).transpose());
  }
  }
  return Mat3::Identity();
}

void JointMap(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &R, JointMatrix *N)
{
  const int        k     = JointNumCoordinates(joint);
  const JointTerms terms = EvaluateTerms(joint, q);
  N->setZero();
  N->block<3, 3>(0, 0) = Mat3::Identity();
  N->block<3, 3>(0, 3) = -Skew(R * terms.b);
  N->block<3, 3>(3, 3) = Mat3::Identity();
  for (int c = 0; c < k; ++c) {
    N->block<3, 1>(0, 6 + c) = R * terms.B.col(c);
    N->block<3, 1>(3, 6 + c) = R * terms.Omega.col(c);
  }
}

Eigen::Matrix<double, 6, 1> JointVelocityProductAcceleration(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &R, const Vec3 &w_m,
                                                             const double *rates)
{
  const int        k = JointNumCoordinates(joint), nt = joint.num_translations;
  const JointTerms terms = EvaluateTerms(joint, q);
  Vec3             slide = Vec3::Zero(), spin = Vec3::Zero(); // R_m B qdot, R_m Omega qdot
  for (int c = 0; c < k; ++c) {
    slide += rates[c] * (R * terms.B.col(c));
    spin += rates[c] * (R * terms.Omega.col(c));
  }
  const Vec3 r           = R * terms.b;
  Vec3       translation = w_m.cross(w_m.cross(r)) + 2.0 * w_m.cross(slide), rotation = w_m.cross(spin);
  if (joint.dependence != JointDependence::None) translation += (terms.ddf * rates[nt] * rates[nt]) * (R * joint.axes.col(joint.dependent_axis));
  if (joint.rotation == JointRotation::TwoAxes)
    rotation += (rates[nt] * rates[nt + 1]) * (R * joint.axes.col(joint.rotation_axis[0]).cross(terms.Omega.col(nt + 1)));
  Eigen::Matrix<double, 6, 1> terms_out;
  terms_out << translation, rotation;
  return terms_out;
}

void JointGeometricStiffness(const JointGeometry &joint, const JointCoordinates &q, const Mat3 &R, const Eigen::Matrix<double, 6, 1> &g, JointSquare *G)
{
  const int        k     = JointNumCoordinates(joint);
  const int        nt    = joint.num_translations;
  const JointTerms terms = EvaluateTerms(joint, q);
  const Vec3      &b     = terms.b;
  const auto      &B = terms.B, &Omega = terms.Omega;
  const double     ddf = terms.ddf;
  const Vec3       gf = g.head<3>(), gm = g.tail<3>();
  const Vec3       vf = R.transpose() * gf, vm = R.transpose() * gm;
  const Mat3       hgf = Skew(gf), hgm = Skew(gm);
  G->setZero();
  // Rows theta_m: d(hat(R b) g_f) = hat(g_f) hat(R b) dtheta_m - hat(g_f) R B dq.
  G->block<3, 3>(3, 3) = hgf * Skew(R * b);
  for (int c = 0; c < k; ++c) {
    G->block<3, 1>(3, 6 + c) = -hgf * (R * B.col(c));
    // Rows q: d(B^T R^T g_f + Omega^T R^T g_m) = (B^T R^T hat(g_f) + Omega^T R^T hat(g_m)) dtheta_m + ...
    G->block<1, 3>(6 + c, 3) = B.col(c).transpose() * R.transpose() * hgf + Omega.col(c).transpose() * R.transpose() * hgm;
  }
  // Rows q, columns q: d(B^T v_f)/dq (the dependent translation) + d(Omega^T v_m)/dq.
  if (joint.dependence != JointDependence::None) (*G)(6 + nt, 6 + nt) += ddf * joint.axes.col(joint.dependent_axis).dot(vf);
  if (joint.rotation == JointRotation::TwoAxes) {
    const Vec3 ai = joint.axes.col(joint.rotation_axis[0]), Omega2 = Omega.col(nt + 1);
    // Omega_2 = exp(phi1 hat(a_i)) a_j:  d(Omega_2 . v)/dphi1 = (a_i x Omega_2) . v
    (*G)(6 + nt + 1, 6 + nt) += ai.cross(Omega2).dot(vm);
  } else if (joint.rotation == JointRotation::Free) {
    const Vec3 w(q.q[nt], q.q[nt + 1], q.q[nt + 2]);
    G->block<3, 3>(6 + nt, 6 + nt) += RodriguesTransposeApplyJacobian(TangentForm(EvaluateRotationSeries(w.squaredNorm())), w, vm);
  }
}

} // namespace msflex
