// The kernels that the force contributors compose besides the beam and the scheme's inertia:
// consistent translational inertia and line loads of a beam element, nodal dead and follower
// loads, the weight of an offset point, the initial-acceleration problem's inertia, and the
// massless groups' equations. Tangents against central finite differences (spin variations of the
// end rotation: Lambda -> exp(hat(h e_k)) Lambda; accelerations where those are the unknowns),
// residuals against their closed forms.
#include "elements/beam_mass.hpp"
#include "elements/inertia.hpp"
#include "elements/loads.hpp"
#include "elements/massless.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

using namespace msflex;

namespace {

std::mt19937 generator(11);
Vec3         RandomVector(double scale)
{
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Vec3(u(generator), u(generator), u(generator));
}

double RelativeError(const Eigen::MatrixXd &analytic, const Eigen::MatrixXd &numeric)
{
  return (analytic - numeric).cwiseAbs().maxCoeff() / std::max(1e-300, analytic.cwiseAbs().maxCoeff());
}

// A 3-node curved element's reference data.
BeamElementReference CurvedReference()
{
  const Vec3 x[3] = {Vec3(0, 0, 0), Vec3(0.5, 0.1, 0.02), Vec3(1.0, 0.15, 0.1)};
  Mat3       T[3];
  for (int a = 0; a < 3; ++a) T[a] = ExpSO3(Vec3(0.0, 0.0, 0.2 * a));
  BeamElementReference ref;
  EXPECT_EQ(BeamElementSetup(3, x, T, &ref), BeamKernelStatus::Ok);
  return ref;
}

} // namespace

TEST(ElementKernels, ConsistentInertiaIsTheMassMatrixTimesTheCoefficient)
{
  const BeamElementReference ref  = CurvedReference();
  const double               rhoA = 2.5, coefficient = 400.0;
  Vec3                       accelerations[3];
  for (Vec3 &a : accelerations) a = RandomVector(3.0);
  double residual[18] = {0}, tangent[18 * 18] = {0};
  BeamConsistentInertia(ref, rhoA, accelerations, coefficient, residual, tangent);
  // The residual: rhoA M a; the tangent: c rhoA M on the translational blocks, zero elsewhere.
  double total_mass = 0.0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) total_mass += rhoA * ref.mass_shape[a][b];
  EXPECT_NEAR(total_mass, rhoA * ref.length, 1e-12 * rhoA * ref.length); // partition of unity
  for (int a = 0; a < 3; ++a) {
    Vec3 expected = Vec3::Zero();
    for (int b = 0; b < 3; ++b) expected += rhoA * ref.mass_shape[a][b] * accelerations[b];
    EXPECT_LT((Vec3(&residual[6 * a]) - expected).norm(), 1e-13 * expected.norm());
    EXPECT_EQ(Vec3(&residual[6 * a + 3]).norm(), 0.0);
  }
  // Finite differences in the accelerations (the residual is linear: d residual = K da / c).
  Eigen::MatrixXd numeric(18, 18);
  numeric.setZero();
  const double h = 1e-3;
  for (int b = 0; b < 3; ++b)
    for (int k = 0; k < 3; ++k) {
      double plus[18] = {0}, minus[18] = {0};
      Vec3   shifted[3] = {accelerations[0], accelerations[1], accelerations[2]};
      shifted[b](k) += h;
      BeamConsistentInertia(ref, rhoA, shifted, coefficient, plus, nullptr);
      shifted[b](k) -= 2 * h;
      BeamConsistentInertia(ref, rhoA, shifted, coefficient, minus, nullptr);
      for (int i = 0; i < 18; ++i) numeric(i, 6 * b + k) = coefficient * (plus[i] - minus[i]) / (2 * h);
    }
  const Eigen::MatrixXd analytic = Eigen::Map<Eigen::Matrix<double, 18, 18, Eigen::RowMajor>>(tangent);
  EXPECT_LT(RelativeError(analytic, numeric), 1e-10);
}

TEST(ElementKernels, LineLoadIsConsistentAndTranslatesMomenta)
{
  const BeamElementReference ref          = CurvedReference();
  const Vec3                 q            = RandomVector(5.0);
  double                     residual[18] = {0};
  BeamLineLoad(ref, q, residual);
  // The nodal forces add up to the load on the element: -q * length.
  Vec3 total = Vec3::Zero();
  for (int a = 0; a < 3; ++a) total += Vec3(&residual[6 * a]);
  EXPECT_LT((total + ref.length * q).norm(), 1e-12 * ref.length * q.norm());
  // Quadratic Lagrange elements give the end nodes 1/6 and the middle node 2/3 of a straight
  // element's load; the curved element is close.
  EXPECT_NEAR(ref.nodal_length[1] / ref.length, 2.0 / 3.0, 2e-2);
}

TEST(ElementKernels, NodalLoadTangentMatchesFiniteDifferences)
{
  NodalLoadValues load;
  load.dead_force_start      = RandomVector(2.0);
  load.dead_moment_start     = RandomVector(2.0);
  load.dead_force_end        = RandomVector(2.0);
  load.dead_moment_end       = RandomVector(2.0);
  load.follower_force_start  = RandomVector(3.0);
  load.follower_moment_start = RandomVector(3.0);
  load.follower_force_end    = RandomVector(3.0);
  load.follower_moment_end   = RandomVector(3.0);
  const Mat3 R_start = ExpSO3(RandomVector(1.0)), R_end = ExpSO3(RandomVector(1.5)) * R_start;
  for (const auto &[w0, w1] : {std::pair<double, double>{0.0, 1.0}, {0.5, 0.5}}) {
    Vec6 r;
    Mat6 K;
    NodalLoadForces(load, w0, w1, R_start, R_end, &r, &K);
    EXPECT_LT((r.head<3>() + w0 * (load.dead_force_start + R_start * load.follower_force_start) + w1 * (load.dead_force_end + R_end * load.follower_force_end))
                  .norm(),
              1e-13);
    Eigen::Matrix<double, 6, 6> numeric;
    const double                h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vec6 plus, minus;
      if (k < 3) { // dead and follower loads do not depend on the position
        numeric.col(k).setZero();
        continue;
      }
      NodalLoadForces(load, w0, w1, R_start, ExpSO3(h * Vec3::Unit(k - 3)) * R_end, &plus, nullptr);
      NodalLoadForces(load, w0, w1, R_start, ExpSO3(-h * Vec3::Unit(k - 3)) * R_end, &minus, nullptr);
      numeric.col(k) = (plus - minus) / (2 * h);
    }
    EXPECT_LT(RelativeError(K, numeric), 1e-8) << "weights " << w0 << ", " << w1;
  }
}

TEST(ElementKernels, OffsetPointWeightTangentMatchesFiniteDifferences)
{
  const Vec3 weight = RandomVector(20.0), c = RandomVector(0.5);
  const Mat3 R_start = ExpSO3(RandomVector(1.0)), R_end = ExpSO3(RandomVector(1.0)) * R_start;
  for (const auto &[a0, a1] : {std::pair<double, double>{0.0, 1.0}, {0.5, 0.5}, {1.0, 0.0}}) {
    Vec6 r;
    Mat6 K;
    OffsetPointWeight(weight, R_start * c, R_end * c, a0, a1, &r, &K);
    EXPECT_LT((r.tail<3>() + (a0 * R_start * c + a1 * R_end * c).cross(weight)).norm(), 1e-12);
    Eigen::Matrix<double, 6, 6> numeric = Eigen::Matrix<double, 6, 6>::Zero();
    const double                h       = 1e-6;
    for (int k = 3; k < 6; ++k) {
      Vec6 plus, minus;
      OffsetPointWeight(weight, R_start * c, ExpSO3(h * Vec3::Unit(k - 3)) * R_end * c, a0, a1, &plus, nullptr);
      OffsetPointWeight(weight, R_start * c, ExpSO3(-h * Vec3::Unit(k - 3)) * R_end * c, a0, a1, &minus, nullptr);
      numeric.col(k) = (plus - minus) / (2 * h);
    }
    if (a1 == 0.0) EXPECT_EQ(K.norm(), 0.0);
    else EXPECT_LT(RelativeError(K, numeric), 1e-8) << "arm weights " << a0 << ", " << a1;
  }
}

TEST(ElementKernels, InitialAccelerationInertiaTangentsAreTheMassMatrices)
{
  const Mat3 Q = ExpSO3(RandomVector(2.0));
  const Mat3 J = Q * Vec3(2.0, 1.3, 0.7).asDiagonal() * Q.transpose();
  const Mat3 R = ExpSO3(RandomVector(1.5));
  const Vec3 W = RandomVector(2.0), wdot = RandomVector(3.0);
  Vec3       moment;
  Mat3       tangent;
  InitialRotationalInertia(J, R, W, wdot, &moment, &tangent);
  // The equation of motion of a rotating body: R (J Wdot + W x J W), Wdot = R^T wdot.
  EXPECT_LT((moment - R * (J * (R.transpose() * wdot) + W.cross(J * W))).norm(), 1e-12 * moment.norm());
  Mat3         numeric;
  const double h = 1e-5;
  for (int k = 0; k < 3; ++k) {
    Vec3 plus, minus;
    InitialRotationalInertia(J, R, W, wdot + h * Vec3::Unit(k), &plus, nullptr);
    InitialRotationalInertia(J, R, W, wdot - h * Vec3::Unit(k), &minus, nullptr);
    numeric.col(k) = (plus - minus) / (2 * h);
  }
  EXPECT_LT(RelativeError(tangent, numeric), 1e-9);

  const double mass = 3.0;
  const Vec3   r = RandomVector(0.7), w = RandomVector(2.0), a = RandomVector(4.0);
  Vec6         residual;
  Mat6         K;
  InitialOffsetPointMassInertia(mass, r, w, a, wdot, &residual, &K);
  const Vec3 a_c = a + wdot.cross(r) + w.cross(w.cross(r));
  EXPECT_LT((residual.head<3>() - mass * a_c).norm(), 1e-12 * mass * a_c.norm());
  EXPECT_LT((residual.tail<3>() - r.cross(mass * a_c)).norm(), 1e-12 * mass * a_c.norm());
  Eigen::Matrix<double, 6, 6> numeric6;
  for (int k = 0; k < 6; ++k) {
    Vec6       plus, minus;
    const Vec3 da = k < 3 ? Vec3(h * Vec3::Unit(k)) : Vec3::Zero(), dw = k < 3 ? Vec3::Zero() : Vec3(h * Vec3::Unit(k - 3));
    InitialOffsetPointMassInertia(mass, r, w, a + da, wdot + dw, &plus, nullptr);
    InitialOffsetPointMassInertia(mass, r, w, a - da, wdot - dw, &minus, nullptr);
    numeric6.col(k) = (plus - minus) / (2 * h);
  }
  EXPECT_LT(RelativeError(K, numeric6), 1e-9);
  // The mass matrix of a point at r is symmetric positive semi-definite.
  EXPECT_LT((K - K.transpose()).norm(), 1e-12 * K.norm());
}

TEST(ElementKernels, MasslessGroupsGetZeroAcceleration)
{
  const Vec3     a = RandomVector(1.0), wdot = RandomVector(1.0);
  NodeMassGroups groups[2];
  groups[0].translational = false, groups[0].rotary = true;
  groups[1].translational = true, groups[1].rotary = false;
  double residual[12];
  for (double &value : residual) value = 7.0;
  DropMasslessRows(2, groups, residual);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(residual[i], 0.0);     // node 0's translations dropped
    EXPECT_EQ(residual[3 + i], 7.0); // its rotations kept
    EXPECT_EQ(residual[6 + i], 7.0); // node 1's translations kept
    EXPECT_EQ(residual[9 + i], 0.0); // its rotations dropped
  }
  double node_residual[6], tangent[36];
  for (double &value : node_residual) value = 5.0;
  for (double &value : tangent) value = 3.0;
  SetMasslessEquations(groups[0], a, wdot, node_residual, tangent);
  // Rows of the translations: r = a, dr/da = I; the rotations' rows untouched.
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(node_residual[i], a(i));
    EXPECT_EQ(node_residual[3 + i], 5.0);
    for (int j = 0; j < 6; ++j) {
      EXPECT_EQ(tangent[i * 6 + j], i == j ? 1.0 : 0.0);
      EXPECT_EQ(tangent[(3 + i) * 6 + j], 3.0);
    }
  }
}
