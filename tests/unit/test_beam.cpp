// Beam kernel: analytic tangent against central finite differences of the residual in spin
// variables, objectivity (strains unchanged by a superposed rigid motion), the residual as the
// gradient of the strain energy, and the stress-free reference configuration.
// Mid-point (mc/em) forces: momentum conservation, time reversal, the exact tangents K_mc and
// K_corr with respect to the end of the step against central differences, r_{n+1} against the
// end-point kernel, and em's beta and its linearisation.
// Cases: 2- and 3-node elements; straight and curved-and-twisted references; deformed states
// with large rigid rotation plus bending, shear, torsion and stretch.
#include "elements/beam.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <utility>
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

TEST_P(BeamKernel, AddingKernelAddsWhatTheKernelWrites)
{
  // BeamAddInternalForces adds r and K into arrays that already hold something: the sums are the
  // prefilled values plus BeamInternalForces' outputs, bit for bit on a zero start.
  const int            nn = GetParam(), n = 6 * nn;
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6), c = Deform(ec, 3, 0.25);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  std::vector<double> r(n), K(n * n), r_sum(n, 0.0), K_sum(n * n, 0.0);
  double              energy = 0.0, energy_added = 0.0;
  ASSERT_EQ(BeamInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r.data(), K.data(), &energy, nullptr), BeamKernelStatus::Ok);
  ASSERT_EQ(BeamAddInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r_sum.data(), K_sum.data(), &energy_added), BeamKernelStatus::Ok);
  EXPECT_TRUE(r_sum == r);
  EXPECT_TRUE(K_sum == K);
  EXPECT_EQ(energy_added, energy);
  // On arrays already holding values: those values plus the kernel's, to round-off.
  for (int i = 0; i < n; ++i) r_sum[i] = 1.0 + i;
  for (int i = 0; i < n * n; ++i) K_sum[i] = 0.5 * i;
  ASSERT_EQ(BeamAddInternalForces(ref, kSection, c.positions.data(), c.triads.data(), r_sum.data(), K_sum.data(), &energy_added), BeamKernelStatus::Ok);
  double scale = 0.0;
  for (double v : K) scale = std::max(scale, std::abs(v));
  for (int i = 0; i < n; ++i) EXPECT_NEAR(r_sum[i], 1.0 + i + r[i], 1e-12 * (1.0 + std::abs(r[i]))) << i;
  for (int i = 0; i < n * n; ++i) EXPECT_NEAR(K_sum[i], 0.5 * i + K[i], 1e-14 * scale) << i;
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

// ---------------------------------------------------------------------------------------------
// Mid-point forces: the exact tangent with respect to the end of the step.

namespace {

// A deformed state from a reference: stretch along the chord, transverse shear, twist and bending
// of the triads growing linearly along the element, random nodal noise, then a rigid rotation
// Q and a translation t.
struct Deformation {
  double   stretch = 0, shear = 0, twist = 0, bend = 0, noise = 0;
  unsigned seed = 1;
  Mat3     Q    = Mat3::Identity();
  Vec3     t    = Vec3::Zero();
};

ElementCase Deformed(const ElementCase &ref, const Deformation &d)
{
  std::mt19937                           gen(d.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ElementCase                            cur = ref;
  for (int a = 0; a < ref.num_nodes; ++a) {
    const double s = double(a) / (ref.num_nodes - 1);
    Vec3         x = ref.positions[0] + (1.0 + d.stretch) * (ref.positions[a] - ref.positions[0]) + d.shear * s * ref.triads[0].col(1);
    Mat3         T = ref.triads[a] * ExpSO3(Vec3(d.twist * s, d.bend * s, 0.0));
    const Vec3   dx(u(gen), u(gen), u(gen)), dth(u(gen), u(gen), u(gen));
    x += d.noise * dx;
    T                = ExpSO3(d.noise * dth) * T;
    cur.positions[a] = d.Q * x + d.t;
    cur.triads[a]    = d.Q * T;
  }
  return cur;
}

struct StepCase {
  std::string name;
  ElementCase start, end;
};

// Steps with a large rigid rotation between n and n+1, bending, torsion, shear and stretch, and a
// random deformation at both ends (rotation increments up to about 1 rad).
std::vector<StepCase> MidpointStepCases(const ElementCase &ref)
{
  const Mat3  Q0 = ExpSO3(Vec3(0.3, -0.2, 0.1));
  Deformation mild;
  mild.stretch = 0.02, mild.shear = 0.03, mild.twist = 0.2, mild.bend = 0.3, mild.noise = 0.05, mild.seed = 1, mild.Q = Q0, mild.t = Vec3(0.5, 1.0, -0.3);
  std::vector<StepCase> cases;
  auto add = [&](const char *name, const Deformation &start, const Deformation &end) { cases.push_back({name, Deformed(ref, start), Deformed(ref, end)}); };
  Deformation end = mild;
  end.noise = 0.02, end.seed = 2, end.Q = ExpSO3(Vec3(0.6, 0.8, 0.0)) * Q0, end.t = mild.t + Vec3(0.2, -0.1, 0.3); // 1 rad rigid rotation
  add("rigid rotation 1 rad", mild, end);
  end      = mild;
  end.bend = 0.9, end.Q = ExpSO3(Vec3(0.0, 0.1, 0.2)) * Q0;
  add("bending", mild, end);
  end       = mild;
  end.twist = 0.9, end.Q = ExpSO3(Vec3(0.2, 0.0, -0.1)) * Q0;
  add("torsion", mild, end);
  end         = mild;
  end.stretch = 0.08, end.shear = 0.15, end.seed = 5, end.Q = ExpSO3(Vec3(0.1, -0.3, 0.2)) * Q0, end.t = mild.t + Vec3(0.05, 0.05, 0.0);
  add("shear and stretch", mild, end);
  Deformation random_start, random_end;
  random_start.noise = 0.25, random_start.seed = 3, random_start.Q = Q0;
  random_end.noise = 0.25, random_end.seed = 4, random_end.Q = ExpSO3(Vec3(-0.5, 0.4, 0.6)) * Q0, random_end.t = Vec3(0.1, 0.2, 0.3);
  add("random, 0.9 rad rigid rotation", random_start, random_end);
  return cases;
}

struct MidpointResult {
  std::vector<double> mc, corr, tangent_mc, tangent_corr, end_residual;
  double              energy_start = 0, energy_end = 0;
};

MidpointResult Midpoint(const BeamElementReference &ref, const ElementCase &start, const ElementCase &end, bool with_tangent)
{
  const int      n = 6 * start.num_nodes;
  MidpointResult r;
  r.mc.resize(n), r.corr.resize(n), r.end_residual.resize(n);
  if (with_tangent) r.tangent_mc.resize(n * n), r.tangent_corr.resize(n * n);
  EXPECT_EQ(BeamMidpointInternalForces(ref, kSection, start.positions.data(), start.triads.data(), end.positions.data(), end.triads.data(), r.mc.data(),
                                       r.corr.data(), with_tangent ? r.tangent_mc.data() : nullptr, with_tangent ? r.tangent_corr.data() : nullptr,
                                       r.end_residual.data(), &r.energy_start, &r.energy_end),
            BeamKernelStatus::Ok);
  return r;
}

// max |K - K_fd| / max |K| for K_mc and K_corr, central differences in the end configuration.
void MidpointTangentErrors(const BeamElementReference &ref, const StepCase &s, const MidpointResult &exact, double *error_mc, double *error_corr)
{
  const int    n       = 6 * s.start.num_nodes;
  const double h       = 1e-6;
  double       diff_mc = 0, diff_corr = 0, max_mc = 0, max_corr = 0;
  for (int j = 0; j < n; ++j) {
    const MidpointResult p = Midpoint(ref, s.start, Perturb(s.end, j, h), false), m = Midpoint(ref, s.start, Perturb(s.end, j, -h), false);
    for (int i = 0; i < n; ++i) {
      diff_mc   = std::max(diff_mc, std::abs((p.mc[i] - m.mc[i]) / (2 * h) - exact.tangent_mc[i * n + j]));
      diff_corr = std::max(diff_corr, std::abs((p.corr[i] - m.corr[i]) / (2 * h) - exact.tangent_corr[i * n + j]));
      max_mc    = std::max(max_mc, std::abs(exact.tangent_mc[i * n + j]));
      max_corr  = std::max(max_corr, std::abs(exact.tangent_corr[i * n + j]));
    }
  }
  *error_mc   = diff_mc / max_mc;
  *error_corr = diff_corr / max_corr;
}

// Net force and net moment about the mid-point configuration x_{n+1/2} of a force vector, and of
// its derivative with respect to each end variable (d/dx_b of sum x_mid x f picks up f_b x e/2).
double MidpointNetForceAndMoment(const StepCase &s, const std::vector<double> &f, const std::vector<double> &K, double *tangent_net)
{
  const int nn = s.start.num_nodes, n = 6 * nn;
  Vec3      force = Vec3::Zero(), moment = Vec3::Zero();
  double    scale = 0, tangent_scale = 0;
  *tangent_net = 0;
  for (int a = 0; a < nn; ++a) {
    const Vec3 x_mid = 0.5 * (s.start.positions[a] + s.end.positions[a]), fa(&f[6 * a]), ma(&f[6 * a + 3]);
    force += fa;
    moment += x_mid.cross(fa) + ma;
    scale = std::max({scale, fa.norm() * (1 + x_mid.norm()), ma.norm()});
  }
  for (int j = 0; j < n; ++j) {
    Vec3 dforce = Vec3::Zero(), dmoment = Vec3::Zero();
    if (j % 6 < 3) dmoment += 0.5 * Vec3::Unit(j % 6).cross(Vec3(&f[6 * (j / 6)]));
    for (int a = 0; a < nn; ++a) {
      const Vec3 x_mid = 0.5 * (s.start.positions[a] + s.end.positions[a]);
      const Vec3 dfa(K[(6 * a) * n + j], K[(6 * a + 1) * n + j], K[(6 * a + 2) * n + j]);
      const Vec3 dma(K[(6 * a + 3) * n + j], K[(6 * a + 4) * n + j], K[(6 * a + 5) * n + j]);
      dforce += dfa;
      dmoment += x_mid.cross(dfa) + dma;
      tangent_scale = std::max({tangent_scale, dfa.norm() * (1 + x_mid.norm()), dma.norm()});
    }
    *tangent_net = std::max(*tangent_net, std::max(dforce.norm(), dmoment.norm()));
  }
  *tangent_net /= tangent_scale;
  return std::max(force.norm(), moment.norm()) / scale;
}

// Increments of a step: u_a = x_{a,n+1} - x_{a,n} and alpha_a, the tangent-scaled vector of
// Lambda_{a,n+1} Lambda_{a,n}^T (Lambda_{n+1} = cay(alpha) Lambda_n).
void StepIncrements(const StepCase &s, std::vector<Vec3> *u, std::vector<Vec3> *alpha)
{
  u->resize(s.start.num_nodes), alpha->resize(s.start.num_nodes);
  for (int a = 0; a < s.start.num_nodes; ++a) {
    (*u)[a]     = s.end.positions[a] - s.start.positions[a];
    (*alpha)[a] = TangentScaledFromRotationVector(LogSO3(s.end.triads[a] * s.start.triads[a].transpose()));
  }
}

double IncrementWork(const std::vector<Vec3> &u, const std::vector<Vec3> &alpha, const std::vector<double> &f)
{
  double w = 0;
  for (size_t a = 0; a < u.size(); ++a) w += u[a].dot(Vec3(&f[6 * a])) + alpha[a].dot(Vec3(&f[6 * a + 3]));
  return w;
}

// em's beta of eq. (20) for one element without inertia: the work of F_mc + beta F_corr equals the
// change of strain energy.
double ElementBeta(const BeamElementReference &ref, const StepCase &s)
{
  std::vector<Vec3> u, alpha;
  StepIncrements(s, &u, &alpha);
  const MidpointResult r = Midpoint(ref, s.start, s.end, false);
  return (r.energy_end - r.energy_start - IncrementWork(u, alpha, r.mc)) / IncrementWork(u, alpha, r.corr);
}

// d(u, alpha) . F / d(x, theta)_{n+1}: F_a . dx_a + F_theta_a . S(alpha_a) dtheta_a + (u, alpha)^T K,
// with d alpha = S(alpha) dtheta, S(a) = I - hat(a)/2 + a a^T/4 (the inverse of eq. 17's S^{-1}).
std::vector<double> IncrementWorkGradient(const std::vector<Vec3> &u, const std::vector<Vec3> &alpha, const std::vector<double> &f,
                                          const std::vector<double> &K)
{
  const int           nn = (int)u.size(), n = 6 * nn;
  std::vector<double> g(n, 0.0);
  for (int a = 0; a < nn; ++a) {
    const Mat3 S     = Mat3::Identity() - 0.5 * Skew(alpha[a]) + 0.25 * alpha[a] * alpha[a].transpose();
    const Vec3 dmdth = S.transpose() * Vec3(&f[6 * a + 3]);
    for (int i = 0; i < 3; ++i) g[6 * a + i] += f[6 * a + i], g[6 * a + 3 + i] += dmdth(i);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < 3; ++i) g[j] += u[a](i) * K[(6 * a + i) * n + j] + alpha[a](i) * K[(6 * a + 3 + i) * n + j];
  }
  return g;
}

} // namespace

TEST_P(BeamKernel, MidpointTangentMatchesFiniteDifferences)
{
  const int nn = GetParam();
  for (const auto &[ref_name, ec] :
       {std::pair<const char *, ElementCase>{"straight", StraightReference(nn, 1.5)}, {"curved", CurvedTwistedReference(nn, 0.6)}}) {
    BeamElementReference ref;
    ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
    for (const StepCase &s : MidpointStepCases(ec)) {
      const MidpointResult exact = Midpoint(ref, s.start, s.end, true);
      double               error_mc, error_corr;
      MidpointTangentErrors(ref, s, exact, &error_mc, &error_corr);
      std::printf("mid-point tangent FD relative error, %d nodes, %s, %s: K_mc %.2e, K_corr %.2e\n", nn, ref_name, s.name.c_str(), error_mc, error_corr);
      EXPECT_LT(error_mc, 1e-6) << ref_name << ", " << s.name;
      EXPECT_LT(error_corr, 1e-6) << ref_name << ", " << s.name;
      // Momentum conservation, for the forces and (differentiated) for the tangents.
      double net_tangent_mc, net_tangent_corr;
      EXPECT_LT(MidpointNetForceAndMoment(s, exact.mc, exact.tangent_mc, &net_tangent_mc), 1e-12) << s.name;
      EXPECT_LT(MidpointNetForceAndMoment(s, exact.corr, exact.tangent_corr, &net_tangent_corr), 1e-12) << s.name;
      EXPECT_LT(net_tangent_mc, 1e-12) << s.name;
      EXPECT_LT(net_tangent_corr, 1e-12) << s.name;
    }
  }
}

// r_{n+1} is the end-point kernel's residual; the energies are the end-point kernel's; asking for
// tangents does not change the forces.
TEST_P(BeamKernel, MidpointEndResidualAndEnergiesMatchTheEndPointKernel)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const StepCase &s : MidpointStepCases(ec)) {
    const MidpointResult full = Midpoint(ref, s.start, s.end, true);
    std::vector<double>  r_end(6 * nn), r_start(6 * nn), mc(6 * nn), corr(6 * nn);
    double               energy_end, energy_start;
    ASSERT_EQ(BeamInternalForces(ref, kSection, s.end.positions.data(), s.end.triads.data(), r_end.data(), nullptr, &energy_end, nullptr),
              BeamKernelStatus::Ok);
    ASSERT_EQ(BeamInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), r_start.data(), nullptr, &energy_start, nullptr),
              BeamKernelStatus::Ok);
    double scale = 0;
    for (double v : r_end) scale = std::max(scale, std::abs(v));
    for (int i = 0; i < 6 * nn; ++i) EXPECT_NEAR(full.end_residual[i], r_end[i], 1e-12 * scale) << s.name;
    EXPECT_NEAR(full.energy_end, energy_end, 1e-13 * energy_end) << s.name;
    EXPECT_NEAR(full.energy_start, energy_start, 1e-13 * energy_start) << s.name;
    ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(), mc.data(),
                                         corr.data(), nullptr, nullptr),
              BeamKernelStatus::Ok);
    for (int i = 0; i < 6 * nn; ++i) {
      EXPECT_EQ(mc[i], full.mc[i]);
      EXPECT_EQ(corr[i], full.corr[i]);
    }
  }
}

// The start of the step computed once (BeamMidpointStartState, as the beam contributor does at the
// start of each step) gives the kernel's results without the start configuration: forces, tangents,
// r_{n+1} and energies agree to round-off.
TEST_P(BeamKernel, MidpointKernelFromTheStoredStartOfTheStep)
{
  const int            nn = GetParam(), nd = 6 * nn;
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const StepCase &s : MidpointStepCases(ec)) {
    BeamMidpointStart start;
    ASSERT_EQ(BeamMidpointStartState(ref, s.start.positions.data(), s.start.triads.data(), &start), BeamKernelStatus::Ok);
    std::vector<double> outputs[2][5];
    double              energies[2][2];
    for (int stored = 0; stored < 2; ++stored) {
      std::vector<double> *o = outputs[stored];
      o[0].assign(nd, 0.0), o[1].assign(nd, 0.0), o[2].assign(nd * nd, 0.0), o[3].assign(nd * nd, 0.0), o[4].assign(nd, 0.0);
      ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, stored ? nullptr : s.start.positions.data(), stored ? nullptr : s.start.triads.data(),
                                           s.end.positions.data(), s.end.triads.data(), o[0].data(), o[1].data(), o[2].data(), o[3].data(), o[4].data(),
                                           &energies[stored][0], &energies[stored][1], EnergyCorrection::Resultants, nullptr, stored ? &start : nullptr),
                BeamKernelStatus::Ok);
    }
    for (int which = 0; which < 5; ++which) {
      double size = 0.0, difference = 0.0;
      for (size_t i = 0; i < outputs[0][which].size(); ++i) {
        size       = std::max(size, std::abs(outputs[0][which][i]));
        difference = std::max(difference, std::abs(outputs[1][which][i] - outputs[0][which][i]));
      }
      EXPECT_LE(difference, 1e-12 * size) << s.name << " output " << which;
    }
    EXPECT_NEAR(energies[1][0], energies[0][0], 1e-13 * energies[0][0]) << s.name;
    EXPECT_EQ(energies[1][1], energies[0][1]) << s.name;
  }
}

// mc's call without the correction (force_correction null): F_mc, K_mc and the energies bit for
// bit those of the call with it, and the correction's tangents still right when asked for.
TEST_P(BeamKernel, MidpointKernelWithoutTheCorrectionIsTheSame)
{
  const int            nn = GetParam(), nd = 6 * nn;
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const StepCase &s : MidpointStepCases(ec)) {
    std::vector<double> f[2], K[2], K_corr[2];
    double              energies[2][2];
    for (int with = 0; with < 2; ++with) {
      std::vector<double> correction(nd, 0.0);
      f[with].assign(nd, 0.0), K[with].assign(nd * nd, 0.0), K_corr[with].assign(nd * nd, 0.0);
      ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(),
                                           f[with].data(), with ? correction.data() : nullptr, K[with].data(), K_corr[with].data(), nullptr, &energies[with][0],
                                           &energies[with][1]),
                BeamKernelStatus::Ok);
    }
    EXPECT_TRUE(f[0] == f[1]) << s.name;
    EXPECT_TRUE(K[0] == K[1]) << s.name;
    EXPECT_TRUE(K_corr[0] == K_corr[1]) << s.name;
    EXPECT_EQ(energies[0][0], energies[1][0]) << s.name;
    EXPECT_EQ(energies[0][1], energies[1][1]) << s.name;
  }
}

// em's combined tangent (beta given): K_mc + beta K_corr from one set of blocks equals the sum of
// the two tangents built apart, for both corrections, with the forces and r_{n+1} unchanged.
TEST_P(BeamKernel, MidpointCombinedTangentIsTheSumOfBoth)
{
  const int            nn = GetParam(), nd = 6 * nn;
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const EnergyCorrection correction : {EnergyCorrection::Resultants, EnergyCorrection::Forces})
    for (const StepCase &s : MidpointStepCases(ec))
      for (const double beta : {0.0, 0.37, -2.5}) {
        std::vector<double> mc(nd), corr(nd), K_mc(nd * nd), K_corr(nd * nd), r(nd), mc_combined(nd), corr_combined(nd), K(nd * nd), r_combined(nd);
        double              energy_start, energy_end;
        ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(),
                                             mc.data(), corr.data(), K_mc.data(), K_corr.data(), r.data(), &energy_start, &energy_end, correction),
                  BeamKernelStatus::Ok);
        ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(),
                                             mc_combined.data(), corr_combined.data(), K.data(), nullptr, r_combined.data(), &energy_start, &energy_end,
                                             correction, &beta),
                  BeamKernelStatus::Ok);
        double difference = 0.0, size = 0.0;
        for (int i = 0; i < nd * nd; ++i) {
          const double sum = K_mc[i] + beta * K_corr[i];
          difference       = std::max(difference, std::abs(K[i] - sum));
          size             = std::max(size, std::abs(sum));
        }
        EXPECT_LE(difference, 1e-12 * size) << s.name << " beta " << beta;
        for (int i = 0; i < nd; ++i) {
          EXPECT_EQ(mc_combined[i], mc[i]) << s.name;
          EXPECT_EQ(corr_combined[i], corr[i]) << s.name;
          EXPECT_EQ(r_combined[i], r[i]) << s.name;
        }
      }
}

// em's tangent pass from what the residual pass kept (BeamMidpointResidualKeeping, then
// BeamMidpointTangentOfIterate) is the one-call kernel's, bit for bit: forces, r_{n+1}, energies,
// K_mc + beta K_corr and the two tangents apart, for both corrections.
template <int NN> void ExpectKeptIterateGivesTheKernelsResults(const BeamElementReference &ref, const StepCase &s, EnergyCorrection correction)
{
  constexpr int     nd = 6 * NN;
  BeamMidpointStart start;
  ASSERT_EQ(BeamMidpointStartState(ref, s.start.positions.data(), s.start.triads.data(), &start), BeamKernelStatus::Ok);
  std::vector<double> mc(nd), corr(nd), r(nd), kept_mc(nd), kept_corr(nd), kept_r(nd);
  double              energies[2], kept_energies[2];
  auto                iterate = std::make_unique<BeamMidpointIterate<NN>>();
  ASSERT_EQ(BeamMidpointResidualKeeping<NN>(ref, kSection, start, s.end.positions.data(), s.end.triads.data(), kept_mc.data(), kept_corr.data(), kept_r.data(),
                                            &kept_energies[0], &kept_energies[1], correction, iterate.get()),
            BeamKernelStatus::Ok);
  for (const double beta : {0.0, 0.37, -2.5}) {
    for (int combined = 0; combined < 2; ++combined) {
      std::vector<double> K_mc(nd * nd), K_corr(nd * nd), kept_K_mc(nd * nd), kept_K_corr(nd * nd);
      ASSERT_EQ(BeamMidpointInternalForces(ref, kSection, nullptr, nullptr, s.end.positions.data(), s.end.triads.data(), mc.data(), corr.data(), K_mc.data(),
                                           combined ? nullptr : K_corr.data(), r.data(), &energies[0], &energies[1], correction, combined ? &beta : nullptr,
                                           &start),
                BeamKernelStatus::Ok);
      BeamMidpointTangentOfIterate<NN>(ref, kSection, *iterate, correction, combined ? &beta : nullptr, kept_K_mc.data(),
                                       combined ? nullptr : kept_K_corr.data());
      bool same = kept_energies[0] == energies[0] && kept_energies[1] == energies[1];
      for (int i = 0; i < nd; ++i) same = same && kept_mc[i] == mc[i] && kept_corr[i] == corr[i] && kept_r[i] == r[i];
      for (int i = 0; i < nd * nd; ++i) same = same && kept_K_mc[i] == K_mc[i] && (combined || kept_K_corr[i] == K_corr[i]);
      EXPECT_TRUE(same) << s.name << (combined ? " combined, beta " : " apart, beta ") << beta;
    }
  }
}

TEST_P(BeamKernel, MidpointTangentFromTheKeptIterateIsTheKernels)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const EnergyCorrection correction : {EnergyCorrection::Resultants, EnergyCorrection::Forces})
    for (const StepCase &s : MidpointStepCases(ec)) {
      if (nn == 2) ExpectKeptIterateGivesTheKernelsResults<2>(ref, s, correction);
      else ExpectKeptIterateGivesTheKernelsResults<3>(ref, s, correction);
    }
}

// em's work identity and the exact linearisation of its beta (eq. 20) from K_mc, K_corr and r_{n+1}:
//   beta = (Pi_{n+1} - Pi_n - W_mc)/W_corr,  W = sum_a u_a . F_a + alpha_a . M_a,
//   d beta = (r_{n+1} - dW_mc - beta dW_corr)/W_corr,
// against central differences of beta in the end configuration; beta vanishes with the step.
TEST_P(BeamKernel, MidpointEnergyCorrectionIsLinearisedExactly)
{
  const int            nn = GetParam();
  const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
  BeamElementReference ref;
  ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
  for (const StepCase &s : MidpointStepCases(ec)) {
    std::vector<Vec3> u, alpha;
    StepIncrements(s, &u, &alpha);
    const MidpointResult r    = Midpoint(ref, s.start, s.end, true);
    const double         w_mc = IncrementWork(u, alpha, r.mc), w_corr = IncrementWork(u, alpha, r.corr);
    const double         beta   = ElementBeta(ref, s);
    const double         change = r.energy_end - r.energy_start;
    std::vector<double>  f_em(6 * nn);
    for (int i = 0; i < 6 * nn; ++i) f_em[i] = r.mc[i] + beta * r.corr[i];
    EXPECT_NEAR(IncrementWork(u, alpha, f_em), change, 1e-12 * (std::abs(w_mc) + std::abs(change))) << s.name;

    const std::vector<double> g_mc = IncrementWorkGradient(u, alpha, r.mc, r.tangent_mc), g_corr = IncrementWorkGradient(u, alpha, r.corr, r.tangent_corr);
    const double              h    = 1e-6;
    double                    diff = 0, size = 0;
    for (int j = 0; j < 6 * nn; ++j) {
      const double exact = (r.end_residual[j] - g_mc[j] - beta * g_corr[j]) / w_corr;
      const double fd    = (ElementBeta(ref, {s.name, s.start, Perturb(s.end, j, h)}) - ElementBeta(ref, {s.name, s.start, Perturb(s.end, j, -h)})) / (2 * h);
      diff               = std::max(diff, std::abs(exact - fd));
      size               = std::max(size, std::abs(exact));
    }
    std::printf("em beta, %d nodes, %s: beta %.3e, d beta FD relative error %.2e\n", nn, s.name.c_str(), beta, diff / size);
    EXPECT_LT(diff / size, 1e-6) << s.name;
  }
  // beta = O(step): the work mismatch of F_mc is O(step^3), the correction's work O(step^2).
  const StepCase base = MidpointStepCases(ec)[4];
  double         beta[2];
  for (int k = 0; k < 2; ++k) {
    StepCase s = base;
    for (int a = 0; a < nn; ++a) {
      const double fraction = 0.05 / (1 << k);
      s.end.positions[a]    = s.start.positions[a] + fraction * (base.end.positions[a] - base.start.positions[a]);
      s.end.triads[a]       = ExpSO3(fraction * LogSO3(base.end.triads[a] * base.start.triads[a].transpose())) * s.start.triads[a];
    }
    beta[k] = ElementBeta(ref, s);
  }
  std::printf("em beta for steps 0.05 and 0.025 of the random case, %d nodes: %.3e, %.3e\n", nn, beta[0], beta[1]);
  EXPECT_GT(std::abs(beta[0] / beta[1]), 1.6);
  EXPECT_LT(std::abs(beta[0] / beta[1]), 2.5);
}

// Cost of the mid-point kernel with both tangents and r_{n+1} against the end-point kernel with its
// tangent, in microseconds per element (minimum over rounds). Prints, asserts nothing about time;
// disabled by default: run with
//   test_beam --gtest_also_run_disabled_tests --gtest_filter='*MidpointKernelCost*'
TEST(BeamKernelTiming, DISABLED_MidpointKernelCost)
{
  for (int nn = 2; nn <= 3; ++nn) {
    const ElementCase    ec = CurvedTwistedReference(nn, 0.6);
    BeamElementReference ref;
    ASSERT_EQ(BeamElementSetup(nn, ec.positions.data(), ec.triads.data(), &ref), BeamKernelStatus::Ok);
    const StepCase s = MidpointStepCases(ec)[4];
    double         f_mc[kBeamMaxDofs], f_corr[kBeamMaxDofs], r[kBeamMaxDofs], K_mc[kBeamMaxDofs * kBeamMaxDofs], K_corr[kBeamMaxDofs * kBeamMaxDofs];
    double         energy_start, energy_end, checksum = 0;
    constexpr int  kRepetitions = 20000, kRounds = 20;
    double         best_end = 1e30, best_midpoint = 1e30, best_midpoint_forces = 1e30;
    using Clock                = std::chrono::steady_clock;
    auto microseconds_per_call = [](Clock::time_point a, Clock::time_point b) {
      return std::chrono::duration<double, std::micro>(b - a).count() / kRepetitions;
    };
    for (int round = 0; round < kRounds; ++round) {
      bool       ok = true;
      const auto t0 = Clock::now();
      for (int i = 0; i < kRepetitions; ++i) {
        ok &= BeamInternalForces(ref, kSection, s.end.positions.data(), s.end.triads.data(), r, K_mc, &energy_end, nullptr) == BeamKernelStatus::Ok;
        checksum += K_mc[7];
      }
      const auto t1 = Clock::now();
      for (int i = 0; i < kRepetitions; ++i) {
        ok &= BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(), f_mc,
                                         f_corr, K_mc, K_corr, r, &energy_start, &energy_end) == BeamKernelStatus::Ok;
        checksum += K_mc[7] + K_corr[7];
      }
      const auto t2 = Clock::now();
      for (int i = 0; i < kRepetitions; ++i) {
        ok &= BeamMidpointInternalForces(ref, kSection, s.start.positions.data(), s.start.triads.data(), s.end.positions.data(), s.end.triads.data(), f_mc,
                                         f_corr, &energy_start, &energy_end) == BeamKernelStatus::Ok;
        checksum += f_mc[7];
      }
      const auto t3 = Clock::now();
      ASSERT_TRUE(ok);
      best_end             = std::min(best_end, microseconds_per_call(t0, t1));
      best_midpoint        = std::min(best_midpoint, microseconds_per_call(t1, t2));
      best_midpoint_forces = std::min(best_midpoint_forces, microseconds_per_call(t2, t3));
    }
    EXPECT_TRUE(std::isfinite(checksum));
    std::printf("%d nodes: end-point with tangent %.2f us/element, mid-point with K_mc, K_corr, r_{n+1} %.2f us/element (ratio %.2f), mid-point forces "
                "alone %.2f us/element\n",
                nn, best_end, best_midpoint, best_midpoint / best_end, best_midpoint_forces);
  }
}
