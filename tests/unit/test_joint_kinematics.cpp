// Joint kinematics: the master–slave map N (eq. 6 and 11) against finite differences of the
// slave configuration, and the geometric term d(N^T g)/d(x_m, theta_m, q) against finite
// differences of N^T g, for every kind of release (none, translations, one axis, two axes, free
// rotation, dependent linear / eccentric cam / periodic-spline cam), in a rotated master state
// with many turns of the released angle; and the periodic cubic spline (interpolation, C^2
// continuity, period, derivatives).
#include "joints/joint_kinematics.hpp"

#include <gtest/gtest.h>

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
