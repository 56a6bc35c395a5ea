// Beam kernel: analytic tangent against central finite differences of the residual in spin
// variables, objectivity (strains unchanged by a superposed rigid motion), the residual as the
// gradient of the strain energy, and the stress-free reference configuration.
// Cases: 2- and 3-node elements; straight and curved-and-twisted references; deformed states
// with large rigid rotation plus bending, shear, torsion and stretch.
#include "elements/beam.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdio>
#include <random>
#include <vector>

using namespace msflex;

namespace {

struct ElementCase {
  int               num_nodes;
  std::vector<Vec3> positions;
  std::vector<Mat3> triads;
};

// Helix-like curved and twisted reference: nodes on an arc of radius 2, triads following the
// tangent and twisting by 0.3 rad per node.
ElementCase CurvedTwistedReference(int num_nodes, double element_angle)
{
  ElementCase ec{num_nodes, {}, {}};
  for (int a = 0; a < num_nodes; ++a) {
    const double phi = element_angle * a / (num_nodes - 1);
    const Vec3   p(2.0 * std::sin(phi), 2.0 * (1 - std::cos(phi)), 0.1 * phi);
    const Vec3   t1 = Vec3(std::cos(phi), std::sin(phi), 0.05).normalized();
    Vec3         t2 = Vec3(-std::sin(phi), std::cos(phi), 0.0);
    t2              = (t2 - t2.dot(t1) * t1).normalized();
    Mat3 T;
    T.col(0) = t1;
    T.col(1) = t2;
    T.col(2) = t1.cross(t2);
    ec.positions.push_back(p);
    ec.triads.push_back(ExpSO3(0.3 * a * t1) * T);
  }
  return ec;
}

ElementCase StraightReference(int num_nodes, double length)
{
  ElementCase ec{num_nodes, {}, {}};
  for (int a = 0; a < num_nodes; ++a) {
    ec.positions.push_back(Vec3(length * a / (num_nodes - 1), 0, 0));
    ec.triads.push_back(Mat3::Identity());
  }
  return ec;
}

// A deformed state: large rigid rotation and translation plus random nodal perturbations.
ElementCase Deform(const ElementCase &ref, unsigned seed, double amplitude)
{
  std::mt19937                           gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Mat3                             Q = ExpSO3(Vec3(1.1, -0.7, 0.4));
  const Vec3                             t(3.0, -2.0, 1.0);
  ElementCase                            cur = ref;
  for (int a = 0; a < ref.num_nodes; ++a) {
    const Vec3 dx(u(gen), u(gen), u(gen)), dth(u(gen), u(gen), u(gen));
    cur.positions[a] = Q * ref.positions[a] + t + amplitude * dx;
    cur.triads[a]    = ExpSO3(amplitude * 2.0 * dth) * Q * ref.triads[a];
  }
  return cur;
}

const BeamSectionStiffness kSection{Vec3(1e4, 3e3, 5e3), Vec3(700, 400, 900)};

std::vector<double> Residual(const BeamElementReference &ref, const ElementCase &c)
{
  std::vector<double> r(6 * c.num_nodes);
  EXPECT_EQ(BeamInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r.data(), nullptr, nullptr, nullptr), BeamKernelStatus::Ok);
  return r;
}

// Perturb DOF j of the element: translations additively, rotations as a spin exp(h e_k) Lambda.
ElementCase Perturb(const ElementCase &c, int dof, double h)
{
  ElementCase p = c;
  const int   a = dof / 6, k = dof % 6;
  if (k < 3) p.positions[a](k) += h;
  else p.triads[a] = ExpSO3(h * Vec3::Unit(k - 3)) * p.triads[a];
  return p;
}

double TangentRelativeError(const BeamElementReference &ref, const ElementCase &c)
{
  const int           n = 6 * c.num_nodes;
  std::vector<double> r(n), K(n * n);
  EXPECT_EQ(BeamInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r.data(), K.data(), nullptr, nullptr), BeamKernelStatus::Ok);
  const double h        = 1e-6;
  double       max_diff = 0, max_entry = 0;
  for (int j = 0; j < n; ++j) {
    const std::vector<double> rp = Residual(ref, Perturb(c, j, h)), rm = Residual(ref, Perturb(c, j, -h));
    for (int i = 0; i < n; ++i) {
      const double fd = (rp[i] - rm[i]) / (2 * h);
      max_diff        = std::max(max_diff, std::abs(fd - K[i * n + j]));
      max_entry       = std::max(max_entry, std::abs(K[i * n + j]));
    }
  }
  return max_diff / max_entry;
}

} // namespace

class BeamKernel : public ::testing::TestWithParam<int> {};

TEST_P(BeamKernel, ReferenceConfigurationIsStressFree)
{
  const int nn = GetParam();
  for (const ElementCase &ec : {StraightReference(nn, 1.5), CurvedTwistedReference(nn, 0.6)}) {
    BeamElementReference ref;
    ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
    const std::vector<double> r = Residual(ref, ec);
    for (double v : r) EXPECT_NEAR(v, 0.0, 1e-10);
  }
}

TEST_P(BeamKernel, TangentMatchesFiniteDifferences)
{
  const int nn = GetParam();
  for (const ElementCase &ec : {StraightReference(nn, 1.5), CurvedTwistedReference(nn, 0.6)}) {
    BeamElementReference ref;
    ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
    for (unsigned seed = 1; seed <= 4; ++seed) {
      const double err = TangentRelativeError(ref, Deform(ec, seed, 0.25));
      RecordProperty("fd_relative_error_nodes" + std::to_string(nn) + "_seed" + std::to_string(seed), std::to_string(err));
      EXPECT_LT(err, 1e-6) << "nodes " << nn << " seed " << seed;
      std::printf("FD tangent relative error: %d nodes, seed %u: %.2e\n", nn, seed, err);
    }
  }
}

TEST_P(BeamKernel, StrainsAreInvariantUnderSuperposedRigidMotion)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  const ElementCase   deformed = Deform(ec, 7, 0.3);
  BeamGaussResults    base;
  std::vector<double> r(6 * nn);
  ASSERT_EQ(BeamInternalForces(ref, kSection, deformed.positions.data(), deformed.triads.data(), r.data(), nullptr, nullptr, &base), BeamKernelStatus::Ok);
  for (const Vec3 &axis : {Vec3(0, 0, 1), Vec3(1, 2, -1), Vec3(-3, 0.5, 2)}) {
    const Mat3  Q       = ExpSO3(axis.normalized() * 2.9);
    ElementCase rotated = deformed;
    for (int a = 0; a < nn; ++a) {
      rotated.positions[a] = Q * deformed.positions[a] + Vec3(100, -50, 25);
      rotated.triads[a]    = Q * deformed.triads[a];
    }
    BeamGaussResults moved;
    ASSERT_EQ(BeamInternalForces(ref, kSection, rotated.positions.data(), rotated.triads.data(), r.data(), nullptr, nullptr, &moved), BeamKernelStatus::Ok);
    for (int g = 0; g < ref.num_gauss; ++g) {
      EXPECT_LT((moved.strain[g] - base.strain[g]).norm(), 1e-12);
      EXPECT_LT((moved.curvature[g] - base.curvature[g]).norm(), 1e-12);
    }
  }
}

TEST_P(BeamKernel, ResidualIsTheGradientOfTheStrainEnergy)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  const ElementCase   c = Deform(ec, 11, 0.2);
  std::vector<double> r(6 * nn);
  ASSERT_EQ(BeamInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r.data(), nullptr, nullptr, nullptr), BeamKernelStatus::Ok);
  auto energy = [&](const ElementCase &e) {
    double              w;
    std::vector<double> tmp(6 * nn);
    BeamInternalForces(ref, kSection, e.positions.data(), e.triads.data(), tmp.data(), nullptr, &w, nullptr);
    return w;
  };
  const double h = 1e-6;
  for (int j = 0; j < 6 * nn; ++j) {
    const double fd = (energy(Perturb(c, j, h)) - energy(Perturb(c, j, -h))) / (2 * h);
    EXPECT_NEAR(r[j], fd, 1e-6 * (1 + std::abs(fd)));
  }
}

INSTANTIATE_TEST_SUITE_P(TwoAndThreeNodes, BeamKernel, ::testing::Values(2, 3));

// Mid-point (mc/em) internal forces: no net force and no net moment about the mid-point
// configuration (momentum conservation), equal to the static residual when the step is empty,
// symmetric in the two ends (the correction antisymmetric), and a work that approximates the
// change of strain energy to third order in the step (so em's beta stays small).
TEST_P(BeamKernel, MidpointForcesConserveMomentumAndApproximateTheEnergyChange)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  const ElementCase start = Deform(ec, 21, 0.2);
  auto              step  = [&](double scale, std::vector<Vec3> *u, std::vector<Vec3> *omega) {
    ElementCase                            end = start;
    std::mt19937                           gen(5);
    std::uniform_real_distribution<double> d(-1.0, 1.0);
    u->assign(nn, Vec3::Zero());
    omega->assign(nn, Vec3::Zero());
    for (int a = 0; a < nn; ++a) {
      (*u)[a]          = scale * Vec3(d(gen), d(gen), d(gen));
      (*omega)[a]      = scale * Vec3(d(gen), d(gen), d(gen));
      end.positions[a] = start.positions[a] + (*u)[a];
      end.triads[a]    = ExpSO3((*omega)[a]) * start.triads[a];
    }
    return end;
  };
  std::vector<double> f_mc(6 * nn), f_corr(6 * nn), back_mc(6 * nn), back_corr(6 * nn), r(6 * nn);
  double              energy_n, energy_1;
  std::vector<Vec3>   u, omega;
  const ElementCase   end = step(0.05, &u, &omega);
  ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, start.positions.data(), start.triads.data(), end.positions.data(), end.triads.data(), f_mc.data(),
                                       f_corr.data(), &energy_n, &energy_1),
            BeamKernelStatus::Ok);
  for (const std::vector<double> *f : {&f_mc, &f_corr}) {
    Vec3   force = Vec3::Zero(), moment = Vec3::Zero();
    double scale = 0;
    for (int a = 0; a < nn; ++a) {
      const Vec3 fa(&(*f)[6 * a]), ma(&(*f)[6 * a + 3]);
      const Vec3 x_mid = 0.5 * (start.positions[a] + end.positions[a]);
      force += fa;
      moment += x_mid.cross(fa) + ma;
      scale = std::max({scale, fa.norm() * (1 + x_mid.norm()), ma.norm()});
    }
    EXPECT_LT(force.norm(), 1e-12 * scale);
    EXPECT_LT(moment.norm(), 1e-12 * scale);
  }
  // Time reversal: the same forces for the reversed step, the correction with opposite sign.
  ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, end.positions.data(), end.triads.data(), start.positions.data(), start.triads.data(), back_mc.data(),
                                       back_corr.data(), nullptr, nullptr),
            BeamKernelStatus::Ok);
  for (int i = 0; i < 6 * nn; ++i) {
    EXPECT_NEAR(back_mc[i], f_mc[i], 1e-10 * (1 + std::abs(f_mc[i])));
    EXPECT_NEAR(back_corr[i], -f_corr[i], 1e-10 * (1 + std::abs(f_corr[i])));
  }
  // An empty step gives the static residual.
  ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, start.positions.data(), start.triads.data(), start.positions.data(), start.triads.data(), f_mc.data(),
                                       f_corr.data(), nullptr, nullptr),
            BeamKernelStatus::Ok);
  ASSERT_EQ(BeamInternalForces(ref, kSection, start.positions.data(), start.triads.data(), r.data(), nullptr, nullptr, nullptr), BeamKernelStatus::Ok);
  for (int i = 0; i < 6 * nn; ++i) EXPECT_NEAR(f_mc[i], r[i], 1e-11 * (1 + std::abs(r[i])));
  // Work (u, alpha) . F_mc versus the change of strain energy: error O(step^3).
  double mismatch[2];
  for (int k = 0; k < 2; ++k) {
    const ElementCase e = step(0.02 / (1 << k), &u, &omega);
    BeamMidpointInternalForces(ref, kSection, start.positions.data(), start.triads.data(), e.positions.data(), e.triads.data(), f_mc.data(), f_corr.data(),
                               &energy_n, &energy_1);
    double work = 0;
    for (int a = 0; a < nn; ++a) work += u[a].dot(Vec3(&f_mc[6 * a])) + TangentScaledFromRotationVector(omega[a]).dot(Vec3(&f_mc[6 * a + 3]));
    mismatch[k] = std::abs(work - (energy_1 - energy_n));
  }
  std::printf("mid-point work vs strain energy change, %d nodes: %.3e, %.3e (ratio %.2f)\n", nn, mismatch[0], mismatch[1], mismatch[0] / mismatch[1]);
  EXPECT_GT(mismatch[0] / mismatch[1], 6.0);
}
