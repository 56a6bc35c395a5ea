// Joint kinematics: the master–slave map N (eq. 6 and 11) against finite differences of the
// slave configuration, and the geometric term d(N^T g)/d(x_m, theta_m, q) against finite
// differences of N^T g, for every kind of release (none, translations, one axis, two axes, free
// rotation, dependent linear / eccentric cam / periodic-spline cam), in a rotated master state
// with many turns of the released angle; and the periodic cubic spline (interpolation, C^2
// continuity, period, derivatives). For the mid-point schemes: the conserving map exact for finite
// steps and tending to N for vanishing ones, its geometric term d(Ntilde^T g)/d(x_m, theta_m, q)
// and dp/dq against finite differences at random finite steps, and the secant of a dependent
// translation (exact, smooth, and free of cancellation for small steps).
#include "joints/joint_kinematics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

using namespace msflex;

namespace {

struct Case {
  std::string   name;
  JointGeometry joint;
};

std::vector<double> spline_knots, spline_values, spline_second;

std::vector<Case> Cases()
{
  const Mat3    axes = ExpSO3(Vec3(0.3, -0.5, 0.8)); // a skewed joint frame
  JointGeometry base;
  base.axes   = axes;
  base.offset = Vec3(0.4, -0.2, 0.7);
  std::vector<Case> cases;
  auto              add = [&](const std::string &name, auto &&configure) {
    JointGeometry j = base;
    configure(j);
    cases.push_back({name, j});
  };
  add("rigid", [](JointGeometry &) {});
  add("revolute", [](JointGeometry &j) { j.rotation = JointRotation::OneAxis, j.rotation_axis[0] = 0; });
  add("universal", [](JointGeometry &j) { j.rotation = JointRotation::TwoAxes, j.rotation_axis[0] = 0, j.rotation_axis[1] = 1; });
  add("spherical", [](JointGeometry &j) { j.rotation = JointRotation::Free; });
  add("cylindrical", [](JointGeometry &j) { j.num_translations = 1, j.translation_axis[0] = 0, j.rotation = JointRotation::OneAxis; });
  add("prismatic", [](JointGeometry &j) { j.num_translations = 1, j.translation_axis[0] = 0; });
  add("planar", [](JointGeometry &j) { j.num_translations = 2, j.translation_axis[0] = 1, j.translation_axis[1] = 2, j.rotation = JointRotation::OneAxis; });
  add("free", [](JointGeometry &j) { j.num_translations = 3, j.rotation = JointRotation::Free; });
  add("screw",
      [](JointGeometry &j) { j.rotation = JointRotation::OneAxis, j.dependence = JointDependence::Linear, j.dependent_axis = 0, j.coefficient = 2.2918; });
  add("rack_pinion",
      [](JointGeometry &j) { j.rotation = JointRotation::OneAxis, j.dependence = JointDependence::Linear, j.dependent_axis = 1, j.coefficient = 0.35; });
  add("cam_eccentric",
      [](JointGeometry &j) { j.rotation = JointRotation::OneAxis, j.dependence = JointDependence::EccentricCam, j.dependent_axis = 1, j.coefficient = 0.3; });
  // A general cam: a lobe sampled at 12 unequal angles.
  spline_knots = {0.0, 0.4, 0.9, 1.3, 1.9, 2.5, 3.0, 3.6, 4.1, 4.8, 5.4, 5.9};
  spline_values.clear();
  for (double k : spline_knots) spline_values.push_back(0.2 * std::cos(k) + 0.05 * std::sin(2 * k));
  spline_second.assign(spline_knots.size(), 0.0);
  EXPECT_TRUE(PeriodicSplineSecondDerivatives(2 * M_PI, (int)spline_knots.size(), spline_knots.data(), spline_values.data(), spline_second.data()));
  add("cam_table", [](JointGeometry &j) {
    j.rotation = JointRotation::OneAxis, j.dependence = JointDependence::Table, j.dependent_axis = 2;
    j.profile = {2 * M_PI, (int)spline_knots.size(), spline_knots.data(), spline_values.data(), spline_second.data()};
  });
  return cases;
}

struct State {
  Vec3             x_m;
  Mat3             R_m;
  JointCoordinates q;
};

// Perturbation of column c of (x_m (3), theta_m (3), q (k)).
State Perturb(const State &s, int c, double h)
{
  State p = s;
  if (c < 3) p.x_m(c) += h;
  else if (c < 6) p.R_m = ExpSO3(h * Vec3::Unit(c - 3)) * p.R_m;
  else p.q.q[c - 6] += h;
  return p;
}

double MaxAbs(const Eigen::MatrixXd &m) { return m.cwiseAbs().maxCoeff(); }

} // namespace

TEST(JointKinematics, MapAndGeometricStiffnessMatchFiniteDifferences)
{
  std::mt19937                           gen(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Case &c : Cases()) {
    const int k = JointNumCoordinates(c.joint);
    State     s;
    s.x_m = Vec3(1.0, -2.0, 0.5);
    s.R_m = ExpSO3(Vec3(0.9, 0.4, -1.3));
    for (int i = 0; i < k; ++i) s.q.q[i] = 0.6 * u(gen);
    if (c.joint.rotation == JointRotation::OneAxis) s.q.q[c.joint.num_translations] = 7.9; // beyond one turn
    s.q.free_rotation_start = ExpSO3(Vec3(-0.2, 0.7, 0.1));
    JointMatrix N;
    JointMap(c.joint, s.q, s.R_m, &N);
    Eigen::Matrix<double, 6, 1> g;
    for (int i = 0; i < 6; ++i) g(i) = u(gen);
    JointSquare G;
    JointGeometricStiffness(c.joint, s.q, s.R_m, g, &G);
    const double    h = 1e-6;
    Eigen::MatrixXd N_fd(6, 6 + k), G_fd(6 + k, 6 + k);
    for (int col = 0; col < 6 + k; ++col) {
      const State p = Perturb(s, col, h), m = Perturb(s, col, -h);
      Vec3        xp, xm;
      Mat3        Rp, Rm;
      JointSlaveConfiguration(c.joint, p.q, p.x_m, p.R_m, &xp, &Rp);
      JointSlaveConfiguration(c.joint, m.q, m.x_m, m.R_m, &xm, &Rm);
      Vec3 x0;
      Mat3 R0;
      JointSlaveConfiguration(c.joint, s.q, s.x_m, s.R_m, &x0, &R0);
      N_fd.block<3, 1>(0, col) = (xp - xm) / (2 * h);
      N_fd.block<3, 1>(3, col) = Unskew((Rp - Rm) / (2 * h) * R0.transpose());
      JointMatrix Np, Nm;
      JointMap(c.joint, p.q, p.R_m, &Np);
      JointMap(c.joint, m.q, m.R_m, &Nm);
      G_fd.col(col) = ((Np.leftCols(6 + k).transpose() * g) - (Nm.leftCols(6 + k).transpose() * g)) / (2 * h);
    }
    const double n_error = MaxAbs(N_fd - N.leftCols(6 + k)) / MaxAbs(N.leftCols(6 + k));
    const double g_error = MaxAbs(G_fd - G.topLeftCorner(6 + k, 6 + k)) / std::max(1.0, MaxAbs(G.topLeftCorner(6 + k, 6 + k)));
    std::printf("joint %-14s k = %d: N FD error %.2e, geometric term FD error %.2e\n", c.name.c_str(), k, n_error, g_error);
    EXPECT_LT(n_error, 1e-7) << c.name;
    EXPECT_LT(g_error, 1e-7) << c.name;
  }
}

TEST(JointKinematics, DependentTranslationFollowsTheRotationExactly)
{
  for (const Case &c : Cases()) {
    if (c.joint.dependence == JointDependence::None) continue;
    JointCoordinates q;
    const Mat3       R_m = ExpSO3(Vec3(0.2, 0.3, -0.4));
    const Vec3       x_m(0.5, 0.1, -0.3);
    for (double phi : {-3.0, 0.7, 12.5, 40.0}) {
      q.q[0] = phi;
      Vec3 x_s;
      Mat3 R_s;
      JointSlaveConfiguration(c.joint, q, x_m, R_m, &x_s, &R_s);
      // Released translation in the joint frame: A^T (R_m^T (x_s - x_m) - d0).
      const Vec3 t = c.joint.axes.transpose() * (R_m.transpose() * (x_s - x_m) - c.joint.offset);
      double     f, df, ddf, f0, df0, ddf0;
      JointDependentTranslation(c.joint, phi, &f, &df, &ddf);
      JointDependentTranslation(c.joint, 0.0, &f0, &df0, &ddf0);
      EXPECT_NEAR(t(c.joint.dependent_axis), f - f0, 1e-12) << c.name;
      for (int i = 0; i < 3; ++i) {
        if (i != c.joint.dependent_axis) {
          EXPECT_NEAR(t(i), 0.0, 1e-12) << c.name;
        }
      }
      // and the released rotation is exactly phi about the axis
      const Mat3 C = R_m.transpose() * R_s;
      EXPECT_LT((C - ExpSO3(phi * c.joint.axes.col(c.joint.rotation_axis[0]))).cwiseAbs().maxCoeff(), 1e-12) << c.name;
    }
  }
}

TEST(PeriodicSpline, InterpolatesRepeatsAndIsTwiceContinuouslyDifferentiable)
{
  Cases(); // builds the spline of the cam_table case
  const PeriodicSpline s{2 * M_PI, (int)spline_knots.size(), spline_knots.data(), spline_values.data(), spline_second.data()};
  double               f, df, ddf;
  for (size_t i = 0; i < spline_knots.size(); ++i) {
    PeriodicSplineEvaluate(s, spline_knots[i], &f, &df, &ddf);
    EXPECT_NEAR(f, spline_values[i], 1e-14);
    double fl, dfl, ddfl, fr, dfr, ddfr; // both sides of the knot
    PeriodicSplineEvaluate(s, spline_knots[i] - 1e-9, &fl, &dfl, &ddfl);
    PeriodicSplineEvaluate(s, spline_knots[i] + 1e-9, &fr, &dfr, &ddfr);
    EXPECT_NEAR(fl, fr, 1e-8);
    EXPECT_NEAR(dfl, dfr, 1e-7);
    EXPECT_NEAR(ddfl, ddfr, 1e-6);
    double fp; // one period later
    PeriodicSplineEvaluate(s, spline_knots[i] + 2 * M_PI * 3, &fp, &df, &ddf);
    EXPECT_NEAR(fp, spline_values[i], 1e-12);
  }
  for (double phi : {0.2, 1.7, 3.3, 6.1, -2.0}) {
    double fp, dfp, ddfp, fm, dfm, ddfm;
    PeriodicSplineEvaluate(s, phi, &f, &df, &ddf);
    PeriodicSplineEvaluate(s, phi + 1e-6, &fp, &dfp, &ddfp);
    PeriodicSplineEvaluate(s, phi - 1e-6, &fm, &dfm, &ddfm);
    EXPECT_NEAR(df, (fp - fm) / 2e-6, 1e-7);
    EXPECT_NEAR(ddf, (dfp - dfm) / 2e-6, 1e-6);
  }
  // Many samples of cos reproduce cos to spline accuracy.
  std::vector<double> knots(64), values(64), second(64);
  for (int i = 0; i < 64; ++i) knots[i] = 2 * M_PI * i / 64, values[i] = std::cos(knots[i]);
  ASSERT_TRUE(PeriodicSplineSecondDerivatives(2 * M_PI, 64, knots.data(), values.data(), second.data()));
  const PeriodicSpline c{2 * M_PI, 64, knots.data(), values.data(), second.data()};
  PeriodicSplineEvaluate(c, 1.2345, &f, &df, &ddf);
  EXPECT_NEAR(f, std::cos(1.2345), 1e-6);
  EXPECT_NEAR(df, -std::sin(1.2345), 1e-4);
  // Knots out of order are refused.
  std::vector<double> bad = {0.0, 2.0, 1.0};
  EXPECT_FALSE(PeriodicSplineSecondDerivatives(2 * M_PI, 3, bad.data(), values.data(), second.data()));
}

// The conserving map of the mid-point schemes is exact for any step: the slave's displacement
// increment and tangent-scaled rotation increment equal Ntilde (u_m, alpha_m, p).
TEST(JointKinematics, ConservingMapIsExactForFiniteSteps)
{
  std::mt19937                           gen(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Case &c : Cases()) {
    const int        k = JointNumCoordinates(c.joint);
    JointCoordinates start;
    double           increment[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};
    for (int i = 0; i < k; ++i) start.q[i] = 0.8 * u(gen), increment[i] = 0.4 * u(gen);
    if (c.joint.rotation == JointRotation::Free) {
      start.free_rotation_start = ExpSO3(Vec3(0.3, -0.2, 0.6));
      for (int i = c.joint.num_translations; i < k; ++i) start.q[i] = 0.0; // a free rotation restarts from C_n
    }
    const Vec3       x_mn(0.2, 0.1, -0.3), u_m(0.05, -0.1, 0.08);
    const Mat3       R_mn = ExpSO3(Vec3(0.4, -0.7, 0.2));
    const Vec3       omega_m(0.3, 0.5, -0.2);
    const Mat3       R_m1 = ExpSO3(omega_m) * R_mn;
    JointCoordinates end  = start;
    for (int i = 0; i < k; ++i) end.q[i] += increment[i];
    Vec3 x_sn, x_s1;
    Mat3 R_sn, R_s1;
    JointSlaveConfiguration(c.joint, start, x_mn, R_mn, &x_sn, &R_sn);
    JointSlaveConfiguration(c.joint, end, x_mn + u_m, R_m1, &x_s1, &R_s1);
    const Vec3  alpha_m = TangentScaledFromRotationVector(omega_m);
    JointMatrix Nt;
    double      p[kJointMaxReleased];
    JointConservingMap(c.joint, start, increment, R_mn, alpha_m, x_sn - x_mn, x_s1 - x_mn - u_m, &Nt, p);
    Eigen::Matrix<double, 6 + kJointMaxReleased, 1> test = Eigen::Matrix<double, 6 + kJointMaxReleased, 1>::Zero();
    test.head<3>()                                       = u_m;
    test.segment<3>(3)                                   = alpha_m;
    for (int i = 0; i < k; ++i) test(6 + i) = p[i];
    const Eigen::Matrix<double, 6, 1> slave   = Nt * test;
    const Vec3                        alpha_s = TangentScaledFromRotationVector(LogSO3(R_s1 * R_sn.transpose()));
    const double                      u_error = (slave.head<3>() - (x_s1 - x_sn)).norm(), alpha_error = (slave.tail<3>() - alpha_s).norm();
    std::printf("joint %-14s conserving map: |u_s error| %.1e, |alpha_s error| %.1e\n", c.name.c_str(), u_error, alpha_error);
    EXPECT_LT(u_error, 1e-13) << c.name;
    EXPECT_LT(alpha_error, 1e-13) << c.name;
  }
}

namespace {

// A step of the mid-point schemes: the master's start (x_mn, Lambda_{m,n}) and end (x_m1,
// Lambda_{m,n+1}), the joint's start coordinates and increments.
struct Step {
  Vec3             x_mn, x_m1;
  Mat3             R_mn, R_m1;
  JointCoordinates start;
  double           increment[kJointMaxReleased] = {0, 0, 0, 0, 0, 0};
};

// The conserving map of a step, built as the assembler does: alpha_m from the master's rotations,
// the offsets from the joint kinematics at both ends.
void ConservingMapOf(const JointGeometry &joint, const Step &s, Vec3 *alpha_m, JointMatrix *Nt, double *p)
{
  const int        k   = JointNumCoordinates(joint);
  JointCoordinates end = s.start;
  for (int i = 0; i < k; ++i) end.q[i] += s.increment[i];
  Vec3 x_sn, x_s1;
  Mat3 R_sn, R_s1;
  JointSlaveConfiguration(joint, s.start, s.x_mn, s.R_mn, &x_sn, &R_sn);
  JointSlaveConfiguration(joint, end, s.x_m1, s.R_m1, &x_s1, &R_s1);
  *alpha_m = TangentScaledFromRotationVector(LogSO3(s.R_m1 * s.R_mn.transpose()));
  JointConservingMap(joint, s.start, s.increment, s.R_mn, *alpha_m, x_sn - s.x_mn, x_s1 - s.x_m1, Nt, p);
}

// Ntilde^T g (6 + k rows) of a step.
Eigen::VectorXd ConservingRows(const JointGeometry &joint, const Step &s, const Eigen::Matrix<double, 6, 1> &g)
{
  const int   k = JointNumCoordinates(joint);
  Vec3        alpha_m;
  JointMatrix Nt;
  double      p[kJointMaxReleased];
  ConservingMapOf(joint, s, &alpha_m, &Nt, p);
  return Nt.leftCols(6 + k).transpose() * g;
}

// Perturbation of column c of (x_m (3), theta_m (3) of the END rotation, dq (k)).
Step PerturbEnd(const Step &s, int c, double h)
{
  Step p = s;
  if (c < 3) p.x_m1(c) += h;
  else if (c < 6) p.R_m1 = ExpSO3(h * Vec3::Unit(c - 3)) * p.R_m1;
  else p.increment[c - 6] += h;
  return p;
}

// A random step: master rotations of about 1 rad at the start and over the step, released
// coordinates up to about 1 rad at the start and over the step, a non-zero C_n of a free
// rotation; `master_at_rest` makes it a joint to the ground (Lambda_m = I, alpha_m = 0).
Step RandomStep(const JointGeometry &joint, std::mt19937 &gen, bool master_at_rest)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int                              k = JointNumCoordinates(joint), nt = joint.num_translations;
  auto                                   random_vector = [&](double length) {
    const Vec3 v(u(gen), u(gen), u(gen));
    return Vec3(length * v.normalized());
  };
  Step s;
  s.x_mn = Vec3(u(gen), u(gen), u(gen));
  s.x_m1 = s.x_mn + 0.3 * Vec3(u(gen), u(gen), u(gen));
  s.R_mn = ExpSO3(random_vector(1.0 + 0.2 * u(gen)));
  s.R_m1 = ExpSO3(random_vector(0.9 + 0.2 * u(gen))) * s.R_mn;
  if (master_at_rest) s.R_mn = s.R_m1 = Mat3::Identity(), s.x_m1 = s.x_mn;
  for (int i = 0; i < k; ++i) {
    s.start.q[i]   = (i < nt ? 0.5 : 1.0) * u(gen);
    s.increment[i] = (i < nt ? 0.3 : 1.0) * u(gen);
  }
  if (joint.rotation == JointRotation::OneAxis) s.start.q[nt] += 6.0; // beyond one turn
  if (joint.rotation == JointRotation::Free) {
    s.start.free_rotation_start = ExpSO3(random_vector(1.1));
    const Vec3 w                = random_vector(0.6 + 0.4 * u(gen));
    for (int i = 0; i < 3; ++i) s.start.q[nt + i] = 0.0, s.increment[nt + i] = w(i); // a free rotation restarts from C_n
  }
  return s;
}

} // namespace

// The geometric term of the mid-point schemes, d(Ntilde^T g)/d(x_m, theta_m, q) at fixed g, and
// dp/dq against central differences of the conserving map, for every release kind at random
// finite steps (and at a joint to the ground).
TEST(JointKinematics, ConservingGeometricStiffnessMatchesFiniteDifferences)
{
  std::mt19937                           gen(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Case &c : Cases()) {
    const int k           = JointNumCoordinates(c.joint);
    double    worst_G     = 0.0;
    double    worst_dp_dq = 0.0;
    for (int trial = 0; trial < 4; ++trial) {
      const Step                  s = RandomStep(c.joint, gen, trial == 3);
      Eigen::Matrix<double, 6, 1> g;
      for (int i = 0; i < 6; ++i) g(i) = u(gen);
      Vec3        alpha_m;
      JointMatrix Nt;
      double      p[kJointMaxReleased];
      ConservingMapOf(c.joint, s, &alpha_m, &Nt, p);
      JointSquare G;
      JointConservingGeometricStiffness(c.joint, s.start, s.increment, s.R_mn, alpha_m, g, &G);
      JointReleasedMatrix dp_dq;
      JointReleasedTestDerivative(c.joint, s.increment, &dp_dq);
      const double    h = 1e-6;
      Eigen::MatrixXd G_fd(6 + k, 6 + k), dp_fd(k, k);
      for (int col = 0; col < 6 + k; ++col) {
        const Step plus = PerturbEnd(s, col, h), minus = PerturbEnd(s, col, -h);
        G_fd.col(col) = (ConservingRows(c.joint, plus, g) - ConservingRows(c.joint, minus, g)) / (2 * h);
        if (col < 6) continue;
        Vec3        a;
        JointMatrix N_plus, N_minus;
        double      p_plus[kJointMaxReleased], p_minus[kJointMaxReleased];
        ConservingMapOf(c.joint, plus, &a, &N_plus, p_plus);
        ConservingMapOf(c.joint, minus, &a, &N_minus, p_minus);
        for (int i = 0; i < k; ++i) dp_fd(i, col - 6) = (p_plus[i] - p_minus[i]) / (2 * h);
      }
      const Eigen::MatrixXd Ga = G.topLeftCorner(6 + k, 6 + k);
      worst_G                  = std::max(worst_G, MaxAbs(G_fd - Ga) / MaxAbs(Ga));
      if (k > 0) worst_dp_dq = std::max(worst_dp_dq, MaxAbs(dp_fd - dp_dq.topLeftCorner(k, k)) / MaxAbs(dp_fd));
    }
    std::printf("joint %-14s k = %d: conserving geometric term FD error %.2e, dp/dq FD error %.2e\n", c.name.c_str(), k, worst_G, worst_dp_dq);
    EXPECT_LT(worst_G, 1e-8) << c.name;
    EXPECT_LT(worst_dp_dq, 1e-8) << c.name;
  }
}

// The secant of a dependent translation: G tau = f(phi_{n+1}) - f(phi_n) for any step, dG/d(dphi)
// against central differences, and the limits G -> f'(phi_n), dG -> f''(phi_n)/2 of a vanishing
// step, where the plain quotient would cancel.
TEST(JointKinematics, DependentSecantIsExactAndSmooth)
{
  for (const Case &c : Cases()) {
    if (c.joint.dependence == JointDependence::None) continue;
    double worst = 0.0;
    for (double phi : {-2.3, 0.35, 0.4, 7.1}) // 0.4 is a knot of the tabulated cam
      for (double dphi : {0.0, 1e-12, -1e-9, 1e-5, 3e-3, -0.02, 0.45, -1.3, 2.9}) {
        double G, dG, f0, df0, ddf0, f1, df1, ddf1;
        JointDependentSecant(c.joint, phi, dphi, &G, &dG);
        JointDependentTranslation(c.joint, phi, &f0, &df0, &ddf0);
        JointDependentTranslation(c.joint, phi + dphi, &f1, &df1, &ddf1);
        const double tau = 2.0 * std::tan(0.5 * dphi);
        EXPECT_NEAR(G * tau, f1 - f0, 1e-14) << c.name << " phi " << phi << " dphi " << dphi;
        // Central differences about a knot (phi = 0.4, tiny dphi) straddle the jump of f''' and are
        // only first order there: the derivative is compared elsewhere.
        const double h = 1e-6;
        double       Gp, Gm, scratch;
        JointDependentSecant(c.joint, phi, dphi + h, &Gp, &scratch);
        JointDependentSecant(c.joint, phi, dphi - h, &Gm, &scratch);
        // (relative to the size of G: the differences of G round off at eps |G| / h).
        const double scale = std::max({1e-3, std::abs(G), std::abs(dG)});
        if (!(phi == 0.4 && std::abs(dphi) < 1e-4)) worst = std::max(worst, std::abs((Gp - Gm) / (2 * h) - dG) / scale);
        if (dphi == 0.0) {
          EXPECT_NEAR(G, df0, 1e-15) << c.name;
          EXPECT_NEAR(dG, 0.5 * ddf0, 1e-15) << c.name;
        } else if (std::abs(dphi) <= 1e-9) { // G = f' + f'' dphi / 2 + O(dphi^2), dG = f''/2 + O(dphi)
          EXPECT_NEAR(G, df0 + 0.5 * ddf0 * dphi, 1e-15) << c.name;
          EXPECT_NEAR(dG, 0.5 * ddf0, 1e-8) << c.name;
        }
      }
    std::printf("joint %-14s secant derivative FD error %.2e\n", c.name.c_str(), worst);
    EXPECT_LT(worst, 1e-8) << c.name;
  }
}

// The step `direction` scaled by `scale`: the master's translation and rotation (about omega_m)
// and the released increments.
Step ScaledStep(const JointGeometry &joint, const Step &direction, const Vec3 &omega_m, double scale)
{
  Step s = direction;
  s.x_m1 = s.x_mn + scale * (direction.x_m1 - direction.x_mn);
  s.R_m1 = ExpSO3(scale * omega_m) * s.R_mn;
  for (int i = 0; i < JointNumCoordinates(joint); ++i) s.increment[i] = scale * direction.increment[i];
  return s;
}

// Ntilde diag(I, dp/dq) of a step: the conserving map in the columns of N.
Eigen::MatrixXd ConservingMapInJointColumns(const JointGeometry &joint, const Step &s)
{
  const int   k = JointNumCoordinates(joint);
  Vec3        alpha_m;
  JointMatrix Nt;
  double      p[kJointMaxReleased];
  ConservingMapOf(joint, s, &alpha_m, &Nt, p);
  JointReleasedMatrix dp_dq;
  JointReleasedTestDerivative(joint, s.increment, &dp_dq);
  Eigen::MatrixXd chain = Eigen::MatrixXd::Identity(6 + k, 6 + k);
  if (k > 0) chain.bottomRightCorner(k, k) = dp_dq.topLeftCorner(k, k);
  return Nt.leftCols(6 + k) * chain;
}

// N at the step's end configuration.
Eigen::MatrixXd JointMapAtEnd(const JointGeometry &joint, const Step &s)
{
  const int        k   = JointNumCoordinates(joint);
  JointCoordinates end = s.start;
  for (int i = 0; i < k; ++i) end.q[i] += s.increment[i];
  JointMatrix N;
  JointMap(joint, end, s.R_m1, &N);
  return N.leftCols(6 + k);
}

// As the step vanishes the conserving map tends to N: Ntilde diag(I, dp/dq) = N exactly for an
// empty step and within O(step) otherwise.
TEST(JointKinematics, ConservingMapTendsToTheJointMap)
{
  std::mt19937 gen(23);
  for (const Case &c : Cases()) {
    const Step   direction = RandomStep(c.joint, gen, false);
    const Vec3   omega_m   = LogSO3(direction.R_m1 * direction.R_mn.transpose());
    double       error[3];
    const double scales[3] = {0.0, 1e-3, 1e-4};
    for (int e = 0; e < 3; ++e) {
      const Step            s = ScaledStep(c.joint, direction, omega_m, scales[e]);
      const Eigen::MatrixXd N = JointMapAtEnd(c.joint, s);
      error[e]                = MaxAbs(ConservingMapInJointColumns(c.joint, s) - N) / MaxAbs(N);
    }
    std::printf("joint %-14s |Ntilde dp/dq - N| / |N|: %.1e (empty step), %.1e (1e-3), %.1e (1e-4)\n", c.name.c_str(), error[0], error[1], error[2]);
    EXPECT_LT(error[0], 1e-14) << c.name;
    EXPECT_LT(error[1], 1e-2) << c.name;
    EXPECT_LT(error[2], 0.2 * error[1]) << c.name; // first order in the step
  }
}

// The mid-point schemes are second order only where the conserving map is centred on the step:
// Ntilde diag(I, dp/dq) equals the mean of N at the step's two ends to O(step^2), for every joint
// kind. (A universal joint's W taken at the end of the step, [a_i + tau_2 b x a_i / 2, b], was off
// by O(step) and made its motion first order under mc and em.)
TEST(JointKinematics, ConservingMapIsCentredOnTheStep)
{
  std::mt19937 gen(29);
  for (const Case &c : Cases()) {
    const int    k         = JointNumCoordinates(c.joint);
    const Step   direction = RandomStep(c.joint, gen, false);
    const Vec3   omega_m   = LogSO3(direction.R_m1 * direction.R_mn.transpose());
    double       error[2];
    const double scales[2] = {1e-2, 1e-3};
    for (int e = 0; e < 2; ++e) {
      const Step  s = ScaledStep(c.joint, direction, omega_m, scales[e]);
      JointMatrix N_start;
      JointMap(c.joint, s.start, s.R_mn, &N_start);
      // A free rotation's three columns span every direction whatever they are (the slave's moment
      // equations hold in full): only the master's and the translations' columns are compared.
      const int             columns = c.joint.rotation == JointRotation::Free ? 6 + c.joint.num_translations : 6 + k;
      const Eigen::MatrixXd mean    = 0.5 * (N_start.leftCols(columns) + JointMapAtEnd(c.joint, s).leftCols(columns));
      error[e]                      = MaxAbs(ConservingMapInJointColumns(c.joint, s).leftCols(columns) - mean) / MaxAbs(mean);
    }
    std::printf("joint %-14s |Ntilde dp/dq - (N_n + N_n+1)/2| / |N|: %.1e (1e-2), %.1e (1e-3)\n", c.name.c_str(), error[0], error[1]);
    EXPECT_LT(error[1], 0.02 * error[0] + 1e-14) << c.name; // second order in the step
  }
}

// The released rotation's step C(q + dq) C(q)^T from the increments alone equals the difference
// of the two rotations for every joint kind (to round-off at moderate angles), and stays smooth in
// dq after the coordinate has turned far: at q = 1000 rad, q + dq rounds to 1.1e-13 rad, while the
// step from dq alone follows a change of dq by 3e-14 rad.
TEST(JointKinematics, RotationStepFromTheIncrementsAlone)
{
  for (const Case &c : Cases()) {
    const JointGeometry &joint = c.joint;
    const int            nt = joint.num_translations, k = JointNumCoordinates(joint);
    JointCoordinates     start;
    double               increment[kJointMaxReleased] = {};
    for (int i = 0; i < k; ++i) start.q[i] = 0.3 + 0.2 * i, increment[i] = 0.05 - 0.02 * i;
    if (joint.rotation == JointRotation::Free) {
      start.free_rotation_start = ExpSO3(Vec3(0.2, -0.4, 0.1));
      for (int i = nt; i < k; ++i) start.q[i] = 0.0; // a free rotation starts every step at w = 0
    }
    JointCoordinates end = start;
    for (int i = 0; i < k; ++i) end.q[i] += increment[i];
    const Mat3 expected = JointReleasedRotation(joint, end) * JointReleasedRotation(joint, start).transpose();
    EXPECT_LT((JointRotationStep(joint, start, increment) - expected).cwiseAbs().maxCoeff(), 1e-15) << c.name;
    if (joint.rotation != JointRotation::OneAxis && joint.rotation != JointRotation::TwoAxes) continue;
    // Far along: q = 1000 rad on the rotation coordinates.
    for (int i = nt; i < k; ++i) start.q[i] = 1000.0 + i;
    const Mat3   step  = JointRotationStep(joint, start, increment);
    const double delta = 3e-14; // below the spacing of doubles near 1000 (1.1e-13)
    double       moved[kJointMaxReleased];
    std::copy(increment, increment + kJointMaxReleased, moved);
    moved[nt] += delta;
    const Mat3 nearby = JointRotationStep(joint, start, moved);
    // The first released angle turns the step by delta (to the few per cent by which the second
    // axis of a universal joint tilts that direction), where a rounded q + dq would turn it by 0
    // or by 1.1e-13.
    EXPECT_NEAR(LogSO3(nearby * step.transpose()).norm(), delta, 0.2 * delta) << c.name;
    // And it is still the rotation step: against the difference at the far angles, to their rounding.
    end = start;
    for (int i = 0; i < k; ++i) end.q[i] += increment[i];
    const Mat3 far_expected = JointReleasedRotation(joint, end) * JointReleasedRotation(joint, start).transpose();
    EXPECT_LT((step - far_expected).cwiseAbs().maxCoeff(), 1e-12) << c.name;
  }
}

// The slave offset's step b(q + dq) - b(q) from the increments alone: equal to the difference at
// moderate coordinates for every joint kind, and smooth in dq far along (translations at 5000 m,
// angles at 1000 rad, where q + dq rounds to 9e-13 and 1.1e-13).
TEST(JointKinematics, OffsetStepFromTheIncrementsAlone)
{
  for (const Case &c : Cases()) {
    const JointGeometry &joint = c.joint;
    const int            k     = JointNumCoordinates(joint);
    if (k == 0) continue;
    JointCoordinates start;
    double           increment[kJointMaxReleased] = {};
    for (int i = 0; i < k; ++i) start.q[i] = 0.3 + 0.2 * i, increment[i] = 0.05 - 0.02 * i;
    if (joint.rotation == JointRotation::Free)
      for (int i = joint.num_translations; i < k; ++i) start.q[i] = 0.0;
    JointCoordinates end = start;
    for (int i = 0; i < k; ++i) end.q[i] += increment[i];
    EXPECT_LT((JointOffsetStep(joint, start, increment) - (JointOffset(joint, end) - JointOffset(joint, start))).cwiseAbs().maxCoeff(), 1e-15) << c.name;
    // Far along: every coordinate moved by delta = 3e-14 changes the step linearly (by B delta, B =
    // db/dq), where a rounded q + dq would change it by 0 or by a whole spacing of doubles.
    if (joint.rotation == JointRotation::Free) continue; // its angles restart from 0 every step
    for (int i = 0; i < k; ++i) start.q[i] = i < joint.num_translations ? 5000.0 + i : 1000.0 + i;
    for (int i = 0; i < k; ++i) {
      const double delta = 3e-14;
      double       moved[kJointMaxReleased];
      std::copy(increment, increment + kJointMaxReleased, moved);
      moved[i] += delta;
      const Vec3 change = JointOffsetStep(joint, start, moved) - JointOffsetStep(joint, start, increment);
      // db/dq_i at the step's end, by a central difference of the step itself over 1e-6.
      double up[kJointMaxReleased], down[kJointMaxReleased];
      std::copy(increment, increment + kJointMaxReleased, up);
      std::copy(increment, increment + kJointMaxReleased, down);
      up[i] += 1e-6, down[i] -= 1e-6;
      const Vec3 slope = (JointOffsetStep(joint, start, up) - JointOffsetStep(joint, start, down)) / 2e-6;
      EXPECT_LT((change - delta * slope).norm(), 0.2 * delta * slope.norm() + 1e-16) << c.name << ", coordinate " << i;
    }
  }
}
