// Rotations on SO(3): skew, exp, log, the tangent operator H of Muñoz, Jelenić & Crisfield (2003)
// eq. (4) and its inverse, the Cayley map with the tangent-scaled vector used by the conserving
// schemes (eq. 17), and unit quaternions.
//
// Conventions (used everywhere in msflex):
//  - hat(v) w = v x w.
//  - Spatial ("spin") variations: delta Lambda = hat(delta_theta) Lambda.
//  - For Lambda = exp(hat(psi)) Lambda_n:  delta_theta = H(psi) delta_psi  (left tangent).
//  - exp(hat(psi))^T d exp(hat(psi)) = hat(H(psi)^T d psi)  (material form).
//  - Quaternions are (w, x, y, z) and are never sign-canonicalised, so a quaternion tracked by
//    composition q_{n+1} = q(omega) * q_n with |omega| < pi distinguishes 0 from 2 pi (q = -1).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace msflex {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

inline Mat3 Skew(const Vec3 &v)
{
  Mat3 s;
  s << 0.0, -v(2), v(1), v(2), 0.0, -v(0), -v(1), v(0), 0.0;
  return s;
}

inline Vec3 Unskew(const Mat3 &s) { return Vec3(0.5 * (s(2, 1) - s(1, 2)), 0.5 * (s(0, 2) - s(2, 0)), 0.5 * (s(1, 0) - s(0, 1))); }

// The entire functions c_n(x) = sum_k (-x)^k / (2k+n)!, x = theta^2, and their first two
// derivatives with respect to x. c0 = cos(theta), c1 = sin(theta)/theta, c2 = (1-cos)/theta^2,
// c3 = (theta - sin)/theta^3, ... Every Rodrigues-type operator below is built from them, so
// all small-angle branches live in one place.
struct RotationSeries {
  double c[5];   // c_0 .. c_4
  double dc[5];  // d c_n / dx
  double ddc[5]; // d^2 c_n / dx^2
};
RotationSeries EvaluateRotationSeries(double x);
// The values c_0 .. c_4 alone (derivatives left zero), summed as EvaluateRotationSeries sums them:
// bit for bit its values, for the matrices exp, H and H^{-1} themselves (TangentH, the node updates).
RotationSeries RotationSeriesValues(double x);

// A Rodrigues-type operator F(psi) = I + alpha(x) hat(psi) + beta(x) hat(psi)^2, x = |psi|^2,
// with the derivatives of alpha and beta with respect to x. exp, H and H^{-1} are of this form.
struct RodriguesForm {
  double alpha, alpha_x, alpha_xx;
  double beta, beta_x, beta_xx;
};
// (Inline: the beam kernels call these per Gauss point and per node.)
inline RodriguesForm ExpForm(const RotationSeries &s) { return {s.c[1], s.dc[1], s.ddc[1], s.c[2], s.dc[2], s.ddc[2]}; }     // alpha = c1, beta = c2
inline RodriguesForm TangentForm(const RotationSeries &s) { return {s.c[2], s.dc[2], s.ddc[2], s.c[3], s.dc[3], s.ddc[3]}; } // H: alpha = c2, beta = c3
// H^{-1}: alpha = -1/2, beta = (1 - (theta/2) cot(theta/2))/theta^2 = (c3 - 2 c4)/(2 c2): no cancellation at small angle.
inline RodriguesForm TangentInverseForm(const RotationSeries &s)
{
  const double num = s.c[3] - 2.0 * s.c[4], num_x = s.dc[3] - 2.0 * s.dc[4], num_xx = s.ddc[3] - 2.0 * s.ddc[4];
  const double den = 2.0 * s.c[2], den_x = 2.0 * s.dc[2], den_xx = 2.0 * s.ddc[2];
  const double beta    = num / den;
  const double beta_x  = (num_x - beta * den_x) / den;
  const double beta_xx = (num_xx - 2.0 * beta_x * den_x - beta * den_xx) / den;
  return {-0.5, 0.0, 0.0, beta, beta_x, beta_xx};
}

// F = I + alpha hat(p) + beta hat(p)^2 written out with hat(p)^2 = p p^T - x I (x = |p|^2): no 3x3
// product, for the beam kernels (per Gauss point) and the node updates (per node and iterate).
inline Mat3 RodriguesMatrix(double alpha, double beta, const Vec3 &p, double x)
{
  const double ap0 = alpha * p(0), ap1 = alpha * p(1), ap2 = alpha * p(2);
  const double b01 = beta * p(0) * p(1), b02 = beta * p(0) * p(2), b12 = beta * p(1) * p(2);
  Mat3         F;
  F << 1.0 + beta * (p(0) * p(0) - x), -ap2 + b01, ap1 + b02, ap2 + b01, 1.0 + beta * (p(1) * p(1) - x), -ap0 + b12, -ap1 + b02, ap0 + b12,
      1.0 + beta * (p(2) * p(2) - x);
  return F;
}
inline Mat3 RodriguesMatrix(const RodriguesForm &f, const Vec3 &psi) { return RodriguesMatrix(f.alpha, f.beta, psi, psi.squaredNorm()); }
// d/dpsi [F(psi)^T a]   (3x3)
Mat3 RodriguesTransposeApplyJacobian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a);
// d/dpsi [F(psi) a]     (3x3)
Mat3 RodriguesApplyJacobian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a);
// d^2/dpsi^2 [ m . F(psi)^T a ]   (3x3, symmetric)
Mat3 RodriguesTransposeApplyHessian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a, const Vec3 &m);

// exp: R^3 -> SO(3)
Mat3 ExpSO3(const Vec3 &psi);
// log: SO(3) -> R^3 with |psi| in [0, pi]; robust near 0 and near pi.
Vec3 LogSO3(const Mat3 &R);

// log(R) as LogSO3, several times cheaper for rotations by less than pi/2 (the relative rotations
// of a beam element's nodes, per element and Newton iterate). With v = vee(R - R^T)/2 = sin(theta) n,
// s = |v| and cos(theta) = (tr R - 1)/2:  psi = (theta/s) v,  theta = atan2(s, cos(theta)); for
// s^2 <= 0.01, theta/s = asin(s)/s = sum_k a_k s^(2k), a_k = (2k)!/(4^k (k!)^2 (2k+1)), by Horner's
// rule (nine terms: the k-th is below 0.01^k a_k, the rest below 1e-19). LogSO3 where
// cos(theta) <= 0. Like LogSO3 (Shepperd's method with a dominant w), it reads the rotation's
// antisymmetric part, so the rounding is alike: about eps/theta relative at small theta.
struct ArcsineOverArgumentSeries {
  static constexpr int kTerms    = 9;
  double               a[kTerms] = {};
  constexpr ArcsineOverArgumentSeries()
  {
    a[0] = 1.0; // a_k = a_{k-1} (2k-1)^2 / (2k (2k+1))
    for (int k = 1; k < kTerms; ++k) a[k] = a[k - 1] * (2.0 * k - 1.0) * (2.0 * k - 1.0) / (2.0 * k * (2.0 * k + 1.0));
  }
};
inline constexpr ArcsineOverArgumentSeries kArcsineOverArgument{};

inline Vec3 LogSO3Acute(const Mat3 &R)
{
  const Vec3   v = Unskew(R);
  const double y = v.squaredNorm(), cosine = 0.5 * (R.trace() - 1.0);
  if (!(cosine > 0.0)) return LogSO3(R);
  if (y > 0.01) {
    const double sine = std::sqrt(y);
    return (std::atan2(sine, cosine) / sine) * v;
  }
  const double *a     = kArcsineOverArgument.a;
  double        ratio = a[ArcsineOverArgumentSeries::kTerms - 1];
  for (int k = ArcsineOverArgumentSeries::kTerms - 2; k >= 0; --k) ratio = ratio * y + a[k];
  return ratio * v;
}
// H(psi) of eq. (4) and its inverse (singular at |psi| = 2 pi).
Mat3 TangentH(const Vec3 &psi);
Mat3 TangentHInverse(const Vec3 &psi);

// Cayley map cay(a) = I + 4/(4 + |a|^2) (hat(a) + hat(a)^2 / 2), equal to exp(psi) for the
// tangent-scaled vector a = tan(|psi|/2)/(|psi|/2) psi.
Mat3 CayleySO3(const Vec3 &a);
Vec3 TangentScaledFromRotationVector(const Vec3 &psi); // a = 2 tan(|psi|/2) psi/|psi|, |psi| < pi
Vec3 RotationVectorFromTangentScaled(const Vec3 &a);   // psi = 2 atan(|a|/2) a/|a|
// S(a)^{-1} = (I + hat(a)/2) / (1 + |a|^2/4) of eq. (17): the tangent operator of the Cayley map,
// d cay(a) cay(a)^T = hat(S(a)^{-1} da).
Mat3 CayleyMidpointOperatorInverse(const Vec3 &a);

// Unit quaternions (w, x, y, z).
struct Quaternion {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;
  Vec3   vec() const { return Vec3(x, y, z); }
};
Quaternion QuaternionMultiply(const Quaternion &p, const Quaternion &q);
Quaternion QuaternionFromRotationVector(const Vec3 &psi);
Quaternion QuaternionFromMatrix(const Mat3 &R);
Mat3       QuaternionToMatrix(const Quaternion &q);
Quaternion QuaternionNormalize(const Quaternion &q);
// Rotation angle in [0, 2 pi] of a tracked quaternion: 2 atan2(|v|, w). q = -1 gives 2 pi.
double QuaternionTrackedAngle(const Quaternion &q);

} // namespace msflex
