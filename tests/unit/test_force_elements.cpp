// Force-element kernels (elements/force_elements.hpp), the rigid offset mass of the Newmark family
// (elements/inertia.hpp) and the beam's strain rates (elements/beam_rates.hpp): every tangent
// against central finite differences (relative error <= 1e-6), the mid-point forms' exact energy
// identity (work over the test quantities = change of stored energy + dissipation - actuator work)
// and their balance of forces and moments about the mid-point configuration.
#include "elements/beam_rates.hpp"
#include "elements/force_elements.hpp"
#include "elements/inertia.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

using namespace msflex;

namespace {

std::mt19937 generator(11);
Vec3         RandomVector(double scale)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Vec3(u(generator), u(generator), u(generator));
}

double RelativeError(const Eigen::MatrixXd &analytic, const Eigen::MatrixXd &fd) { return (analytic - fd).norm() / std::max(analytic.norm(), 1e-300); }

// A tabulated curve, stiffening in tension: (-0.2, -30), (0, 0), (0.05, 4), (0.3, 60).
const double kDeflections[] = {-0.2, 0.0, 0.05, 0.3};
const double kForces[]      = {-30.0, 0.0, 4.0, 60.0};
SpringCurve  TableSpring(double free_value)
{
  SpringCurve s;
  s.free_value  = free_value;
  s.count       = 4;
  s.deflections = kDeflections;
  s.forces      = kForces;
  return s;
}
SpringCurve LinearSpring(double stiffness, double free_value)
{
  SpringCurve s;
  s.stiffness  = stiffness;
  s.free_value = free_value;
  return s;
}

} // namespace

TEST(SpringCurve, EnergyIsTheIntegralOfTheForceAndTheMeanIsExact)
{
  for (const SpringCurve &spring : {LinearSpring(250.0, 0.4), TableSpring(0.1)}) {
    for (double x : {-0.5, 0.02, 0.13, 0.16, 0.33, 0.9}) {
      const double h = 1e-6;
      double       slope;
      const double f = SpringForce(spring, x, &slope);
      EXPECT_NEAR((SpringEnergy(spring, x + h) - SpringEnergy(spring, x - h)) / (2 * h), f, 1e-6 * std::max(1.0, std::abs(f)));
      EXPECT_NEAR((SpringForce(spring, x + h, nullptr) - SpringForce(spring, x - h, nullptr)) / (2 * h), slope, 1e-6 * std::max(1.0, std::abs(slope)));
      for (double x1 : {-0.45, 0.0, 0.12, 0.145, 0.6, 1.2}) {
        double       derivative;
        const double mean = SpringMeanForce(spring, x, x1, &derivative);
        if (x1 != x) EXPECT_NEAR(mean * (x1 - x), SpringEnergy(spring, x1) - SpringEnergy(spring, x), 1e-12 * std::max(1.0, std::abs(mean)));
        double       unused;
        const double fd = (SpringMeanForce(spring, x, x1 + h, &unused) - SpringMeanForce(spring, x, x1 - h, &unused)) / (2 * h);
        EXPECT_NEAR(derivative, fd, 1e-6 * std::max(1.0, std::abs(fd))) << x << " -> " << x1;
      }
    }
  }
}

TEST(CoordinateForce, TangentsMatchFiniteDifferencesAndTheMidpointWorkIsExact)
{
  const SpringCurve springs[] = {LinearSpring(40.0, 0.2), TableSpring(-0.05)};
  for (const SpringCurve &spring : springs)
    for (bool angle : {false, true}) {
      // End point (Newmark): qdot = qdot_0 + c_v dq.
      CoordinateForceStep step;
      step.start            = 0.07;
      step.increment        = 0.21;
      step.rate_coefficient = 37.0;
      step.actuator         = 1.3;
      step.angle            = angle;
      const double rate0    = -0.4;
      auto         row      = [&](double dq, bool midpoint) {
        CoordinateForceStep s = step;
        s.increment           = dq;
        s.midpoint            = midpoint;
        s.rate                = rate0 + step.rate_coefficient * dq;
        s.dt                  = 0.01;
        CoordinateForceValues v;
        CoordinateForce(&spring, 2.5, s, &v);
        return v;
      };
      const double h = 1e-6;
      for (bool midpoint : {false, true}) {
        const CoordinateForceValues v  = row(step.increment, midpoint);
        const double                fd = (row(step.increment + h, midpoint).residual - row(step.increment - h, midpoint).residual) / (2 * h);
        EXPECT_NEAR(v.tangent, fd, 1e-6 * std::abs(fd)) << (midpoint ? "mid-point" : "end point") << (angle ? ", angle" : "");
      }
      // Mid-point: r p = V(q_{n+1}) - V(q_n) + dissipation - actuator work, p = 2 tan(dq/2) for an angle.
      for (double dq : {0.21, 1e-5, -0.8}) {
        const CoordinateForceValues v  = row(dq, true);
        const double                p  = angle ? 2.0 * std::tan(0.5 * dq) : dq;
        const double                V1 = SpringEnergy(spring, step.start + dq), V0 = SpringEnergy(spring, step.start);
        const double                balance = V1 - V0 + v.dissipation - v.actuator_work;
        // Relative to the energies: their difference cancels for a small step.
        EXPECT_NEAR(v.residual * p, balance, 1e-13 * (std::abs(v.residual * p) + std::abs(V1) + std::abs(V0)));
        EXPECT_GE(v.dissipation, 0.0);
      }
    }
}

TEST(AxialSpringDamper, TangentsMatchFiniteDifferences)
{
  const SpringCurve spring = TableSpring(1.2);
  const Vec3        xa0 = Vec3(0.1, -0.2, 0.3), xb0 = Vec3(1.0, 0.6, 0.1);
  const Vec3        xa = xa0 + RandomVector(0.1), xb = xb0 + RandomVector(0.1), va0 = RandomVector(1.0), vb0 = RandomVector(1.0);
  const double      cv = 41.0, c = 3.5, dt = 0.02;
  for (bool midpoint : {false, true}) {
    auto evaluate = [&](const Vec3 &a, const Vec3 &b, Mat12 *K) {
      AxialSpringValues v;
      bool              ok = midpoint ? AxialSpringDamperMidpoint(spring, c, xa0, xb0, a, b, dt, &v, K)
                                      : AxialSpringDamperEndPoint(spring, c, a, b, va0 + cv * (a - xa), vb0 + cv * (b - xb), cv, &v, K);
      EXPECT_TRUE(ok);
      return v.residual;
    };
    Mat12 K;
    evaluate(xa, xb, &K);
    Mat12        fd = Mat12::Zero();
    const double h  = 1e-6;
    for (int j = 0; j < 3; ++j)
      for (int node = 0; node < 2; ++node) {
        Vec3 a = xa, b = xb, a2 = xa, b2 = xb;
        (node == 0 ? a : b)(j) += h;
        (node == 0 ? a2 : b2)(j) -= h;
        fd.col(6 * node + j) = (evaluate(a, b, nullptr) - evaluate(a2, b2, nullptr)) / (2 * h);
      }
    EXPECT_LT(RelativeError(K, fd), 1e-6) << (midpoint ? "mid-point" : "end point");
  }
  // Mid-point: work over (u_a, u_b) = change of stored energy + c dl^2/dt; no net force or moment
  // about the mid-point configuration.
  AxialSpringValues v;
  ASSERT_TRUE(AxialSpringDamperMidpoint(spring, c, xa0, xb0, xa, xb, dt, &v, nullptr));
  const double l0 = (xb0 - xa0).norm(), l1 = (xb - xa).norm();
  const double work = v.residual.segment<3>(0).dot(xa - xa0) + v.residual.segment<3>(6).dot(xb - xb0);
  EXPECT_NEAR(work, SpringEnergy(spring, l1) - SpringEnergy(spring, l0) + c * (l1 - l0) * (l1 - l0) / dt, 1e-13 * std::abs(work));
  const Vec3 moment = (0.5 * (xa0 + xa)).cross(Vec3(v.residual.segment<3>(0))) + (0.5 * (xb0 + xb)).cross(Vec3(v.residual.segment<3>(6)));
  EXPECT_LT(moment.norm(), 1e-13 * v.residual.norm());
}

namespace {

struct BushingSetup {
  Mat6 K, C;
  Mat3 axes;
  Vec3 d_ref;
};
BushingSetup MakeBushing()
{
  BushingSetup                b;
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Random();
  b.K                           = A * A.transpose() + 6.0 * Mat6::Identity();
  b.K *= 50.0;
  Eigen::Matrix<double, 6, 6> B = Eigen::Matrix<double, 6, 6>::Random();
  b.C                           = B * B.transpose() + Mat6::Identity();
  b.axes                        = ExpSO3(Vec3(0.3, -0.5, 0.8));
  b.d_ref                       = Vec3(0.2, -0.1, 0.05);
  return b;
}

// A spin perturbation of node `node`'s rotation (component j) or a displacement.
void Perturb(BushingNode *a, BushingNode *b, int column, double h)
{
  BushingNode *n = column < 6 ? a : b;
  const int    k = column % 6;
  if (k < 3) n->position(k) += h;
  else n->rotation = ExpSO3(h * Vec3::Unit(k - 3)) * n->rotation;
}

} // namespace

TEST(Bushing, EndPointTangentMatchesFiniteDifferences)
{
  const BushingSetup s = MakeBushing();
  BushingNode        a, b;
  a.position             = Vec3(0.1, 0.2, -0.1);
  a.rotation             = ExpSO3(Vec3(0.4, -0.3, 0.2));
  b.position             = a.position + a.rotation * s.axes * s.d_ref + RandomVector(0.05);
  b.rotation             = a.rotation * ExpSO3(Vec3(0.3, 0.2, -0.25));
  a.velocity             = RandomVector(1.0);
  b.velocity             = RandomVector(1.0);
  a.angular              = RandomVector(2.0);
  b.angular              = RandomVector(2.0);
  a.velocity_coefficient = 30.0;
  b.velocity_coefficient = 30.0;
  a.angular_jacobian     = 30.0 * ExpSO3(RandomVector(0.3)) - Skew(a.angular);
  b.angular_jacobian     = 30.0 * ExpSO3(RandomVector(0.3)) - Skew(b.angular);
  for (bool damped : {false, true}) {
    const Mat6 C        = damped ? s.C : Mat6::Zero();
    auto       evaluate = [&](int column, double h, Mat12 *K) {
      BushingNode pa = a, pb = b;
      Perturb(&pa, &pb, column, h);
      // The velocities move with the configuration as the scheme makes them.
      Vec6 da = Vec6::Zero(), db = Vec6::Zero();
      if (column >= 0) (column < 6 ? da : db)(column % 6) = h;
      pa.velocity += a.velocity_coefficient * da.head<3>(), pa.angular += a.angular_jacobian * da.tail<3>();
      pb.velocity += b.velocity_coefficient * db.head<3>(), pb.angular += b.angular_jacobian * db.tail<3>();
      BushingValues v;
      EXPECT_TRUE(BushingEndPoint(s.K, C, s.axes, s.d_ref, pa, pb, &v, K));
      return v.residual;
    };
    Mat12 K;
    evaluate(-1, 0.0, &K);
    Mat12 fd;
    for (int j = 0; j < 12; ++j) fd.col(j) = (evaluate(j, 1e-6, nullptr) - evaluate(j, -1e-6, nullptr)) / 2e-6;
    EXPECT_LT(RelativeError(K, fd), 1e-6) << (damped ? "damped" : "elastic");
  }
}

TEST(Bushing, MidpointTangentAndExactEnergyAndMomenta)
{
  const BushingSetup s = MakeBushing();
  BushingNode        a0, b0, a1, b1;
  a0.position           = Vec3(0.1, 0.2, -0.1);
  a0.rotation           = ExpSO3(Vec3(0.4, -0.3, 0.2));
  b0.position           = a0.position + a0.rotation * s.axes * s.d_ref + RandomVector(0.05);
  b0.rotation           = a0.rotation * ExpSO3(Vec3(0.3, 0.2, -0.25));
  a1.position           = a0.position + RandomVector(0.2);
  a1.rotation           = ExpSO3(RandomVector(0.6)) * a0.rotation;
  b1.position           = b0.position + RandomVector(0.2);
  b1.rotation           = ExpSO3(RandomVector(0.6)) * b0.rotation;
  const double dt       = 0.05;
  auto         alpha_of = [](const BushingNode &start, const BushingNode &end) {
    return TangentScaledFromRotationVector(LogSO3(end.rotation * start.rotation.transpose()));
  };
  auto evaluate = [&](int column, double h, Mat12 *K) {
    BushingNode pa = a1, pb = b1;
    Perturb(&pa, &pb, column, h);
    BushingValues v;
    EXPECT_TRUE(BushingMidpoint(s.K, s.C, s.axes, s.d_ref, a0, b0, pa, pb, alpha_of(a0, pa), alpha_of(b0, pb), dt, &v, K));
    return v.residual;
  };
  Mat12 K;
  evaluate(-1, 0.0, &K);
  Mat12 fd;
  for (int j = 0; j < 12; ++j) fd.col(j) = (evaluate(j, 1e-6, nullptr) - evaluate(j, -1e-6, nullptr)) / 2e-6;
  EXPECT_LT(RelativeError(K, fd), 1e-6);

  // Work over (u_a, alpha_a, u_b, alpha_b) = change of e^T K e / 2 + the damper's dissipation.
  BushingValues v;
  const Vec3    alpha_a = alpha_of(a0, a1), alpha_b = alpha_of(b0, b1);
  ASSERT_TRUE(BushingMidpoint(s.K, s.C, s.axes, s.d_ref, a0, b0, a1, b1, alpha_a, alpha_b, dt, &v, nullptr));
  Vec6 e0, e1;
  ASSERT_TRUE(BushingDeflection(s.axes, s.d_ref, a0.position, a0.rotation, b0.position, b0.rotation, &e0));
  ASSERT_TRUE(BushingDeflection(s.axes, s.d_ref, a1.position, a1.rotation, b1.position, b1.rotation, &e1));
  Vec12 test;
  test << a1.position - a0.position, alpha_a, b1.position - b0.position, alpha_b;
  const double work       = v.residual.dot(test);
  const double stored     = 0.5 * e1.dot(s.K * e1) - 0.5 * e0.dot(s.K * e0);
  const double dissipated = v.damper_force.dot(e1 - e0);
  EXPECT_NEAR(work, stored + dissipated, 1e-12 * (std::abs(work) + std::abs(stored)));
  EXPECT_GT(dissipated, 0.0);
  // No net force; no net moment about the mid-point configuration.
  const Vec3 force  = v.residual.segment<3>(0) + v.residual.segment<3>(6);
  const Vec3 moment = (0.5 * (a0.position + a1.position)).cross(Vec3(v.residual.segment<3>(0))) + Vec3(v.residual.segment<3>(3)) +
                      (0.5 * (b0.position + b1.position)).cross(Vec3(v.residual.segment<3>(6))) + Vec3(v.residual.segment<3>(9));
  EXPECT_LT(force.norm(), 1e-13 * v.residual.norm());
  EXPECT_LT(moment.norm(), 1e-12 * v.residual.norm());
}

TEST(RigidOffsetMass, NewmarkFamilyTangentMatchesFiniteDifferences)
{
  for (TimeSchemeKind kind : {TimeSchemeKind::Newmark, TimeSchemeKind::GeneralizedAlpha}) {
    const TimeScheme scheme = MakeTimeScheme(kind, 0.7, 0.03);
    const Mat3       R0     = ExpSO3(Vec3(0.3, -0.6, 0.2));
    const Vec3       c(0.2, -0.1, 0.5), u = RandomVector(0.1), omega = RandomVector(0.5);
    MotionState      translation, rotation;
    translation.velocity = RandomVector(1.0), translation.acceleration = RandomVector(1.0), translation.pseudo_acceleration = RandomVector(1.0);
    rotation.velocity = RandomVector(2.0), rotation.acceleration = RandomVector(1.0), rotation.pseudo_acceleration = RandomVector(1.0);
    Vec6 r;
    Mat6 K, fd;
    // The node's acceleration from its increment, as StateUpdateNode makes it for a free node.
    const auto acceleration = [&](const Vec3 &increment) { return AdvanceMotion(scheme, translation, increment).acceleration; };
    RigidOffsetMassInertia(scheme, 2.5, c, R0, omega, acceleration(u), rotation, &r, &K);
    for (int j = 0; j < 6; ++j) {
      Vec6 rp, rm;
      Vec3 up = u, um = u, wp = omega, wm = omega;
      (j < 3 ? up : wp)(j % 3) += 1e-6;
      (j < 3 ? um : wm)(j % 3) -= 1e-6;
      RigidOffsetMassInertia(scheme, 2.5, c, R0, wp, acceleration(up), rotation, &rp, nullptr);
      RigidOffsetMassInertia(scheme, 2.5, c, R0, wm, acceleration(um), rotation, &rm, nullptr);
      fd.col(j) = (rp - rm) / 2e-6;
    }
    EXPECT_LT(RelativeError(K, fd), 1e-6) << TimeSchemeName(kind);
    // A prescribed spin (W, Wdot fixed; NodeSpinUpdate): the same check, W x c and Wdot x c now
    // constants of omega, and the residual that of those rates.
    MotionUpdate spin;
    spin.velocity = RandomVector(2.0), spin.acceleration = spin.pseudo_acceleration = RandomVector(1.0);
    RigidOffsetMassInertia(scheme, 2.5, c, R0, omega, acceleration(u), rotation, &r, &K, &spin);
    const Vec3 y = spin.acceleration.cross(c) + spin.velocity.cross(spin.velocity.cross(c));
    EXPECT_LT((r.head<3>() - 2.5 * (acceleration(u) + ExpSO3(omega) * R0 * y)).norm(), 1e-12 * r.norm()) << TimeSchemeName(kind);
    for (int j = 0; j < 6; ++j) {
      Vec6 rp, rm;
      Vec3 up = u, um = u, wp = omega, wm = omega;
      (j < 3 ? up : wp)(j % 3) += 1e-6;
      (j < 3 ? um : wm)(j % 3) -= 1e-6;
      RigidOffsetMassInertia(scheme, 2.5, c, R0, wp, acceleration(up), rotation, &rp, nullptr, &spin);
      RigidOffsetMassInertia(scheme, 2.5, c, R0, wm, acceleration(um), rotation, &rm, nullptr, &spin);
      fd.col(j) = (rp - rm) / 2e-6;
    }
    EXPECT_LT(RelativeError(K, fd), 1e-6) << TimeSchemeName(kind) << ", prescribed spin";
  }
}

namespace {

// A curved 3-node element in a deformed configuration.
void CurvedElement(BeamElementReference *ref, Vec3 *x, Mat3 *T)
{
  Vec3 X[3] = {Vec3(0, 0, 0), Vec3(0.5, 0.1, 0.05), Vec3(1.0, 0.15, 0.0)};
  Mat3 T0[3];
  for (int a = 0; a < 3; ++a) T0[a] = ExpSO3(Vec3(0.05 * a, -0.1 * a, 0.2 * a));
  ASSERT_EQ(BeamElementSetup(3, X, T0, ref), BeamKernelStatus::Ok);
  for (int a = 0; a < 3; ++a) {
    x[a] = X[a] + RandomVector(0.05);
    T[a] = ExpSO3(RandomVector(0.3)) * T0[a];
  }
}

} // namespace

TEST(BeamStrainRates, RatesAndAccelerationsAreTimeDerivatives)
{
  BeamElementReference ref;
  Vec3                 x[3], v[3], w[3], a[3], wdot[3];
  Mat3                 T[3];
  CurvedElement(&ref, x, T);
  for (int n = 0; n < 3; ++n) v[n] = RandomVector(1.0), w[n] = RandomVector(1.5), a[n] = RandomVector(2.0), wdot[n] = RandomVector(2.0);
  // The motion x(t) = x + t v + t^2 a / 2, Lambda(t) = exp(t w + t^2 wdot / 2) Lambda (spatial angular
  // velocity w + t wdot + O(t^2)); its strains at t = +-h and its rates.
  auto strains_at = [&](double t, Vec3 *strain, Vec3 *curvature, Vec3 *rate, Vec3 *curvature_rate) {
    Vec3 xt[3], vt[3], wt[3];
    Mat3 Tt[3];
    for (int n = 0; n < 3; ++n) {
      xt[n] = x[n] + t * v[n] + 0.5 * t * t * a[n];
      vt[n] = v[n] + t * a[n];
      // For Lambda(t) = exp(phi(t)) Lambda, phi = t w + t^2 wdot/2: spatial angular velocity H(phi) phidot.
      const Vec3 phi = t * w[n] + 0.5 * t * t * wdot[n];
      Tt[n]          = ExpSO3(phi) * T[n];
      wt[n]          = TangentH(phi) * (w[n] + t * wdot[n]);
    }
    ASSERT_EQ(BeamStrainRates(ref, xt, Tt, vt, wt, strain, curvature, rate, curvature_rate), BeamKernelStatus::Ok);
  };
  const double h = 1e-5;
  Vec3         s0[2], k0[2], r0[2], q0[2], sp[2], kp[2], rp[2], qp[2], sm[2], km[2], rm[2], qm[2];
  strains_at(0.0, s0, k0, r0, q0);
  strains_at(h, sp, kp, rp, qp);
  strains_at(-h, sm, km, rm, qm);
  Vec3 acceleration[2], curvature_acceleration[2];
  // The angular acceleration of Lambda(t) at t = 0: d/dt [H(phi) phidot] = wdot + (dH/dt) w = wdot (dH(0)/dt w = hat(w) w / 2 = 0).
  ASSERT_EQ(BeamStrainAccelerations(ref, x, T, v, w, a, wdot, acceleration, curvature_acceleration), BeamKernelStatus::Ok);
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const Vec3 fd_rate = (sp[gp] - sm[gp]) / (2 * h), fd_curvature_rate = (kp[gp] - km[gp]) / (2 * h);
    EXPECT_LT((r0[gp] - fd_rate).norm(), 1e-6 * fd_rate.norm());
    EXPECT_LT((q0[gp] - fd_curvature_rate).norm(), 1e-6 * fd_curvature_rate.norm());
    const Vec3 fd_acceleration = (rp[gp] - rm[gp]) / (2 * h), fd_curvature_acceleration = (qp[gp] - qm[gp]) / (2 * h);
    EXPECT_LT((acceleration[gp] - fd_acceleration).norm(), 1e-6 * fd_acceleration.norm());
    EXPECT_LT((curvature_acceleration[gp] - fd_curvature_acceleration).norm(), 1e-6 * fd_curvature_acceleration.norm());
  }
  // A rigid motion has no strain rate.
  Vec3 rigid_v[3], rigid_w[3], rate[2], curvature_rate[2];
  for (int n = 0; n < 3; ++n) rigid_v[n] = Vec3(0.3, -0.2, 0.5) + Vec3(1.0, 0.4, -0.7).cross(x[n]), rigid_w[n] = Vec3(1.0, 0.4, -0.7);
  ASSERT_EQ(BeamStrainRates(ref, x, T, rigid_v, rigid_w, nullptr, nullptr, rate, curvature_rate), BeamKernelStatus::Ok);
  for (int gp = 0; gp < ref.num_gauss; ++gp) EXPECT_LT(rate[gp].norm() + curvature_rate[gp].norm(), 1e-14);
}
