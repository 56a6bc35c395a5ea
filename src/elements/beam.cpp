#include "elements/beam.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace msflex {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Lagrange shape functions on xi in [-1, 1] with equally spaced nodes.
void LagrangeShape(int num_nodes, double xi, double *value, double *derivative)
{
  if (num_nodes == 2) {
    value[0]      = 0.5 * (1.0 - xi);
    value[1]      = 0.5 * (1.0 + xi);
    derivative[0] = -0.5;
    derivative[1] = 0.5;
  } else {
    value[0]      = 0.5 * xi * (xi - 1.0);
    value[1]      = 1.0 - xi * xi;
    value[2]      = 0.5 * xi * (xi + 1.0);
    derivative[0] = xi - 0.5;
    derivative[1] = -2.0 * xi;
    derivative[2] = xi + 0.5;
  }
}

// Local (objective) nodal coordinates: psi_a = log(Lambda_c^T Lambda_a), rho_a = Lambda_c^T (x_a - x_c).
bool LocalCoordinates(int num_nodes, int c, const Vec3 *positions, const Mat3 *triads, Vec3 *rho, Vec3 *psi)
{
  const Mat3 LcT = triads[c].transpose();
  for (int a = 0; a < num_nodes; ++a) {
    if (a == c) {
      rho[a].setZero();
      psi[a].setZero();
      continue;
    }
    rho[a] = LcT * (positions[a] - positions[c]);
    psi[a] = LogSO3Acute(LcT * triads[a]);
    // log returns |psi| <= pi; a relative rotation this large inside one element is not resolvable.
    if (psi[a].norm() > 0.95 * kPi) return false;
  }
  return true;
}

// The element's nodes other than the reference node c, in order.
template <int NN> void NonReferenceNodes(int c, int *others)
{
  for (int a = 0, o = 0; a < NN; ++a)
    if (a != c) others[o++] = a;
}

// Interpolated local rotation Psi, its arc-length derivative Psi' and rho' at Gauss point gp.
struct GaussInterpolation {
  Vec3 Psi, dPsi, drho;
};
[[gnu::always_inline]] inline GaussInterpolation InterpolateAtGauss(const BeamElementReference &ref, int gp, const Vec3 *rho, const Vec3 *psi)
{
  GaussInterpolation g{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  for (int a = 0; a < ref.num_nodes; ++a) {
    g.Psi += ref.shape[gp][a] * psi[a];
    g.dPsi += ref.shape_derivative[gp][a] * psi[a];
    g.drho += ref.shape_derivative[gp][a] * rho[a];
  }
  return g;
}

// The rotation series c_n(x) = sum_k (-x)^k/(2k+n)! (math/rotation.hpp) for the small relative
// rotations inside an element, x <= kShortSeriesLimit: ten terms of each, summed by Horner's rule
// with fixed coefficients (no branches, no loop-carried counters). The first omitted term is below
// x^10/(20+n)! < 5e-25 for c_n and likewise for the derivatives; larger x falls back to
// EvaluateRotationSeries. Only the functions a form needs are summed: [first, first + 3).
constexpr double kShortSeriesLimit = 0.25;
constexpr int    kShortSeriesTerms = 10;
struct ShortSeriesCoefficients {
  double c[5][kShortSeriesTerms], dc[5][kShortSeriesTerms], ddc[5][kShortSeriesTerms];
  ShortSeriesCoefficients()
  {
    for (int n = 0; n < 5; ++n) {
      // a_k = (-1)^k/(2k+n)!;  c = sum a_k x^k, c' = sum (k+1) a_{k+1} x^k, c'' = sum (k+2)(k+1) a_{k+2} x^k
      double a[kShortSeriesTerms + 2];
      for (int k = 0; k < kShortSeriesTerms + 2; ++k) {
        double factorial = 1.0;
        for (int m = 2; m <= 2 * k + n; ++m) factorial *= m;
        a[k] = (k % 2 ? -1.0 : 1.0) / factorial;
      }
      for (int k = 0; k < kShortSeriesTerms; ++k) {
        c[n][k]   = a[k];
        dc[n][k]  = (k + 1) * a[k + 1];
        ddc[n][k] = (k + 2) * (k + 1) * a[k + 2];
      }
    }
  }
};
const ShortSeriesCoefficients kShortSeries;

inline double Horner(const double *coefficient, double x)
{
  double value = coefficient[kShortSeriesTerms - 1];
  for (int k = kShortSeriesTerms - 2; k >= 0; --k) value = value * x + coefficient[k];
  return value;
}

[[gnu::always_inline]] inline RotationSeries ElementRotationSeries(double x, int first, bool second_derivatives)
{
  if (x > kShortSeriesLimit) return EvaluateRotationSeries(x);
  RotationSeries s{};
  for (int n = first; n < first + 3; ++n) {
    s.c[n]  = Horner(kShortSeries.c[n], x);
    s.dc[n] = Horner(kShortSeries.dc[n], x);
    if (second_derivatives) s.ddc[n] = Horner(kShortSeries.ddc[n], x);
  }
  return s;
}

template <int NN> using NodalMatrix = Eigen::Matrix<double, 6 * NN, 6 * NN, Eigen::RowMajor>;

// always_inline on these small closed forms: the mid-point kernels are too large for GCC's inliner
// to inline them (it called the 3x3 products out of line), and flattening those kernels whole made
// them slower (scripts/bench-kernel).
// Closed forms of the Rodrigues-type operators F = I + alpha hat(p) + beta hat(p)^2 (math/rotation.hpp)
// written out for the end-point kernel, which calls them on every element of every Newton
// iteration: hat(p)^2 = p p^T - x I (x = |p|^2), so F and its products need no 3x3 matrix product,
// and one vector u per operand carries every derivative term of the Jacobian (below).

// F^T v = v - alpha p x v + beta (p (p.v) - x v)
[[gnu::always_inline]] inline Vec3 FormTransposeTimes(double alpha, double beta, const Vec3 &p, double x, const Vec3 &v)
{
  return v - alpha * p.cross(v) + beta * (p.dot(v) * p - x * v);
}

// F v = v + alpha p x v + beta (p (p.v) - x v)
[[gnu::always_inline]] inline Vec3 FormTimes(double alpha, double beta, const Vec3 &p, double x, const Vec3 &v)
{
  return v + alpha * p.cross(v) + beta * (p.dot(v) * p - x * v);
}

// J = d(F^T a)/dp = alpha hat(a) + beta (p.a) I + beta p a^T + u p^T with
// u = -2 alpha_x (p x a) - 2 beta a + 2 beta_x p x (p x a)  (RodriguesTransposeApplyJacobian regrouped).
// d(F a)/dp is the same with alpha, alpha_x negated.
[[gnu::always_inline]] inline Vec3 JacobianShift(double alpha_x, double beta, double beta_x, const Vec3 &p, const Vec3 &a)
{
  const Vec3 pxa = p.cross(a);
  return -2.0 * alpha_x * pxa - 2.0 * beta * a + 2.0 * beta_x * p.cross(pxa);
}

[[gnu::always_inline]] inline Mat3 JacobianMatrix(double alpha, double beta, const Vec3 &p, const Vec3 &a, const Vec3 &u)
{
  const double pa = beta * p.dot(a);
  Mat3         J;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) J(i, j) = beta * p(i) * a(j) + u(i) * p(j);
  J(0, 0) += pa, J(1, 1) += pa, J(2, 2) += pa;
  J(0, 1) -= alpha * a(2), J(1, 0) += alpha * a(2);
  J(0, 2) += alpha * a(1), J(2, 0) -= alpha * a(1);
  J(1, 2) -= alpha * a(0), J(2, 1) += alpha * a(0);
  return J;
}

// J^T n without forming J: alpha (n x a) + beta (p.a) n + beta (p.n) a + (u.n) p
[[gnu::always_inline]] inline Vec3 JacobianTransposeTimes(double alpha, double beta, const Vec3 &p, const Vec3 &a, const Vec3 &u, const Vec3 &n)
{
  return alpha * n.cross(a) + beta * (p.dot(a) * n + p.dot(n) * a) + u.dot(n) * p;
}

// rows of M times hat(d) (row_i x d), and hat(d) times the columns of M (d x column_j)
[[gnu::always_inline]] inline Mat3 TimesSkew(const Mat3 &M, const Vec3 &d)
{
  Mat3 R;
  for (int i = 0; i < 3; ++i) R.row(i) = M.row(i).transpose().cross(d).transpose();
  return R;
}
[[gnu::always_inline]] inline Mat3 SkewTimes(const Vec3 &d, const Mat3 &M)
{
  Mat3 R;
  for (int j = 0; j < 3; ++j) R.col(j) = d.cross(M.col(j));
  return R;
}

[[gnu::always_inline]] inline Mat3 Mul(const Mat3 &a, const Mat3 &b) { return a.lazyProduct(b); }
[[gnu::always_inline]] inline Mat3 MulT(const Mat3 &a, const Mat3 &b) { return a.lazyProduct(b.transpose()); } // a b^T
[[gnu::always_inline]] inline Mat3 TMul(const Mat3 &a, const Mat3 &b) { return a.transpose().lazyProduct(b); } // a^T b

// Per Gauss point, the 3x3 products from which every block of the local stiffness is a scalar
// combination (I_a, I'_a are the shape functions and derivatives at the point):
//   local gradient   g_rho_a = wJ I'_a E N,   g_psi_a = wJ [I_a (A^T N + B^T M) + I'_a H M]
//   material blocks  d(Gamma, K)/d(rho_a, psi_a) = [[I'_a E^T, I_a A], [0, I_a B + I'_a H^T]]
//   geometric blocks (rho_a, psi_b): I'_a I_b P;  (psi_a, psi_b): I_a I_b (Sg + Sk) + I'_a I_b Q + I_a I'_b Q^T
// with P = d(E N)/dPsi, Q = d(H M)/dPsi, Sg + Sk = d(A^T N + B^T M)/dPsi at fixed N, M. The sums
// shared by every (a, b) pair are formed once per point; the local stiffness is symmetric
// (a Hessian), so (psi_a, rho_b) is the transpose of (rho_b, psi_a).
struct GaussProducts {
  double wJ;
  Mat3   ECE, HCH;  // E C_N E^T, H C_M H^T
  Mat3   ECA_P;     // E C_N A + P
  Mat3   ACA_BCB_S; // A^T C_N A + B^T C_M B + Sg + Sk
  Mat3   BCH_QT;    // B^T C_M H^T + Q^T
};

// Sg + Sk = d^2/dPsi^2 [N.E^T drho' + M.H^T Psi'] at fixed N, M: the Hessian of m.F^T a of
// RodriguesTransposeApplyHessian, summed over the two terms before the matrix is formed:
//   sum over (F, a, m) of  p w^T + w p^T + beta (m a^T + a m^T) + k p p^T + s I,
//   w = -2 alpha_x (a x m) + 2 beta_x grad g,  k = -4 alpha_xx h + 4 beta_xx g,
//   s = -2 alpha_x h - 2 beta (m.a) + 2 beta_x g,  h = p.(a x m),  g = (p.m)(p.a) - x (m.a).
inline Mat3 StressHessian(const RodriguesForm &Fe, const RodriguesForm &Fh, const Vec3 &p, double x, const Vec3 &drho, const Vec3 &N, const Vec3 &dPsi,
                          const Vec3 &M)
{
  Vec3   w = Vec3::Zero();
  double k = 0.0, s = 0.0;
  auto   add = [&](const RodriguesForm &f, const Vec3 &a, const Vec3 &m) {
    const Vec3   c = a.cross(m);
    const double h = p.dot(c), ma = m.dot(a), pm = p.dot(m), pa = p.dot(a);
    const double g  = pm * pa - x * ma;
    const Vec3   gg = pa * m + pm * a - 2.0 * ma * p;
    w += -2.0 * f.alpha_x * c + 2.0 * f.beta_x * gg;
    k += -4.0 * f.alpha_xx * h + 4.0 * f.beta_xx * g;
    s += -2.0 * f.alpha_x * h - 2.0 * f.beta * ma + 2.0 * f.beta_x * g;
  };
  add(Fe, drho, N);
  add(Fh, dPsi, M);
  Mat3 S;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      S(i, j) = p(i) * w(j) + w(i) * p(j) + k * p(i) * p(j) + Fe.beta * (N(i) * drho(j) + drho(i) * N(j)) + Fh.beta * (M(i) * dPsi(j) + dPsi(i) * M(j));
  S(0, 0) += s, S(1, 1) += s, S(2, 2) += s;
  return S;
}

// flatten: in a function this large GCC's inliner leaves the small closed forms above (FormTimes,
// JacobianShift, the 3x3 products, the block adders) as calls; inlining every one of them takes a
// 2-node call with tangent from 0.83 to 0.60 us (scripts/bench-kernel), with the same results.
// kAdd: add r and K into the caller's arrays instead of overwriting them (BeamAddInternalForces).
template <int NN, bool kAdd = false>
[[gnu::flatten]] BeamKernelStatus InternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions,
                                                 const Mat3 *triads, double *residual_out, double *tangent_out, double *energy_out, BeamGaussResults *results)
{
  const int c = ref.reference_node;
  Vec3      rho[NN], psi[NN];
  if (!LocalCoordinates(NN, c, positions, triads, rho, psi)) return BeamKernelStatus::RotationTooLarge;
  int others[NN - 1];
  NonReferenceNodes<NN>(c, others);

  const bool  want_tangent = tangent_out != nullptr;
  const Vec3 &CN = section.axial_shear, &CM = section.torsion_bending;
  double      energy = 0.0;
  Vec3        g_rho[NN], g_psi[NN]; // gradient of the energy with respect to the local coordinates
  for (int a = 0; a < NN; ++a) g_rho[a].setZero(), g_psi[a].setZero();
  GaussProducts gauss[kBeamMaxGauss];

  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const double  *I             = ref.shape[gp];
    const double  *dI            = ref.shape_derivative[gp];
    GaussProducts &G             = gauss[gp];
    G.wJ                         = ref.weight_jacobian[gp];
    const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho, psi);
    const double         x       = Psi.squaredNorm();
    const RotationSeries series  = ElementRotationSeries(x, 1, want_tangent); // c1..c3: exp and H
    const RodriguesForm  Fe      = ExpForm(series);
    const RodriguesForm  Fh      = TangentForm(series);
    const Vec3           eps     = FormTransposeTimes(Fe.alpha, Fe.beta, Psi, x, drho) - ref.strain0[gp];    // Gamma - Gamma_0
    const Vec3           kap     = FormTransposeTimes(Fh.alpha, Fh.beta, Psi, x, dPsi) - ref.curvature0[gp]; // K - K_0
    const Vec3           N       = CN.cwiseProduct(eps);
    const Vec3           M       = CM.cwiseProduct(kap);
    energy += 0.5 * G.wJ * (eps.dot(N) + kap.dot(M));
    if (results) {
      results->strain[gp]    = eps;
      results->curvature[gp] = kap;
      results->force[gp]     = N;
      results->moment[gp]    = M;
    }
    // dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'  (A, B: JacobianMatrix with ua, ub)
    const Vec3 ua    = JacobianShift(Fe.alpha_x, Fe.beta, Fe.beta_x, Psi, drho);
    const Vec3 ub    = JacobianShift(Fh.alpha_x, Fh.beta, Fh.beta_x, Psi, dPsi);
    const Vec3 EN    = FormTimes(Fe.alpha, Fe.beta, Psi, x, N);
    const Vec3 HM    = FormTimes(Fh.alpha, Fh.beta, Psi, x, M);
    const Vec3 AN_BM = JacobianTransposeTimes(Fe.alpha, Fe.beta, Psi, drho, ua, N) + JacobianTransposeTimes(Fh.alpha, Fh.beta, Psi, dPsi, ub, M);
    for (int a : others) {
      g_rho[a] += G.wJ * dI[a] * EN;
      g_psi[a] += G.wJ * (I[a] * AN_BM + dI[a] * HM);
    }
    if (!want_tangent) continue;
    const Mat3 E = RodriguesMatrix(Fe.alpha, Fe.beta, Psi, x), H = RodriguesMatrix(Fh.alpha, Fh.beta, Psi, x);
    const Mat3 A = JacobianMatrix(Fe.alpha, Fe.beta, Psi, drho, ua), B = JacobianMatrix(Fh.alpha, Fh.beta, Psi, dPsi, ub);
    // P = d(E N)/dPsi, Q = d(H M)/dPsi: the Jacobians of F a with alpha negated.
    const Mat3 P   = JacobianMatrix(-Fe.alpha, Fe.beta, Psi, N, JacobianShift(-Fe.alpha_x, Fe.beta, Fe.beta_x, Psi, N));
    const Mat3 Q   = JacobianMatrix(-Fh.alpha, Fh.beta, Psi, M, JacobianShift(-Fh.alpha_x, Fh.beta, Fh.beta_x, Psi, M));
    const Mat3 ECN = E * CN.asDiagonal(), HCM = H * CM.asDiagonal();
    const Mat3 CA = CN.asDiagonal() * A, CB = CM.asDiagonal() * B;
    G.ECE       = MulT(ECN, E);
    G.HCH       = MulT(HCM, H);
    G.ECA_P     = Mul(ECN, A) + P;
    G.ACA_BCB_S = TMul(A, CA) + TMul(B, CB) + StressHessian(Fe, Fh, Psi, x, drho, N, dPsi, M);
    G.BCH_QT    = TMul(CB, H.transpose()) + Q.transpose();
  }
  if (energy_out) *energy_out = energy;

  // Chain rule to nodal (x, theta), with d_a = x_a - x_c, L = Lambda_c:
  //   delta rho_a = L^T (dx_a - dx_c) + M_a dtheta_c,  M_a = L^T hat(d_a)
  //   delta psi_a = P_a (dtheta_a - dtheta_c),         P_a = Hinv(psi_a) L^T
  const Mat3                                  &L = triads[c];
  Mat3                                         Pm[NN];
  RodriguesForm                                Finv[NN];
  Vec3                                         fa[NN], ma[NN], d[NN]; // nodal force L g_rho_a and moment P_a^T g_psi_a
  Eigen::Map<Eigen::Matrix<double, 6 * NN, 1>> residual(residual_out);
  if constexpr (!kAdd) residual.setZero();
  for (int a : others) {
    d[a]           = positions[a] - positions[c];
    const double x = psi[a].squaredNorm();
    Finv[a]        = TangentInverseForm(ElementRotationSeries(x, 2, false)); // c2..c4; beta_xx unused here
    const Vec3 &f = fa[a] = L * g_rho[a];
    // m = L Hinv^T g_psi; -d x f - m = M_a^T g_rho - m
    const Vec3 &m = ma[a] = L * FormTransposeTimes(Finv[a].alpha, Finv[a].beta, psi[a], x, g_psi[a]);
    residual.template segment<3>(6 * a) += f;
    residual.template segment<3>(6 * a + 3) += m;
    residual.template segment<3>(6 * c) -= f;
    residual.template segment<3>(6 * c + 3) -= d[a].cross(f) + m;
    if (want_tangent) Pm[a] = MulT(RodriguesMatrix(Finv[a].alpha, Finv[a].beta, psi[a], x), L);
  }
  if (!want_tangent) return BeamKernelStatus::Ok;

  // Per pair (a, b) of non-reference nodes, with the local blocks Krr, Krp, Kpr = Krp(b, a)^T, Kpp:
  //   Nxx = L Krr L^T, Nxt = L Krp P_b, Ntx = P_a^T Kpr L^T = Nxt(b, a)^T, Ntt = P_a^T Kpp P_b,
  // and the rank-3 part of the map (M_b on dtheta_c), by M_b = L^T hat(d_b):
  //   L Krr M_b = Nxx hat(d_b),  P_a^T Kpr M_b = Ntx hat(d_b),  M_a^T Krr L^T = -hat(d_a) Nxx,
  //   M_a^T Krp P_b = -hat(d_a) Nxt,  M_a^T Krr M_b = -hat(d_a) Nxx hat(d_b).
  Mat3 Nxx[NN][NN], Nxt[NN][NN], Ntt[NN][NN];
  for (int a : others) {
    for (int b : others) {
      Mat3 Krr = Mat3::Zero(), Krp = Mat3::Zero(), Kpp = Mat3::Zero();
      for (int gp = 0; gp < ref.num_gauss; ++gp) {
        const GaussProducts &G  = gauss[gp];
        const double        *I  = ref.shape[gp];
        const double        *dI = ref.shape_derivative[gp];
        Krr += (G.wJ * dI[a] * dI[b]) * G.ECE;
        Krp += (G.wJ * dI[a] * I[b]) * G.ECA_P;
        Kpp += G.wJ * (I[a] * I[b] * G.ACA_BCB_S + I[a] * dI[b] * G.BCH_QT + dI[a] * I[b] * G.BCH_QT.transpose() + dI[a] * dI[b] * G.HCH);
      }
      Nxx[a][b] = MulT(Mul(L, Krr), L);
      Nxt[a][b] = Mul(Mul(L, Krp), Pm[b]);
      Ntt[a][b] = TMul(Pm[a], Mul(Kpp, Pm[b]));
    }
  }
  Eigen::Map<NodalMatrix<NN>> K(tangent_out);
  if constexpr (!kAdd) K.setZero();
  auto add = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) += block; };
  auto sub = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) -= block; }; // no negated temporary
  for (int a : others) {
    for (int b : others) {
      const Mat3 &xx = Nxx[a][b], &xt = Nxt[a][b], &tt = Ntt[a][b];
      const Mat3  tx = Nxt[b][a].transpose();
      const Mat3  Cx = TimesSkew(xx, d[b]), Ct = TimesSkew(tx, d[b]);
      // The theta_c rows' terms negated (mR = -R = hat(d_a) N): subtracted, not negated and added.
      const Mat3 mRx = SkewTimes(d[a], xx), mRt = SkewTimes(d[a], xt), mEcc = SkewTimes(d[a], Cx);
      const int  ax = 6 * a, at = 6 * a + 3, bx = 6 * b, bt = 6 * b + 3, cx = 6 * c, ct = 6 * c + 3;
      add(ax, bx, xx), add(ax, bt, xt), add(at, bx, tx), add(at, bt, tt);
      sub(ax, cx, xx), add(ax, ct, Cx - xt), sub(at, cx, tx), add(at, ct, Ct - tt);
      sub(cx, bx, xx), sub(cx, bt, xt), sub(ct, bx, mRx + tx), sub(ct, bt, mRt + tt);
      add(cx, cx, xx), add(cx, ct, xt - Cx), add(ct, cx, tx + mRx), add(ct, ct, tt - Ct + mRt - mEcc);
    }
  }
  // Terms from the configuration dependence of the map at fixed local gradient g:
  //   f_a = L g_rho_a, m_a = P_a^T g_psi_a, G_a = L d(Hinv^T g_psi)/dpsi P_a.
  for (int a : others) {
    const Vec3 &f = fa[a], &m = ma[a];
    const Vec3  u  = JacobianShift(Finv[a].alpha_x, Finv[a].beta, Finv[a].beta_x, psi[a], g_psi[a]);
    const Mat3  Ga = Mul(Mul(L, JacobianMatrix(Finv[a].alpha, Finv[a].beta, psi[a], g_psi[a], u)), Pm[a]);
    const Mat3  hf = Skew(f), hm = Skew(m);
    K.template block<3, 3>(6 * a, 6 * c + 3) -= hf;
    K.template block<3, 3>(6 * c, 6 * c + 3) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * a) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * c) -= hf;
    K.template block<3, 3>(6 * c + 3, 6 * c + 3) += SkewTimes(d[a], hf) + hm + Ga;
    K.template block<3, 3>(6 * a + 3, 6 * c + 3) -= hm + Ga;
    K.template block<3, 3>(6 * a + 3, 6 * a + 3) += Ga;
    K.template block<3, 3>(6 * c + 3, 6 * a + 3) -= Ga;
  }
  return BeamKernelStatus::Ok;
}

// Gamma = E^T rho', K = H^T Psi' at a Gauss point from the local coordinates (the reference's
// Gamma_0, K_0 not taken off).
void GaussDeformation(const BeamElementReference &ref, int gp, const Vec3 *rho, const Vec3 *psi, Vec3 *Gamma, Vec3 *K)
{
  const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho, psi);
  const double         x       = Psi.squaredNorm();
  const RotationSeries series  = ElementRotationSeries(x, 1, false);
  const RodriguesForm  Fe = ExpForm(series), Fh = TangentForm(series);
  *Gamma = FormTransposeTimes(Fe.alpha, Fe.beta, Psi, x, drho);
  *K     = FormTransposeTimes(Fh.alpha, Fh.beta, Psi, x, dPsi);
}

// Mid-point forces and their exact linearisation with respect to the end of the step.
//
// Forces (local coordinates q = (rho_a, psi_a), D(q) = d(Gamma, K)/dq, S = (N, M), C = diag(C_N, C_M)):
//   h_mc = sum_gp wJ D(q_mid)^T (S_n + S_{n+1})/2,   h_corr = sum_gp wJ D(q_mid)^T (S_{n+1} - S_n)
//   f_a = Lbar h_rho_a,  m_a = Lbar Hinv(psi_{a,mid})^T h_psi_a,  f_c = -sum f_a,
//   m_c = sum_a (-dbar_a x f_a - m_a),   Lbar = (Lambda_{c,n} + Lambda_{c,n+1})/2, dbar_a = (d_{a,n} + d_{a,n+1})/2.
// Tangent with respect to (delta x_{n+1}, delta theta_{n+1}); with q_mid = (q_n + q_{n+1})/2 and
// delta S_{n+1} = C D(q_{n+1}) delta q_{n+1}, the local part is
//   delta h = [s D(q_mid)^T C D(q_{n+1}) + G(q_mid, S)/2] delta q_{n+1},   s = 1/2 (mc), 1 (corr),
// G(q, S) = d(D(q)^T S)/dq at fixed S (the geometric stiffness of the end-point kernel with S),
// delta q_{n+1} the end-point map (T_{n+1} below), and F = Tbar^T h adds the variation of Tbar at
// fixed h: Lbar and dbar move with half the end variation, Hinv(psi_{a,mid}) with half of delta psi_{a,n+1}.

// Per Gauss point, the 3x3 matrices from which each local block of s D_m^T C D_1 + G_m/2 is a
// scalar combination (m: at q_mid, 1: at q_{n+1}; I_a, I'_a the shape functions and derivatives):
//   (rho_a, rho_b): I'_a I'_b rr                 rr  = s E_m C_N E_1^T
//   (rho_a, psi_b): I'_a I_b  rp                 rp  = s E_m C_N A_1 + P/2
//   (psi_a, rho_b): I_a  I'_b pr                 pr  = s A_m^T C_N E_1^T + P^T/2
//   (psi_a, psi_b): I_a I_b pp + I_a I'_b pd + I'_a I_b dp + I'_a I'_b dd
//                   pp = s (A_m^T C_N A_1 + B_m^T C_M B_1) + (Sg + Sk)/2,  pd = s B_m^T C_M H_1^T + Q^T/2,
//                   dp = s H_m C_M B_1 + Q/2,  dd = s H_m C_M H_1^T
// with P = d(E N)/dPsi, Q = d(H M)/dPsi, Sg + Sk = d(A^T N + B^T M)/dPsi at q_mid for the stresses S of the output.
struct MidpointGaussBlocks {
  double wJ;
  Mat3   rr, rp, pr, pp, pd, dp, dd;
};

// K = Tbar^T K_loc T_{n+1} + (delta Tbar^T) h for one output (mc or corr), row-major 6 NN x 6 NN,
// with the maps of the iterate (per non-reference node, by slot: node others[o]; so are the local
// gradients h_rho, h_psi): Tbar (mid-point, maps the forces) and T_{n+1} (end, maps the variations),
//   delta rho_a = L^T (dx_a - dx_c) + L^T hat(d_a) dtheta_c,   delta psi_a = P_a (dtheta_a - dtheta_c),  P_a = Hinv(psi_a) L^T.
template <int NN>
void MidpointTangent(const BeamElementReference &ref, const int *others, const MidpointGaussBlocks *blocks, const BeamMidpointIterate<NN> &maps,
                     const Vec3 *h_rho, const Vec3 *h_psi, double *tangent_out)
{
  const int                   c = ref.reference_node;
  Eigen::Map<NodalMatrix<NN>> K(tangent_out);
  K.setZero();
  auto add = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) += block; };
  auto sub = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) -= block; }; // no negated temporary
  for (int o = 0; o < NN - 1; ++o) {
    const int a = others[o];
    for (int ob = 0; ob < NN - 1; ++ob) {
      const int b   = others[ob];
      Mat3      Krr = Mat3::Zero(), Krp = Mat3::Zero(), Kpr = Mat3::Zero(), Kpp = Mat3::Zero();
      for (int gp = 0; gp < ref.num_gauss; ++gp) {
        const MidpointGaussBlocks &G  = blocks[gp];
        const double              *I  = ref.shape[gp];
        const double              *dI = ref.shape_derivative[gp];
        Krr += (G.wJ * dI[a] * dI[b]) * G.rr;
        Krp += (G.wJ * dI[a] * I[b]) * G.rp;
        Kpr += (G.wJ * I[a] * dI[b]) * G.pr;
        Kpp += G.wJ * (I[a] * I[b] * G.pp + I[a] * dI[b] * G.pd + dI[a] * I[b] * G.dp + dI[a] * dI[b] * G.dd);
      }
      // Tbar^T (rows) and T_{n+1} (columns) of the local block: rows x_a = Lbar (.), theta_a = PbarT_a (.),
      // x_c = -x_a, theta_c = -dbar_a x x_a - theta_a; columns x_b = (.)_rho L^T, theta_b = (.)_psi P_b,
      // x_c = -x_b, theta_c = x_b hat(d_b) - theta_b.
      const Mat3 LKrr = Mul(maps.Lbar, Krr), LKrp = Mul(maps.Lbar, Krp), PKpr = Mul(maps.PbarT[o], Kpr), PKpp = Mul(maps.PbarT[o], Kpp);
      const Mat3 Nxx = MulT(LKrr, maps.L), Nxt = Mul(LKrp, maps.P[ob]), Ntx = MulT(PKpr, maps.L), Ntt = Mul(PKpp, maps.P[ob]);
      const Mat3 Nxc = TimesSkew(Nxx, maps.d[ob]) - Nxt, Ntc = TimesSkew(Ntx, maps.d[ob]) - Ntt; // theta_c columns
      // theta_c rows, negated: -C = hat(dbar_a) N + N_t
      const Mat3 mCxx = SkewTimes(maps.dbar[o], Nxx) + Ntx, mCxt = SkewTimes(maps.dbar[o], Nxt) + Ntt, mCxc = SkewTimes(maps.dbar[o], Nxc) + Ntc;
      const int  ax = 6 * a, at = 6 * a + 3, bx = 6 * b, bt = 6 * b + 3, cx = 6 * c, ct = 6 * c + 3;
      add(ax, bx, Nxx), add(ax, bt, Nxt), sub(ax, cx, Nxx), add(ax, ct, Nxc);
      add(at, bx, Ntx), add(at, bt, Ntt), sub(at, cx, Ntx), add(at, ct, Ntc);
      sub(cx, bx, Nxx), sub(cx, bt, Nxt), add(cx, cx, Nxx), sub(cx, ct, Nxc);
      sub(ct, bx, mCxx), sub(ct, bt, mCxt), add(ct, cx, mCxx), sub(ct, ct, mCxc);
    }
  }
  // Variation of Tbar at fixed h, with g_a = L h_rho_a, w_a = L Hinv(psi_mid)^T h_psi_a:
  //   delta f_a = -hat(g_a) dtheta_c / 2
  //   delta m_a = -hat(w_a) dtheta_c / 2 + W_a (dtheta_a - dtheta_c),  W_a = Lbar d(Hinv^T h_psi_a)/dpsi|_mid P_a / 2
  //   delta (-dbar_a x f_a) = hat(f_a) (dx_a - dx_c) / 2 - hat(dbar_a) delta f_a
  for (int o = 0; o < NN - 1; ++o) {
    const int            a  = others[o];
    const Vec3           g  = maps.L * h_rho[o];
    const Vec3           f  = maps.Lbar * h_rho[o];
    const Vec3           w  = maps.L * (maps.HinvT_mid[o] * h_psi[o]);
    const RodriguesForm &Fi = maps.Finv_mid[o];
    const Vec3          &pm = maps.psi_mid[o];
    const Mat3           J  = JacobianMatrix(Fi.alpha, Fi.beta, pm, h_psi[o], JacobianShift(Fi.alpha_x, Fi.beta, Fi.beta_x, pm, h_psi[o])); // d(Hinv^T h)/dpsi
    const Mat3           W  = 0.5 * Mul(Mul(maps.Lbar, J), maps.P[o]);
    const Mat3           hg = 0.5 * Skew(g), hf = 0.5 * Skew(f), hw = 0.5 * Skew(w);
    const int            ax = 6 * a, at = 6 * a + 3, cx = 6 * c, ct = 6 * c + 3;
    K.template block<3, 3>(ax, ct) -= hg;
    K.template block<3, 3>(cx, ct) += hg;
    K.template block<3, 3>(at, at) += W;
    K.template block<3, 3>(at, ct) -= hw + W;
    K.template block<3, 3>(ct, at) -= W;
    K.template block<3, 3>(ct, ct) += hw + W + SkewTimes(maps.dbar[o], hg);
    K.template block<3, 3>(ct, ax) += hf;
    K.template block<3, 3>(ct, cx) -= hf;
  }
}

// The residual half of the mid-point kernel (BeamMidpointInternalForces): F_mc, F_corr, the
// energies and, with end_residual_out, r_{n+1}; what the tangent needs as well goes into *it.
// for_tangent: the mid-point series with second derivatives and the end maps P_a, which only the
// tangent reads.
template <int NN>
BeamKernelStatus MidpointResidualPhase(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointStart &start,
                                       const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction, double *end_residual_out,
                                       double *energy_start_out, double *energy_end_out, EnergyCorrection correction, bool for_tangent,
                                       BeamMidpointIterate<NN> *it)
{
  const int  c                  = ref.reference_node;
  const bool correction_moments = correction == EnergyCorrection::Resultants; // (N_d, M_d), else (N_d, 0)
  Vec3       rho_1[NN], psi_1[NN], rho_m[NN], psi_m[NN];
  if (!LocalCoordinates(NN, c, positions, triads, rho_1, psi_1)) return BeamKernelStatus::RotationTooLarge;
  int others[NN - 1];
  NonReferenceNodes<NN>(c, others);
  for (int a = 0; a < NN; ++a) {
    rho_m[a] = 0.5 * (start.rho[a] + rho_1[a]);
    psi_m[a] = 0.5 * (start.psi[a] + psi_1[a]);
  }
  const bool  want_end        = for_tangent || end_residual_out; // the end-point operators A_1, B_1
  const bool  want_correction = force_correction != nullptr;     // em's F_corr (mc has no use for it)
  const Vec3 &CN = section.axial_shear, &CM = section.torsion_bending;
  // Local gradients per non-reference node, by its slot o (node others[o]).
  Vec3 *h_rho = it->h_rho, *h_psi = it->h_psi, *k_rho = it->k_rho, *k_psi = it->k_psi;
  Vec3  g_rho[NN - 1], g_psi[NN - 1];
  for (int o = 0; o < NN - 1; ++o) h_rho[o].setZero(), h_psi[o].setZero(), k_rho[o].setZero(), k_psi[o].setZero(), g_rho[o].setZero(), g_psi[o].setZero();
  double energy_n = 0.0, energy_1 = 0.0;
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const double *I = ref.shape[gp], *dI = ref.shape_derivative[gp];
    const double  wJ = ref.weight_jacobian[gp];
    auto         &pt = it->point[gp];
    pt.wJ            = wJ;
    // Start and end of the step: strains and stresses (the operators applied in closed form, no
    // 3x3 matrix unless the tangent needs it).
    const Vec3               eps_n   = start.strain[gp] - ref.strain0[gp];
    const Vec3               kap_n   = start.curvature[gp] - ref.curvature0[gp];
    const GaussInterpolation end     = InterpolateAtGauss(ref, gp, rho_1, psi_1);
    const double             x1      = end.Psi.squaredNorm();
    const RotationSeries     series1 = ElementRotationSeries(x1, 1, false);
    const RodriguesForm      Fe1 = ExpForm(series1), Fh1 = TangentForm(series1);
    const Vec3               eps_1 = FormTransposeTimes(Fe1.alpha, Fe1.beta, end.Psi, x1, end.drho) - ref.strain0[gp];
    const Vec3               kap_1 = FormTransposeTimes(Fh1.alpha, Fh1.beta, end.Psi, x1, end.dPsi) - ref.curvature0[gp];
    const Vec3               N_n = CN.cwiseProduct(eps_n), M_n = CM.cwiseProduct(kap_n), N_1 = CN.cwiseProduct(eps_1), M_1 = CM.cwiseProduct(kap_1);
    energy_n += 0.5 * wJ * (eps_n.dot(N_n) + kap_n.dot(M_n));
    energy_1 += 0.5 * wJ * (eps_1.dot(N_1) + kap_1.dot(M_1));
    pt.Psi1 = end.Psi, pt.dPsi1 = end.dPsi, pt.drho1 = end.drho, pt.x1 = x1, pt.Fe1 = Fe1, pt.Fh1 = Fh1;
    pt.N_mid = 0.5 * (N_n + N_1), pt.M_mid = 0.5 * (M_n + M_1), pt.N_d = N_1 - N_n, pt.M_d = correction_moments ? Vec3(M_1 - M_n) : Vec3::Zero();
    // D(q_mid): dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'  (A = d(E^T drho)/dPsi, B = d(H^T dPsi)/dPsi)
    const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho_m, psi_m);
    const double         x       = Psi.squaredNorm();
    const RotationSeries series  = ElementRotationSeries(x, 1, for_tangent);
    const RodriguesForm  Fe = ExpForm(series), Fh = TangentForm(series);
    const Vec3           ue = JacobianShift(Fe.alpha_x, Fe.beta, Fe.beta_x, Psi, drho), uh = JacobianShift(Fh.alpha_x, Fh.beta, Fh.beta_x, Psi, dPsi);
    pt.Psi = Psi, pt.dPsi = dPsi, pt.drho = drho, pt.x = x, pt.Fe = Fe, pt.Fh = Fh, pt.ue = ue, pt.uh = uh;
    // D(q_mid)^T (N, M) as the local gradient's three parts: E N, A^T N + B^T M, H M.
    auto gradient = [&](const Vec3 &N, const Vec3 &M, Vec3 *EN, Vec3 *AN_BM, Vec3 *HM) {
      *EN    = FormTimes(Fe.alpha, Fe.beta, Psi, x, N);
      *AN_BM = JacobianTransposeTimes(Fe.alpha, Fe.beta, Psi, drho, ue, N) + JacobianTransposeTimes(Fh.alpha, Fh.beta, Psi, dPsi, uh, M);
      *HM    = FormTimes(Fh.alpha, Fh.beta, Psi, x, M);
    };
    Vec3 EN, AN_BM, HM, ENd, ANd, HMd;
    gradient(pt.N_mid, pt.M_mid, &EN, &AN_BM, &HM);
    for (int o = 0; o < NN - 1; ++o) {
      const int a = others[o];
      h_rho[o] += wJ * dI[a] * EN;
      h_psi[o] += wJ * (I[a] * AN_BM + dI[a] * HM);
    }
    if (want_correction) {
      gradient(pt.N_d, pt.M_d, &ENd, &ANd, &HMd);
      for (int o = 0; o < NN - 1; ++o) {
        const int a = others[o];
        k_rho[o] += wJ * dI[a] * ENd;
        k_psi[o] += wJ * (I[a] * ANd + dI[a] * HMd);
      }
    }
    if (!want_end) continue;
    pt.ue1 = JacobianShift(Fe1.alpha_x, Fe1.beta, Fe1.beta_x, end.Psi, end.drho);
    pt.uh1 = JacobianShift(Fh1.alpha_x, Fh1.beta, Fh1.beta_x, end.Psi, end.dPsi);
    if (end_residual_out) {
      const Vec3 EN1 = FormTimes(Fe1.alpha, Fe1.beta, end.Psi, x1, N_1), HM1 = FormTimes(Fh1.alpha, Fh1.beta, end.Psi, x1, M_1);
      const Vec3 AN_BM1 = JacobianTransposeTimes(Fe1.alpha, Fe1.beta, end.Psi, end.drho, pt.ue1, N_1) +
                          JacobianTransposeTimes(Fh1.alpha, Fh1.beta, end.Psi, end.dPsi, pt.uh1, M_1);
      for (int o = 0; o < NN - 1; ++o) {
        const int a = others[o];
        g_rho[o] += wJ * dI[a] * EN1;
        g_psi[o] += wJ * (I[a] * AN_BM1 + dI[a] * HM1);
      }
    }
  }
  if (energy_start_out) *energy_start_out = energy_n;
  if (energy_end_out) *energy_end_out = energy_1;

  BeamMidpointIterate<NN> &maps = *it;
  maps.Lbar                     = 0.5 * (start.triad_c + triads[c]);
  maps.L                        = triads[c];
  for (int i = 0; i < 6 * NN; ++i) force_mc[i] = 0.0;
  if (want_correction)
    for (int i = 0; i < 6 * NN; ++i) force_correction[i] = 0.0;
  if (end_residual_out)
    for (int i = 0; i < 6 * NN; ++i) end_residual_out[i] = 0.0;
  for (int o = 0; o < NN - 1; ++o) {
    const int a       = others[o];
    maps.dbar[o]      = 0.5 * (start.d[a] + (positions[a] - positions[c]));
    maps.d[o]         = positions[a] - positions[c];
    maps.psi_mid[o]   = psi_m[a];
    maps.Finv_mid[o]  = TangentInverseForm(ElementRotationSeries(psi_m[a].squaredNorm(), 2, for_tangent));
    maps.HinvT_mid[o] = RodriguesMatrix(maps.Finv_mid[o], psi_m[a]).transpose();
    maps.PbarT[o]     = Mul(maps.Lbar, maps.HinvT_mid[o]); // (H^{-1}(psi_mid) Lbar^T)^T
    for (int which = 0; which < (want_correction ? 2 : 1); ++which) {
      double     *out = which == 0 ? force_mc : force_correction;
      const Vec3 &hr = which == 0 ? h_rho[o] : k_rho[o], &hp = which == 0 ? h_psi[o] : k_psi[o];
      // theta_c: (Lbar^T hat(dbar))^T hr - m = -dbar x f - m
      const Vec3 f = maps.Lbar * hr, m = maps.PbarT[o] * hp, mc = -maps.dbar[o].cross(f) - m;
      for (int i = 0; i < 3; ++i) {
        out[6 * a + i] += f(i);
        out[6 * a + 3 + i] += m(i);
        out[6 * c + i] -= f(i);
        out[6 * c + 3 + i] += mc(i);
      }
    }
    if (!want_end) continue;
    maps.P[o] = MulT(RodriguesMatrix(TangentInverseForm(ElementRotationSeries(psi_1[a].squaredNorm(), 2, false)), psi_1[a]), maps.L);
    if (end_residual_out) {
      // r_{n+1} = T_{n+1}^T g: the gradient of the end strain energy (as BeamInternalForces).
      const Vec3 f = maps.L * g_rho[o], m = maps.P[o].transpose() * g_psi[o], mc = -maps.d[o].cross(f) - m; // (L^T hat(d))^T g - m
      for (int i = 0; i < 3; ++i) {
        end_residual_out[6 * a + i] += f(i);
        end_residual_out[6 * a + 3 + i] += m(i);
        end_residual_out[6 * c + i] -= f(i);
        end_residual_out[6 * c + 3 + i] += mc(i);
      }
    }
  }
  return BeamKernelStatus::Ok;
}

// The tangent half: the Gauss blocks of s D(q_mid)^T C D(q_{n+1}) + G(q_mid, S)/2 from the
// iterate's operators, then MidpointTangent (K_mc + beta K_corr at once with combined_beta).
template <int NN>
void MidpointTangentPhase(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointIterate<NN> &it, EnergyCorrection correction,
                          const double *combined_beta, double *tangent_mc, double *tangent_correction)
{
  if (combined_beta) tangent_correction = nullptr;
  const int c = ref.reference_node;
  int       others[NN - 1];
  NonReferenceNodes<NN>(c, others);
  const Vec3         &CN = section.axial_shear, &CM = section.torsion_bending;
  const double        m = correction == EnergyCorrection::Resultants ? 1.0 : 0.0;
  MidpointGaussBlocks blocks_mc[NN - 1], blocks_corr[NN - 1];
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const auto  &pt  = it.point[gp];
    const Vec3  &Psi = pt.Psi, &dPsi = pt.dPsi, &drho = pt.drho;
    const double x  = pt.x;
    const auto  &Fe = pt.Fe, &Fh = pt.Fh, &Fe1 = pt.Fe1, &Fh1 = pt.Fh1;
    const Mat3   E = RodriguesMatrix(Fe.alpha, Fe.beta, Psi, x), H = RodriguesMatrix(Fh.alpha, Fh.beta, Psi, x);
    const Mat3   A = JacobianMatrix(Fe.alpha, Fe.beta, Psi, drho, pt.ue), B = JacobianMatrix(Fh.alpha, Fh.beta, Psi, dPsi, pt.uh);
    const Mat3   E1 = RodriguesMatrix(Fe1.alpha, Fe1.beta, pt.Psi1, pt.x1), H1 = RodriguesMatrix(Fh1.alpha, Fh1.beta, pt.Psi1, pt.x1);
    const Mat3   A1 = JacobianMatrix(Fe1.alpha, Fe1.beta, pt.Psi1, pt.drho1, pt.ue1), B1 = JacobianMatrix(Fh1.alpha, Fh1.beta, pt.Psi1, pt.dPsi1, pt.uh1);
    // Material part D(q_mid)^T C D(q_{n+1}), shared by both outputs.
    const Mat3 ECN = E * CN.asDiagonal(), ACN = A.transpose() * CN.asDiagonal(), BCM = B.transpose() * CM.asDiagonal(), HCM = H * CM.asDiagonal();
    const Mat3 rr = MulT(ECN, E1), rp = Mul(ECN, A1), pr = MulT(ACN, E1), pp_forces = Mul(ACN, A1);
    const Mat3 pd = MulT(BCM, H1), dp = Mul(HCM, B1), dd = MulT(HCM, H1), pp_moments = Mul(BCM, B1);
    // Blocks for the stresses (N, M) of the geometric part G(q_mid, S)/2 (P = d(E N)/dPsi,
    // Q = d(H M)/dPsi, Sg the Hessian of N.E^T drho + M.H^T dPsi), the material part weighted
    // s_forces (terms of the force resultants) and s_moments (of the moments): 1/2 and 1/2 for mc,
    // 1 and m for the correction (m = 0 drops the moments' variation: the (N_d, 0) correction).
    // The blocks are linear in (s, N, M), so those of K_mc + beta K_corr are one fill with
    // 1/2 + beta, 1/2 + beta m and S_mid + beta S_d.
    auto fill = [&](MidpointGaussBlocks *G, double s_forces, double s_moments, const Vec3 &N, const Vec3 &M) {
      const Mat3 P  = JacobianMatrix(-Fe.alpha, Fe.beta, Psi, N, JacobianShift(-Fe.alpha_x, Fe.beta, Fe.beta_x, Psi, N));
      const Mat3 Q  = JacobianMatrix(-Fh.alpha, Fh.beta, Psi, M, JacobianShift(-Fh.alpha_x, Fh.beta, Fh.beta_x, Psi, M));
      const Mat3 Sg = StressHessian(Fe, Fh, Psi, x, drho, N, dPsi, M);
      G->wJ         = pt.wJ;
      G->rr         = s_forces * rr;
      G->rp         = s_forces * rp + 0.5 * P;
      G->pr         = s_forces * pr + 0.5 * P.transpose();
      G->pp         = s_forces * pp_forces + s_moments * pp_moments + 0.5 * Sg;
      G->pd         = s_moments * pd + 0.5 * Q.transpose();
      G->dp         = s_moments * dp + 0.5 * Q;
      G->dd         = s_moments * dd;
    };
    if (combined_beta) {
      const double beta = *combined_beta;
      fill(&blocks_mc[gp], 0.5 + beta, 0.5 + beta * m, pt.N_mid + beta * pt.N_d, pt.M_mid + beta * pt.M_d);
      continue;
    }
    if (tangent_mc) fill(&blocks_mc[gp], 0.5, 0.5, pt.N_mid, pt.M_mid);
    if (tangent_correction) fill(&blocks_corr[gp], 1.0, m, pt.N_d, pt.M_d);
  }
  // With beta given, blocks_mc combine both tangents; so must the local gradients of the maps'
  // variation (the forces are already out).
  Vec3 h_rho[NN - 1], h_psi[NN - 1];
  for (int o = 0; o < NN - 1; ++o) {
    h_rho[o] = it.h_rho[o], h_psi[o] = it.h_psi[o];
    if (combined_beta) h_rho[o] += *combined_beta * it.k_rho[o], h_psi[o] += *combined_beta * it.k_psi[o];
  }
  if (tangent_mc) MidpointTangent<NN>(ref, others, blocks_mc, it, h_rho, h_psi, tangent_mc);
  if (tangent_correction) MidpointTangent<NN>(ref, others, blocks_corr, it, it.k_rho, it.k_psi, tangent_correction);
}

template <int NN>
BeamKernelStatus MidpointForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start, const Mat3 *triads_start,
                                const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction, double *tangent_mc,
                                double *tangent_correction, double *end_residual_out, double *energy_start_out, double *energy_end_out,
                                EnergyCorrection correction, const double *combined_beta, const BeamMidpointStart *start)
{
  if (combined_beta) tangent_correction = nullptr;
  double correction_scratch[6 * NN]; // the correction's tangents are built from its gradient
  if (!force_correction && (tangent_correction || combined_beta)) force_correction = correction_scratch;
  BeamMidpointStart computed;
  if (!start) {
    if (BeamMidpointStartState(ref, positions_start, triads_start, &computed) != BeamKernelStatus::Ok) return BeamKernelStatus::RotationTooLarge;
    start = &computed;
  }
  const bool              want_tangent = tangent_mc || tangent_correction;
  BeamMidpointIterate<NN> it;
  const BeamKernelStatus  status = MidpointResidualPhase<NN>(ref, section, *start, positions, triads, force_mc, force_correction, end_residual_out,
                                                            energy_start_out, energy_end_out, correction, want_tangent, &it);
  if (status != BeamKernelStatus::Ok) return status;
  if (want_tangent) MidpointTangentPhase<NN>(ref, section, it, correction, combined_beta, tangent_mc, tangent_correction);
  return BeamKernelStatus::Ok;
}

} // namespace

BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *tangent_mc, double *tangent_correction, double *end_residual, double *strain_energy_start,
                                            double *strain_energy_end, EnergyCorrection correction, const double *combined_beta, const BeamMidpointStart *start)
{
  if (ref.num_nodes == 2)
    return MidpointForces<2>(ref, section, positions_start, triads_start, positions, triads, force_mc, force_correction, tangent_mc, tangent_correction,
                             end_residual, strain_energy_start, strain_energy_end, correction, combined_beta, start);
  return MidpointForces<3>(ref, section, positions_start, triads_start, positions, triads, force_mc, force_correction, tangent_mc, tangent_correction,
                           end_residual, strain_energy_start, strain_energy_end, correction, combined_beta, start);
}

BeamKernelStatus BeamMidpointStartState(const BeamElementReference &ref, const Vec3 *positions_start, const Mat3 *triads_start, BeamMidpointStart *start)
{
  const int c = ref.reference_node;
  if (!LocalCoordinates(ref.num_nodes, c, positions_start, triads_start, start->rho, start->psi)) return BeamKernelStatus::RotationTooLarge;
  start->triad_c = triads_start[c];
  for (int a = 0; a < ref.num_nodes; ++a) start->d[a] = positions_start[a] - positions_start[c];
  for (int gp = 0; gp < ref.num_gauss; ++gp) GaussDeformation(ref, gp, start->rho, start->psi, &start->strain[gp], &start->curvature[gp]);
  return BeamKernelStatus::Ok;
}

template <int NN>
BeamKernelStatus BeamMidpointResidualKeeping(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointStart &start,
                                             const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction, double *end_residual,
                                             double *strain_energy_start, double *strain_energy_end, EnergyCorrection correction,
                                             BeamMidpointIterate<NN> *iterate)
{
  if (ref.num_nodes != NN) return BeamKernelStatus::DegenerateGeometry;
  return MidpointResidualPhase<NN>(ref, section, start, positions, triads, force_mc, force_correction, end_residual, strain_energy_start, strain_energy_end,
                                   correction, true, iterate);
}

template <int NN>
void BeamMidpointTangentOfIterate(const BeamElementReference &ref, const BeamSectionStiffness &section, const BeamMidpointIterate<NN> &iterate,
                                  EnergyCorrection correction, const double *combined_beta, double *tangent_mc, double *tangent_correction)
{
  MidpointTangentPhase<NN>(ref, section, iterate, correction, combined_beta, tangent_mc, tangent_correction);
}

template BeamKernelStatus BeamMidpointResidualKeeping<2>(const BeamElementReference &, const BeamSectionStiffness &, const BeamMidpointStart &, const Vec3 *,
                                                         const Mat3 *, double *, double *, double *, double *, double *, EnergyCorrection,
                                                         BeamMidpointIterate<2> *);
template BeamKernelStatus BeamMidpointResidualKeeping<3>(const BeamElementReference &, const BeamSectionStiffness &, const BeamMidpointStart &, const Vec3 *,
                                                         const Mat3 *, double *, double *, double *, double *, double *, EnergyCorrection,
                                                         BeamMidpointIterate<3> *);
template void BeamMidpointTangentOfIterate<2>(const BeamElementReference &, const BeamSectionStiffness &, const BeamMidpointIterate<2> &, EnergyCorrection,
                                              const double *, double *, double *);
template void BeamMidpointTangentOfIterate<3>(const BeamElementReference &, const BeamSectionStiffness &, const BeamMidpointIterate<3> &, EnergyCorrection,
                                              const double *, double *, double *);

BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *strain_energy_start, double *strain_energy_end)
{
  return BeamMidpointInternalForces(ref, section, positions_start, triads_start, positions, triads, force_mc, force_correction, nullptr, nullptr, nullptr,
                                    strain_energy_start, strain_energy_end);
}

BeamKernelStatus BeamElementSetup(int num_nodes, const Vec3 *reference_positions, const Mat3 *reference_triads, BeamElementReference *ref)
{
  if (num_nodes != 2 && num_nodes != 3) return BeamKernelStatus::DegenerateGeometry;
  ref->num_nodes                  = num_nodes;
  ref->num_gauss                  = num_nodes - 1; // reduced integration
  ref->reference_node             = (num_nodes == 2) ? 0 : 1;
  const double gauss_point[2][2]  = {{0.0, 0.0}, {-1.0 / std::sqrt(3.0), 1.0 / std::sqrt(3.0)}};
  const double gauss_weight[2][2] = {{2.0, 0.0}, {1.0, 1.0}};

  // Scale for the degeneracy test: the element's extent.
  double extent = 0.0;
  for (int a = 1; a < num_nodes; ++a) extent = std::max(extent, (reference_positions[a] - reference_positions[0]).norm());
  if (!(extent > 0.0)) return BeamKernelStatus::DegenerateGeometry;

  Vec3 rho[kBeamMaxNodes], psi[kBeamMaxNodes];
  if (!LocalCoordinates(num_nodes, ref->reference_node, reference_positions, reference_triads, rho, psi)) return BeamKernelStatus::RotationTooLarge;

  for (int gp = 0; gp < ref->num_gauss; ++gp) {
    double I[kBeamMaxNodes], dI_dxi[kBeamMaxNodes];
    LagrangeShape(num_nodes, gauss_point[num_nodes - 2][gp], I, dI_dxi);
    Vec3 dX_dxi = Vec3::Zero();
    for (int a = 0; a < num_nodes; ++a) dX_dxi += dI_dxi[a] * reference_positions[a];
    const double jacobian = dX_dxi.norm();
    if (jacobian < 1e-12 * extent) return BeamKernelStatus::DegenerateGeometry;
    ref->weight_jacobian[gp] = gauss_weight[num_nodes - 2][gp] * jacobian;
    for (int a = 0; a < num_nodes; ++a) {
      ref->shape[gp][a]            = I[a];
      ref->shape_derivative[gp][a] = dI_dxi[a] / jacobian;
    }
    const auto [Psi, dPsi, drho] = InterpolateAtGauss(*ref, gp, rho, psi);
    ref->strain0[gp]             = ExpSO3(Psi).transpose() * drho;
    ref->curvature0[gp]          = TangentH(Psi).transpose() * dPsi;
  }

  // Length, consistent nodal lengths and mass integrals with 3-point Gauss (exact for straight
  // elements: I_a I_b is at most quartic).
  const double xi3[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w3[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  ref->length = 0.0;
  for (int a = 0; a < kBeamMaxNodes; ++a) {
    ref->nodal_length[a] = 0.0;
    for (int b = 0; b < kBeamMaxNodes; ++b) ref->mass_shape[a][b] = 0.0;
  }
  for (int q = 0; q < 3; ++q) {
    double I[kBeamMaxNodes], dI_dxi[kBeamMaxNodes];
    LagrangeShape(num_nodes, xi3[q], I, dI_dxi);
    Vec3 dX_dxi = Vec3::Zero();
    for (int a = 0; a < num_nodes; ++a) dX_dxi += dI_dxi[a] * reference_positions[a];
    const double ds = w3[q] * dX_dxi.norm();
    ref->length += ds;
    for (int a = 0; a < num_nodes; ++a) {
      ref->nodal_length[a] += I[a] * ds;
      for (int b = 0; b < num_nodes; ++b) ref->mass_shape[a][b] += I[a] * I[b] * ds;
    }
  }
  return BeamKernelStatus::Ok;
}

BeamKernelStatus BeamInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                    double *residual, double *tangent, double *strain_energy, BeamGaussResults *results)
{
  if (ref.num_nodes == 2) return InternalForces<2>(ref, section, positions, triads, residual, tangent, strain_energy, results);
  return InternalForces<3>(ref, section, positions, triads, residual, tangent, strain_energy, results);
}

BeamKernelStatus BeamAddInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                       double *residual, double *tangent, double *strain_energy)
{
  if (ref.num_nodes == 2) return InternalForces<2, true>(ref, section, positions, triads, residual, tangent, strain_energy, nullptr);
  return InternalForces<3, true>(ref, section, positions, triads, residual, tangent, strain_energy, nullptr);
}

} // namespace msflex
