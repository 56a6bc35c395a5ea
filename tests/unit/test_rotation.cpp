// Rotation library: identities and finite-difference checks.
// Branches covered: series (|psi|^2 < 4) and closed forms (>= 4) of c_n and derivatives;
// log at 0, small angles, generic, and near pi; H and H^{-1} at small, generic and large angles;
// quaternion composition keeps track of 2 pi (q = -1).
#include "math/rotation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

using namespace msflex;

namespace {
const double kPi = 3.14159265358979323846;

Vec3 RandomVector(std::mt19937 &gen, double scale)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Vec3(u(gen), u(gen), u(gen));
}

double MaxAbs(const Mat3 &m) { return m.cwiseAbs().maxCoeff(); }

// Angles exercising every branch: tiny, series region, boundary of the series, closed forms, near pi and beyond.
const double kTestAngles[] = {1e-9, 1e-4, 0.3, 1.0, 1.99, 2.01, 2.5, 3.0, kPi - 1e-7, 4.0, 5.5};
} // namespace

TEST(RotationSeries, MatchesClosedFormsAndDerivatives)
{
  for (double theta : {0.05, 0.7, 1.9, 2.1, 3.0, 5.0}) {
    const double         x = theta * theta;
    const RotationSeries s = EvaluateRotationSeries(x);
    EXPECT_NEAR(s.c[0], std::cos(theta), 1e-14);
    EXPECT_NEAR(s.c[1], std::sin(theta) / theta, 1e-14);
    EXPECT_NEAR(s.c[2], (1 - std::cos(theta)) / x, 1e-13);
    EXPECT_NEAR(s.c[3], (theta - std::sin(theta)) / (x * theta), 1e-12);
    // derivatives by central differences in x
    const double         h  = 1e-5 * std::max(1.0, x);
    const RotationSeries sp = EvaluateRotationSeries(x + h), sm = EvaluateRotationSeries(x - h);
    for (int n = 0; n <= 4; ++n) {
      EXPECT_NEAR(s.dc[n], (sp.c[n] - sm.c[n]) / (2 * h), 1e-8 * (1 + std::abs(s.dc[n]))) << "n=" << n << " theta=" << theta;
      EXPECT_NEAR(s.ddc[n], (sp.dc[n] - sm.dc[n]) / (2 * h), 1e-7 * (1 + std::abs(s.ddc[n]))) << "n=" << n << " theta=" << theta;
    }
  }
  // Continuity across the series/closed-form switch at x = 4.
  const RotationSeries a = EvaluateRotationSeries(4.0 - 1e-12), b = EvaluateRotationSeries(4.0 + 1e-12);
  for (int n = 0; n <= 4; ++n) {
    // first-order Taylor correction for the 2e-12 gap in x
    EXPECT_NEAR(a.c[n] + 2e-12 * a.dc[n], b.c[n], 1e-14);
    EXPECT_NEAR(a.dc[n] + 2e-12 * a.ddc[n], b.dc[n], 1e-13);
    EXPECT_NEAR(a.ddc[n], b.ddc[n], 1e-11);
  }
}

TEST(SO3, ExpIsOrthogonalAndLogInvertsIt)
{
  std::mt19937 gen(1);
  for (double angle : kTestAngles) {
    if (angle >= kPi) continue;
    for (int trial = 0; trial < 20; ++trial) {
      const Vec3 psi = RandomVector(gen, 1.0).normalized() * angle;
      const Mat3 R   = ExpSO3(psi);
      EXPECT_LT(MaxAbs(R.transpose() * R - Mat3::Identity()), 1e-14);
      EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
      EXPECT_LT((LogSO3(R) - psi).norm(), 1e-12 * (1 + angle)) << "angle " << angle;
    }
  }
  // Exactly pi: log returns a vector of length pi along the axis (either sign).
  const Vec3 axis = Vec3(1, 2, 3).normalized();
  const Vec3 lp   = LogSO3(ExpSO3(kPi * axis));
  EXPECT_NEAR(lp.norm(), kPi, 1e-12);
  EXPECT_NEAR(std::abs(lp.normalized().dot(axis)), 1.0, 1e-12);
  EXPECT_EQ(LogSO3(Mat3::Identity()).norm(), 0.0);
}

TEST(SO3, AcuteLogAgreesWithLogEverywhere)
{
  // The three branches of LogSO3Acute: the arcsine series (sin^2 <= 0.01), atan2 (up to pi/2),
  // LogSO3 itself beyond; both sides of each switch and of pi/2 (a series cut too short would
  // show just below its switch). Small angles carry the rounding
  // of R's antisymmetric part, eps/theta relative, in both functions alike.
  std::mt19937 gen(7);
  const double switch_angle = std::asin(0.1);
  for (double angle : {0.0, 1e-12, 1e-7, 1e-3, 0.05, switch_angle - 1e-9, switch_angle + 1e-9, 0.35, 1.0, 0.5 * kPi - 1e-6, 0.5 * kPi + 1e-6, 2.5, 3.1}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Vec3 psi  = RandomVector(gen, 1.0).normalized() * angle;
      const Mat3 R    = ExpSO3(psi);
      const Vec3 fast = LogSO3Acute(R), reference = LogSO3(R);
      EXPECT_LE((fast - reference).norm(), 4e-16 + 4e-16 * angle) << "angle " << angle;
      EXPECT_LE((fast - psi).norm(), 4e-16 + 1e-15 * angle) << "angle " << angle;
    }
  }
  EXPECT_EQ(LogSO3Acute(Mat3::Identity()).norm(), 0.0);
}

TEST(SO3, TangentOperatorsMatchTheirSeriesForms)
{
  // TangentH and TangentHInverse sum only the functions they need: the same values, bit for bit,
  // as the full series' forms.
  std::mt19937 gen(8);
  for (double angle : kTestAngles) {
    const Vec3           psi = RandomVector(gen, 1.0).normalized() * angle;
    const RotationSeries s   = EvaluateRotationSeries(psi.squaredNorm());
    EXPECT_TRUE(TangentH(psi) == RodriguesMatrix(TangentForm(s), psi)) << "angle " << angle;
    if (angle < 2.0 * kPi - 1.0) EXPECT_TRUE(TangentHInverse(psi) == RodriguesMatrix(TangentInverseForm(s), psi)) << "angle " << angle;
  }
}

TEST(SO3, RodriguesMatrixIsTheOperatorWrittenOut)
{
  // I + alpha S + beta S^2 with S^2 = psi psi^T - x I written out: the operator itself to round-off,
  // and from RotationSeriesValues the exp, H and H^{-1} that the node updates build (bit for bit
  // the series' values, so ExpSO3, TangentH and TangentHInverse to round-off).
  std::mt19937 gen(9);
  for (double angle : kTestAngles) {
    const Vec3           psi = RandomVector(gen, 1.0).normalized() * angle;
    const Mat3           S   = Skew(psi);
    const RotationSeries s = RotationSeriesValues(psi.squaredNorm()), full = EvaluateRotationSeries(psi.squaredNorm());
    for (int n = 0; n < 5; ++n) EXPECT_EQ(s.c[n], full.c[n]) << "c" << n << " angle " << angle;
    for (const RodriguesForm &f : {ExpForm(s), TangentForm(s)}) {
      EXPECT_LT(MaxAbs(RodriguesMatrix(f, psi) - (Mat3::Identity() + f.alpha * S + f.beta * S * S)), 4e-16 * (1 + angle * angle)) << "angle " << angle;
    }
    EXPECT_LT(MaxAbs(RodriguesMatrix(ExpForm(s), psi) - ExpSO3(psi)), 1e-15 * (1 + angle)) << "angle " << angle;
    EXPECT_TRUE(RodriguesMatrix(TangentForm(s), psi) == TangentH(psi)) << "angle " << angle;
    if (angle < 2.0 * kPi - 1.0) EXPECT_TRUE(RodriguesMatrix(TangentInverseForm(s), psi) == TangentHInverse(psi)) << "angle " << angle;
  }
}

TEST(SO3, TangentOperatorIsTheDerivativeOfExp)
{
  // exp(psi + h dpsi) exp(psi)^T ~ exp(h H(psi) dpsi): the spin of a perturbed exp.
  std::mt19937 gen(2);
  for (double angle : kTestAngles) {
    for (int trial = 0; trial < 5; ++trial) {
      const Vec3   psi  = RandomVector(gen, 1.0).normalized() * angle;
      const Vec3   dpsi = RandomVector(gen, 1.0);
      const double h    = 1e-6;
      const Mat3   dR   = (ExpSO3(psi + h * dpsi) - ExpSO3(psi - h * dpsi)) / (2 * h);
      const Vec3   spin = Unskew(dR * ExpSO3(psi).transpose());
      EXPECT_LT((spin - TangentH(psi) * dpsi).norm(), 1e-8) << "angle " << angle;
      // H(psi) = exp(psi) H(psi)^T and H^{-1} H = I (away from 2 pi)
      EXPECT_LT(MaxAbs(TangentH(psi) - ExpSO3(psi) * TangentH(psi).transpose()), 1e-13);
      EXPECT_LT(MaxAbs(TangentHInverse(psi) * TangentH(psi) - Mat3::Identity()), 1e-12);
    }
  }
}

TEST(SO3, RodriguesJacobiansAndHessiansMatchFiniteDifferences)
{
  std::mt19937 gen(3);
  for (double angle : kTestAngles) {
    if (angle > 5.0) continue; // H^{-1} is singular at 2 pi
    const Vec3   psi = RandomVector(gen, 1.0).normalized() * angle, a = RandomVector(gen, 2.0), m = RandomVector(gen, 2.0);
    const double h = 1e-6;
    for (int which = 0; which < 3; ++which) {
      auto form = [which](const Vec3 &p) {
        const RotationSeries s = EvaluateRotationSeries(p.squaredNorm());
        return which == 0 ? ExpForm(s) : which == 1 ? TangentForm(s) : TangentInverseForm(s);
      };
      const RodriguesForm f = form(psi);
      Mat3                JT_fd, J_fd, H_fd;
      for (int k = 0; k < 3; ++k) {
        const Vec3 e  = Vec3::Unit(k) * h;
        const Mat3 Fp = RodriguesMatrix(form(psi + e), psi + e), Fm = RodriguesMatrix(form(psi - e), psi - e);
        JT_fd.col(k)  = (Fp.transpose() * a - Fm.transpose() * a) / (2 * h);
        J_fd.col(k)   = (Fp * a - Fm * a) / (2 * h);
        const Mat3 Jp = RodriguesTransposeApplyJacobian(form(psi + e), psi + e, a), Jm = RodriguesTransposeApplyJacobian(form(psi - e), psi - e, a);
        H_fd.col(k) = (Jp.transpose() * m - Jm.transpose() * m) / (2 * h);
      }
      const double scale = 1 + a.norm() * m.norm();
      EXPECT_LT(MaxAbs(RodriguesTransposeApplyJacobian(f, psi, a) - JT_fd), 1e-7 * scale) << which << " angle " << angle;
      EXPECT_LT(MaxAbs(RodriguesApplyJacobian(f, psi, a) - J_fd), 1e-7 * scale) << which << " angle " << angle;
      EXPECT_LT(MaxAbs(RodriguesTransposeApplyHessian(f, psi, a, m) - H_fd), 1e-6 * scale) << which << " angle " << angle;
      if (which == 0) {
        EXPECT_LT(MaxAbs(RodriguesMatrix(f, psi) - ExpSO3(psi)), 1e-13);
      }
    }
  }
}

TEST(SO3, CayleyAndTangentScaledVectors)
{
  std::mt19937 gen(4);
  for (double angle : {1e-9, 0.2, 1.5, 3.0}) {
    const Vec3 psi = RandomVector(gen, 1.0).normalized() * angle;
    const Vec3 a   = TangentScaledFromRotationVector(psi);
    EXPECT_LT(MaxAbs(CayleySO3(a) - ExpSO3(psi)), 1e-13);
    EXPECT_LT((RotationVectorFromTangentScaled(a) - psi).norm(), 1e-13);
    // Mid-point identity of the Cayley map: (I - hat(a)/2) cay(a) = I + hat(a)/2, i.e.
    // Lambda_{n+1} - Lambda_n = hat(a) (Lambda_n + Lambda_{n+1}) / 2.
    const Mat3 S = Skew(a);
    EXPECT_LT(MaxAbs((Mat3::Identity() - 0.5 * S) * CayleySO3(a) - (Mat3::Identity() + 0.5 * S)), 1e-12);
    // S(a)^{-1} of eq. (17) is the tangent operator of the Cayley map: d cay(a) cay(a)^T = hat(S^{-1} da).
    const Vec3   da   = RandomVector(gen, 1.0);
    const double h    = 1e-6;
    const Vec3   spin = Unskew((CayleySO3(a + h * da) - CayleySO3(a - h * da)) / (2 * h) * CayleySO3(a).transpose());
    EXPECT_LT((spin - CayleyMidpointOperatorInverse(a) * da).norm(), 1e-8);
  }
}

TEST(Quaternion, CompositionMatchesMatricesAndTracksTwoPi)
{
  std::mt19937 gen(5);
  for (int trial = 0; trial < 20; ++trial) {
    const Vec3       p = RandomVector(gen, 2.0), q = RandomVector(gen, 2.0);
    const Quaternion qp = QuaternionFromRotationVector(p), qq = QuaternionFromRotationVector(q);
    EXPECT_LT(MaxAbs(QuaternionToMatrix(qp) - ExpSO3(p)), 1e-14);
    EXPECT_LT(MaxAbs(QuaternionToMatrix(QuaternionMultiply(qp, qq)) - ExpSO3(p) * ExpSO3(q)), 1e-13);
    const Quaternion back = QuaternionFromMatrix(ExpSO3(p));
    EXPECT_LT(MaxAbs(QuaternionToMatrix(back) - ExpSO3(p)), 1e-14);
  }
  // Sixteen steps of 2 pi / 16 about z: q = -1, tracked angle 2 pi.
  Quaternion q;
  for (int k = 0; k < 16; ++k) q = QuaternionMultiply(QuaternionFromRotationVector(Vec3(0, 0, 2 * kPi / 16)), q);
  EXPECT_NEAR(q.w, -1.0, 1e-14);
  EXPECT_NEAR(QuaternionTrackedAngle(q), 2 * kPi, 1e-12);
}
