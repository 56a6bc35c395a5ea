// Inertia kernels and time schemes: tangents against central finite differences for every scheme
// (rotational inertia of a node, a rigid body's offset centre of mass), and the exact discrete
// energy identities of the mid-point family (kinetic energy changes by exactly u.F + alpha.M).
#include "elements/inertia.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

using namespace msflex;

namespace {

std::mt19937 generator(7);
Vec3         RandomVector(double scale)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Vec3(u(generator), u(generator), u(generator));
}

Mat3 RandomInertia()
{
  const Mat3 Q = ExpSO3(RandomVector(2.0));
  return Q * Vec3(2.0, 1.3, 0.7).asDiagonal() * Q.transpose();
}

MotionState RandomMotion()
{
  MotionState s;
  s.velocity            = RandomVector(1.5);
  s.acceleration        = RandomVector(1.0);
  s.pseudo_acceleration = RandomVector(1.0);
  return s;
}

const TimeSchemeKind kAllSchemes[] = {TimeSchemeKind::Newmark, TimeSchemeKind::GeneralizedAlpha, TimeSchemeKind::MomentumConserving,
                                      TimeSchemeKind::EnergyMomentum};

double MaxAbs(const Eigen::MatrixXd &m) { return m.cwiseAbs().maxCoeff(); }

} // namespace

TEST(TimeScheme, GeneralizedAlphaCoefficientsFromSpectralRadius)
{
  const TimeScheme s = MakeTimeScheme(TimeSchemeKind::GeneralizedAlpha, 0.6, 0.01);
  EXPECT_NEAR(s.alpha_m, (2 * 0.6 - 1) / 1.6, 1e-15);
  EXPECT_NEAR(s.alpha_f, 0.6 / 1.6, 1e-15);
  EXPECT_NEAR(s.gamma, 0.5 + s.alpha_f - s.alpha_m, 1e-15);
  EXPECT_NEAR(s.beta, 0.25 * (s.gamma + 0.5) * (s.gamma + 0.5), 1e-15);
  // rho = 1 reduces to the trapezoidal rule.
  const TimeScheme t = MakeTimeScheme(TimeSchemeKind::GeneralizedAlpha, 1.0, 0.01);
  EXPECT_NEAR(t.alpha_m, 0.5, 1e-15);
  EXPECT_NEAR(t.alpha_f, 0.5, 1e-15);
  EXPECT_NEAR(t.beta, 0.25, 1e-15);
  EXPECT_NEAR(t.gamma, 0.5, 1e-15);
}

TEST(TimeScheme, TangentScaledIncrementAndDerivative)
{
  for (double angle : {1e-5, 2e-3, 0.4, 1.5, 2.8}) {
    const Vec3 omega = RandomVector(1.0).normalized() * angle;
    Vec3       alpha;
    Mat3       dalpha;
    TangentScaledIncrement(omega, &alpha, &dalpha);
    EXPECT_LT((alpha - TangentScaledFromRotationVector(omega)).norm(), 1e-14 * (1 + alpha.norm()));
    Mat3 fd;
    for (int k = 0; k < 3; ++k) {
      Vec3 ap, am;
      TangentScaledIncrement(omega + 1e-6 * Vec3::Unit(k), &ap, nullptr);
      TangentScaledIncrement(omega - 1e-6 * Vec3::Unit(k), &am, nullptr);
      fd.col(k) = (ap - am) / 2e-6;
    }
    EXPECT_LT(MaxAbs(fd - dalpha), 1e-8 * (1 + MaxAbs(dalpha))) << angle;
  }
}

TEST(TimeScheme, TangentScaledIncrementFromTheSeriesIsTheTangentForm)
{
  // The node update's form (2 c2/c1 from the rotation series) against tan: the same vector and
  // derivative to round-off, on both sides of the small-angle switch and towards pi.
  for (double angle : {0.0, 1e-7, 1e-3 - 1e-12, 1e-3 + 1e-12, 0.02, 0.4, 1.5, 2.8, 3.1}) {
    const Vec3           omega  = RandomVector(1.0).normalized() * angle;
    const RotationSeries series = RotationSeriesValues(omega.squaredNorm());
    Vec3                 alpha, alpha_series;
    Mat3                 dalpha, dalpha_series;
    TangentScaledIncrement(omega, &alpha, &dalpha);
    TangentScaledIncrement(omega, series.c[1], series.c[2], &alpha_series, &dalpha_series);
    EXPECT_LT((alpha_series - alpha).norm(), 4e-16 * (1 + alpha.norm())) << angle;
    EXPECT_LT(MaxAbs(dalpha_series - dalpha), 1e-13 * (1 + MaxAbs(dalpha))) << angle;
    EXPECT_LT((alpha_series - TangentScaledFromRotationVector(omega)).norm(), 1e-14 * (1 + alpha.norm())) << angle;
  }
}

TEST(Inertia, RotationalInertiaTangentMatchesFiniteDifferences)
{
  for (TimeSchemeKind kind : kAllSchemes) {
    const TimeScheme  scheme = MakeTimeScheme(kind, 0.7, 0.05);
    const Mat3        J = RandomInertia(), R = ExpSO3(RandomVector(2.0));
    const MotionState start = RandomMotion();
    const Vec3        omega = RandomVector(0.4);
    Vec3              moment;
    Mat3              tangent, fd;
    MotionUpdate      update;
    RotationalInertia(scheme, J, R, omega, start, &moment, &tangent, &update);
    for (int k = 0; k < 3; ++k) {
      Vec3 mp, mm;
      RotationalInertia(scheme, J, R, omega + 1e-6 * Vec3::Unit(k), start, &mp, nullptr, &update);
      RotationalInertia(scheme, J, R, omega - 1e-6 * Vec3::Unit(k), start, &mm, nullptr, &update);
      fd.col(k) = (mp - mm) / 2e-6;
    }
    const double error = MaxAbs(fd - tangent) / MaxAbs(tangent);
    std::printf("rotational inertia, %s: FD relative error %.2e\n", TimeSchemeName(kind), error);
    EXPECT_LT(error, 1e-6) << TimeSchemeName(kind);
  }
}

// Newmark family, a wholly prescribed rotation (NodeState::prescribed_spin): W_{n+1} and Wdot_{n+1}
// are given, so the moment Lambda_{n+1} (J Wdot + W x J W) varies with omega through Lambda_{n+1}
// alone, and the update reports the given rates.
TEST(Inertia, PrescribedSpinTangentMatchesFiniteDifferences)
{
  for (TimeSchemeKind kind : {TimeSchemeKind::Newmark, TimeSchemeKind::GeneralizedAlpha}) {
    const TimeScheme  scheme = MakeTimeScheme(kind, 0.7, 0.05);
    const Mat3        J = RandomInertia(), R = ExpSO3(RandomVector(2.0));
    const MotionState start = RandomMotion();
    MotionUpdate      spin;
    spin.velocity = RandomVector(1.5), spin.acceleration = spin.pseudo_acceleration = RandomVector(1.0);
    const auto increment_of = [&](const Vec3 &omega) {
      RotationIncrement increment;
      increment.omega    = omega;
      increment.rotation = ExpSO3(omega) * R;
      increment.tangent  = TangentH(omega);
      return increment;
    };
    const Vec3   omega = RandomVector(0.4);
    Vec3         moment;
    Mat3         tangent, fd;
    MotionUpdate update;
    RotationalInertia(scheme, J, R, increment_of(omega), start, &moment, &tangent, &update, &spin);
    EXPECT_EQ(update.velocity, spin.velocity);
    EXPECT_EQ(update.acceleration, spin.acceleration);
    const Vec3 expected = ExpSO3(omega) * R * (J * spin.acceleration + spin.velocity.cross(J * spin.velocity));
    EXPECT_LT((moment - expected).norm(), 1e-12 * expected.norm());
    for (int k = 0; k < 3; ++k) {
      Vec3 mp, mm;
      RotationalInertia(scheme, J, R, increment_of(omega + 1e-6 * Vec3::Unit(k)), start, &mp, nullptr, &update, &spin);
      RotationalInertia(scheme, J, R, increment_of(omega - 1e-6 * Vec3::Unit(k)), start, &mm, nullptr, &update, &spin);
      fd.col(k) = (mp - mm) / 2e-6;
    }
    const double error = MaxAbs(fd - tangent) / MaxAbs(tangent);
    std::printf("rotational inertia with a prescribed spin, %s: FD relative error %.2e\n", TimeSchemeName(kind), error);
    EXPECT_LT(error, 1e-6) << TimeSchemeName(kind);
  }
}

TEST(Inertia, OffsetPointMassTangentMatchesFiniteDifferences)
{
  for (TimeSchemeKind kind : kAllSchemes) {
    const TimeScheme  scheme = MakeTimeScheme(kind, 0.7, 0.05);
    const Mat3        R      = ExpSO3(RandomVector(2.0));
    const Vec3        offset = RandomVector(0.8), u = RandomVector(0.1), omega = RandomVector(0.4);
    const MotionState start = RandomMotion();
    Vec6              residual;
    Mat6              tangent, fd;
    MotionUpdate      update;
    OffsetPointMassInertia(scheme, 3.0, offset, R, u, omega, start, &residual, &tangent, &update);
    for (int k = 0; k < 6; ++k) {
      Vec6       rp, rm;
      const Vec3 du = k < 3 ? Vec3(1e-6 * Vec3::Unit(k)) : Vec3::Zero(), dw = k >= 3 ? Vec3(1e-6 * Vec3::Unit(k - 3)) : Vec3::Zero();
      OffsetPointMassInertia(scheme, 3.0, offset, R, u + du, omega + dw, start, &rp, nullptr, &update);
      OffsetPointMassInertia(scheme, 3.0, offset, R, u - du, omega - dw, start, &rm, nullptr, &update);
      fd.col(k) = (rp - rm) / 2e-6;
    }
    const double error = MaxAbs(fd - tangent) / MaxAbs(tangent);
    std::printf("offset point mass, %s: FD relative error %.2e\n", TimeSchemeName(kind), error);
    EXPECT_LT(error, 1e-6) << TimeSchemeName(kind);
  }
}

TEST(Inertia, MidpointSchemesChangeKineticEnergyByExactlyTheWork)
{
  for (TimeSchemeKind kind : {TimeSchemeKind::MomentumConserving, TimeSchemeKind::EnergyMomentum}) {
    const TimeScheme  scheme = MakeTimeScheme(kind, 0.0, 0.05);
    const Mat3        J = RandomInertia(), R = ExpSO3(RandomVector(2.0));
    const MotionState start = RandomMotion();
    const Vec3        omega = RandomVector(0.9), u = RandomVector(0.2), offset = RandomVector(0.7);
    Vec3              alpha;
    TangentScaledIncrement(omega, &alpha, nullptr);
    // Rotation: T_{n+1} - T_n = m_in . alpha.
    Vec3         moment;
    MotionUpdate update;
    RotationalInertia(scheme, J, R, omega, start, &moment, nullptr, &update);
    const double dT_rotation = 0.5 * update.velocity.dot(J * update.velocity) - 0.5 * start.velocity.dot(J * start.velocity);
    EXPECT_NEAR(dT_rotation, moment.dot(alpha), 1e-12 * (1 + std::abs(dT_rotation)));
    // Offset point mass: T_{n+1} - T_n = (F, M) . (u, alpha).
    Vec6 residual;
    OffsetPointMassInertia(scheme, 2.5, offset, R, u, omega, start, &residual, nullptr, &update);
    const double dT_point = 0.5 * 2.5 * (update.velocity.squaredNorm() - start.velocity.squaredNorm());
    EXPECT_NEAR(dT_point, residual.head<3>().dot(u) + residual.tail<3>().dot(alpha), 1e-12 * (1 + std::abs(dT_point)));
  }
}

// The beams' consistent translational inertia is sum_b M_ab xddot_b with xddot from AdvanceMotion;
// its tangent is M_ab * InertiaCoefficient(). Check that coefficient (and the velocity one) by
// finite differences for every scheme.
TEST(Inertia, TranslationalInertiaCoefficientsMatchFiniteDifferences)
{
  for (TimeSchemeKind kind : kAllSchemes) {
    const TimeScheme  scheme = MakeTimeScheme(kind, 0.7, 0.05);
    const MotionState start  = RandomMotion();
    const Vec3        u      = RandomVector(0.1);
    for (int k = 0; k < 3; ++k) {
      const MotionUpdate plus = AdvanceMotion(scheme, start, u + 1e-6 * Vec3::Unit(k)), minus = AdvanceMotion(scheme, start, u - 1e-6 * Vec3::Unit(k));
      const Vec3         dacc = (plus.acceleration - minus.acceleration) / 2e-6, dvel = (plus.velocity - minus.velocity) / 2e-6;
      EXPECT_NEAR(dacc(k), scheme.InertiaCoefficient(), 1e-6 * scheme.InertiaCoefficient()) << TimeSchemeName(kind);
      EXPECT_NEAR(dvel(k), scheme.VelocityCoefficient(), 1e-6 * scheme.VelocityCoefficient()) << TimeSchemeName(kind);
      EXPECT_NEAR(dacc.norm(), std::abs(dacc(k)), 1e-6 * scheme.InertiaCoefficient()); // diagonal
    }
  }
}
