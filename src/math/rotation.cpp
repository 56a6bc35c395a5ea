#include "math/rotation.hpp"

#include <algorithm>

namespace msflex {

namespace {
// Below this x = theta^2 the power series is summed; above it the closed forms are used
// (at x = 4 the closed forms lose at most a digit to cancellation).
constexpr double kSeriesLimit    = 4.0;
constexpr int    kMaxSeriesTerms = 24;
constexpr int    kNumFunctions   = sizeof(RotationSeries::c) / sizeof(double);

struct InverseFactorials {
  double value[2 * kMaxSeriesTerms + kNumFunctions + 2];
  InverseFactorials()
  {
    value[0] = 1.0;
    for (int m = 1; m < (int)(sizeof(value) / sizeof(double)); ++m) value[m] = value[m - 1] / m;
  }
};
const InverseFactorials kInverseFactorial;
} // namespace

namespace {
// The series and closed forms of EvaluateRotationSeries; without kDerivatives only the values c_n
// (H and H^{-1} as matrices, per node and Newton iterate), summed alike, so bit for bit the same.
template <bool kDerivatives> RotationSeries SumRotationSeries(double x)
{
  RotationSeries s{};
  const double  *inv_fact = kInverseFactorial.value;
  if (x < kSeriesLimit) {
    // c_n = sum_k (-x)^k/(2k+n)!, c_n' = sum_k k (-x)^(k-1) (-1)/(2k+n)!, c_n'' likewise. Terms
    // shrink at least like x^k/(2k)!; stop once that bound is below 1e-20 (all c_n, n <= 4, are
    // at least 1/24 there, their derivatives at least 1/4000).
    double power           = 1.0;                        // (-x)^k
    double power_minus_one = 0.0, power_minus_two = 0.0; // (-x)^(k-1), (-x)^(k-2)
    for (int k = 0; k < kMaxSeriesTerms; ++k) {
      for (int n = 0; n < kNumFunctions; ++n) {
        const double f = inv_fact[2 * k + n];
        s.c[n] += power * f;
        if constexpr (kDerivatives) {
          s.dc[n] -= k * power_minus_one * f;
          s.ddc[n] += k * (k - 1) * power_minus_two * f;
        }
      }
      if (std::abs(power) * inv_fact[2 * k] < 1e-20 && k >= 2) break;
      power_minus_two = power_minus_one;
      power_minus_one = power;
      power *= -x;
    }
    return s;
  }
  const double theta = std::sqrt(x);
  s.c[0]             = std::cos(theta);
  s.c[1]             = std::sin(theta) / theta;
  // c_{n+2} = (1/n! - c_n)/x
  for (int n = 0; n + 2 < kNumFunctions; ++n) s.c[n + 2] = (inv_fact[n] - s.c[n]) / x;
  if constexpr (kDerivatives) {
    // d c_0/dx = -sin(theta)/(2 theta) = -c1/2;  2 x c_n' = c_{n-1} - n c_n for n >= 1.
    s.dc[0] = -0.5 * s.c[1];
    for (int n = 1; n < kNumFunctions; ++n) s.dc[n] = (s.c[n - 1] - n * s.c[n]) / (2.0 * x);
    // Differentiate 2 x c_n' = c_{n-1} - n c_n:  2 c_n' + 2 x c_n'' = c_{n-1}' - n c_n'.
    s.ddc[0] = -0.5 * s.dc[1];
    for (int n = 1; n < kNumFunctions; ++n) s.ddc[n] = (s.dc[n - 1] - (n + 2) * s.dc[n]) / (2.0 * x);
  }
  return s;
}
} // namespace

RotationSeries EvaluateRotationSeries(double x) { return SumRotationSeries<true>(x); }

RotationSeries RotationSeriesValues(double x) { return SumRotationSeries<false>(x); }

// F^T a = a - alpha psi x a + beta psi x (psi x a), and psi x (psi x a) = psi (psi.a) - a x.
// d/dpsi = alpha hat(a) - 2 alpha_x (psi x a) psi^T + beta [(psi.a) I + psi a^T - 2 a psi^T]
//          + 2 beta_x (psi x (psi x a)) psi^T
Mat3 RodriguesTransposeApplyJacobian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a)
{
  const Vec3   pxa  = psi.cross(a);
  const Vec3   pxpa = psi.cross(pxa);
  const double pa   = psi.dot(a);
  Mat3         J    = f.alpha * Skew(a) - 2.0 * f.alpha_x * pxa * psi.transpose();
  J += f.beta * (pa * Mat3::Identity() + psi * a.transpose() - 2.0 * a * psi.transpose());
  J += 2.0 * f.beta_x * pxpa * psi.transpose();
  return J;
}

// F a = a + alpha psi x a + beta psi x (psi x a) is F^T a with the sign of alpha (and alpha_x) flipped.
Mat3 RodriguesApplyJacobian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a)
{
  RodriguesForm flipped = f;
  flipped.alpha         = -f.alpha;
  flipped.alpha_x       = -f.alpha_x;
  return RodriguesTransposeApplyJacobian(flipped, psi, a);
}

// f(psi) = m.F^T a = m.a - alpha(x) psi.c + beta(x) g(psi),  c = a x m,
// g = (psi.m)(psi.a) - x (m.a),  grad g = (psi.a) m + (psi.m) a - 2 (m.a) psi.
// Hess(alpha h) = 2 alpha_x (psi c^T + c psi^T) + (2 alpha_x I + 4 alpha_xx psi psi^T) h,  h = psi.c
// Hess(beta g)  = beta Hess g + 2 beta_x (psi grad g^T + grad g psi^T) + (2 beta_x I + 4 beta_xx psi psi^T) g
Mat3 RodriguesTransposeApplyHessian(const RodriguesForm &f, const Vec3 &psi, const Vec3 &a, const Vec3 &m)
{
  const Vec3   c     = a.cross(m);
  const double h     = psi.dot(c);
  const double x     = psi.squaredNorm();
  const double ma    = m.dot(a);
  const double g     = psi.dot(m) * psi.dot(a) - x * ma;
  const Vec3   gradg = psi.dot(a) * m + psi.dot(m) * a - 2.0 * ma * psi;
  const Mat3   I     = Mat3::Identity();
  const Mat3   ppT   = psi * psi.transpose();
  Mat3         Hs    = -(2.0 * f.alpha_x * (psi * c.transpose() + c * psi.transpose()) + (2.0 * f.alpha_x * I + 4.0 * f.alpha_xx * ppT) * h);
  Hs += f.beta * (m * a.transpose() + a * m.transpose() - 2.0 * ma * I);
  Hs += 2.0 * f.beta_x * (psi * gradg.transpose() + gradg * psi.transpose());
  Hs += (2.0 * f.beta_x * I + 4.0 * f.beta_xx * ppT) * g;
  return Hs;
}

Mat3 ExpSO3(const Vec3 &psi)
{
  const double x = psi.squaredNorm();
  double       a, b;
  if (x < 1e-6) {
    a = 1.0 - x / 6.0 + x * x / 120.0;
    b = 0.5 - x / 24.0 + x * x / 720.0;
  } else {
    const double t = std::sqrt(x);
    a              = std::sin(t) / t;
    b              = (1.0 - std::cos(t)) / x;
  }
  const Mat3 S = Skew(psi);
  return Mat3::Identity() + a * S + b * S * S;
}

Vec3 LogSO3(const Mat3 &R)
{
  // Through the quaternion: robust everywhere, including theta -> 0 and theta -> pi.
  const Quaternion q = QuaternionFromMatrix(R);
  Quaternion       p = q;
  if (p.w < 0) p = {-p.w, -p.x, -p.y, -p.z};
  const Vec3   v  = p.vec();
  const double sn = v.norm();
  if (sn < 1e-8) {
    // theta = 2 asin(sn) ~ 2 sn (1 + sn^2/6): psi = v * theta/sn
    return v * (2.0 / p.w) * (1.0 - sn * sn / (3.0 * p.w * p.w)); // 2 atan(sn/w)/sn series
  }
  const double theta = 2.0 * std::atan2(sn, p.w);
  return v * (theta / sn);
}

Mat3 TangentH(const Vec3 &psi) { return RodriguesMatrix(TangentForm(RotationSeriesValues(psi.squaredNorm())), psi); }

Mat3 TangentHInverse(const Vec3 &psi) { return RodriguesMatrix(TangentInverseForm(RotationSeriesValues(psi.squaredNorm())), psi); }

Mat3 CayleySO3(const Vec3 &a)
{
  const Mat3 S = Skew(a);
  return Mat3::Identity() + (4.0 / (4.0 + a.squaredNorm())) * (S + 0.5 * S * S);
}

Vec3 TangentScaledFromRotationVector(const Vec3 &psi)
{
  const double t = psi.norm();
  if (t < 1e-8) return psi * (1.0 + t * t / 12.0);
  return psi * (2.0 * std::tan(0.5 * t) / t);
}

Vec3 RotationVectorFromTangentScaled(const Vec3 &a)
{
  const double n = a.norm();
  if (n < 1e-8) return a * (1.0 - n * n / 12.0);
  return a * (2.0 * std::atan(0.5 * n) / n);
}

Mat3 CayleyMidpointOperatorInverse(const Vec3 &a) { return (Mat3::Identity() + 0.5 * Skew(a)) / (1.0 + 0.25 * a.squaredNorm()); }

Quaternion QuaternionMultiply(const Quaternion &p, const Quaternion &q)
{
  return {p.w * q.w - p.x * q.x - p.y * q.y - p.z * q.z, p.w * q.x + p.x * q.w + p.y * q.z - p.z * q.y, p.w * q.y - p.x * q.z + p.y * q.w + p.z * q.x,
          p.w * q.z + p.x * q.y - p.y * q.x + p.z * q.w};
}

Quaternion QuaternionFromRotationVector(const Vec3 &psi)
{
  const double t = psi.norm();
  double       s; // sin(t/2)/t
  if (t < 1e-6) s = 0.5 - t * t / 48.0;
  else s = std::sin(0.5 * t) / t;
  return {std::cos(0.5 * t), s * psi(0), s * psi(1), s * psi(2)};
}

Quaternion QuaternionFromMatrix(const Mat3 &R)
{
  // Shepperd's method: pick the largest of w^2, x^2, y^2, z^2 to divide by.
  const double tr = R.trace();
  Quaternion   q;
  if (tr >= R(0, 0) && tr >= R(1, 1) && tr >= R(2, 2)) {
    const double r = std::sqrt(1.0 + tr);
    q.w            = 0.5 * r;
    q.x            = (R(2, 1) - R(1, 2)) / (2.0 * r);
    q.y            = (R(0, 2) - R(2, 0)) / (2.0 * r);
    q.z            = (R(1, 0) - R(0, 1)) / (2.0 * r);
  } else if (R(0, 0) >= R(1, 1) && R(0, 0) >= R(2, 2)) {
    const double r = std::sqrt(std::max(0.0, 1.0 + R(0, 0) - R(1, 1) - R(2, 2)));
    q.x            = 0.5 * r;
    q.w            = (R(2, 1) - R(1, 2)) / (2.0 * r);
    q.y            = (R(0, 1) + R(1, 0)) / (2.0 * r);
    q.z            = (R(0, 2) + R(2, 0)) / (2.0 * r);
  } else if (R(1, 1) >= R(2, 2)) {
    const double r = std::sqrt(std::max(0.0, 1.0 - R(0, 0) + R(1, 1) - R(2, 2)));
    q.y            = 0.5 * r;
    q.w            = (R(0, 2) - R(2, 0)) / (2.0 * r);
    q.x            = (R(0, 1) + R(1, 0)) / (2.0 * r);
    q.z            = (R(1, 2) + R(2, 1)) / (2.0 * r);
  } else {
    const double r = std::sqrt(std::max(0.0, 1.0 - R(0, 0) - R(1, 1) + R(2, 2)));
    q.z            = 0.5 * r;
    q.w            = (R(1, 0) - R(0, 1)) / (2.0 * r);
    q.x            = (R(0, 2) + R(2, 0)) / (2.0 * r);
    q.y            = (R(1, 2) + R(2, 1)) / (2.0 * r);
  }
  return QuaternionNormalize(q);
}

Mat3 QuaternionToMatrix(const Quaternion &q)
{
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  Mat3         R;
  R << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  return R;
}

Quaternion QuaternionNormalize(const Quaternion &q)
{
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w / n, q.x / n, q.y / n, q.z / n};
}

double QuaternionTrackedAngle(const Quaternion &q) { return 2.0 * std::atan2(q.vec().norm(), q.w); }

} // namespace msflex
