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
    psi[a] = LogSO3(LcT * triads[a]);
    // log returns |psi| <= pi; a relative rotation this large inside one element is not resolvable.
    if (psi[a].norm() > 0.95 * kPi) return false;
  }
  return true;
}

// Interpolated local rotation Psi, its arc-length derivative Psi' and rho' at Gauss point gp.
struct GaussInterpolation {
  Vec3 Psi, dPsi, drho;
};
GaussInterpolation InterpolateAtGauss(const BeamElementReference &ref, int gp, const Vec3 *rho, const Vec3 *psi)
{
  GaussInterpolation g{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  for (int a = 0; a < ref.num_nodes; ++a) {
    g.Psi += ref.shape[gp][a] * psi[a];
    g.dPsi += ref.shape_derivative[gp][a] * psi[a];
    g.drho += ref.shape_derivative[gp][a] * rho[a];
  }
  return g;
}

template <int NN> using NodalMatrix = Eigen::Matrix<double, 6 * NN, 6 * NN, Eigen::RowMajor>;

// Per Gauss point, the 3x3 products from which every block of the local stiffness is a scalar
// combination (I_a, I'_a are the shape functions and derivatives at the point):
//   local gradient   g_rho_a = wJ I'_a E N,   g_psi_a = wJ [I_a (A^T N + B^T M) + I'_a H M]
//   material blocks  d(Gamma, K)/d(rho_a, psi_a) = [[I'_a E^T, I_a A], [0, I_a B + I'_a H^T]]
//   geometric blocks (rho_a, psi_b): I'_a I_b P;  (psi_a, psi_b): I_a I_b (Sg + Sk) + I'_a I_b Q + I_a I'_b Q^T
// with P = d(E N)/dPsi, Q = d(H M)/dPsi. The sums shared by every (a, b) pair are formed once per point.
struct GaussProducts {
  double wJ;
  Vec3   EN, AN_BM, HM; // E N, A^T N + B^T M, H M
  Mat3   ECE, HCH;      // E C_N E^T, H C_M H^T
  Mat3   ECA_P;         // E C_N A + P
  Mat3   ACA_BCB_S;     // A^T C_N A + B^T C_M B + Sg + Sk
  Mat3   BCH_QT;        // B^T C_M H^T + Q^T
};

template <int NN>
BeamKernelStatus InternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                double *residual_out, double *tangent_out, double *energy_out, BeamGaussResults *results)
{
  const int c = ref.reference_node;
  Vec3      rho[NN], psi[NN];
  if (!LocalCoordinates(NN, c, positions, triads, rho, psi)) return BeamKernelStatus::RotationTooLarge;
  int others[NN - 1];
  for (int a = 0, o = 0; a < NN; ++a)
    if (a != c) others[o++] = a;

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
    const RotationSeries series  = EvaluateRotationSeries(Psi.squaredNorm());
    const RodriguesForm  Fe      = ExpForm(series);
    const RodriguesForm  Fh      = TangentForm(series);
    const Mat3           E       = RodriguesMatrix(Fe, Psi);
    const Mat3           H       = RodriguesMatrix(Fh, Psi);
    const Vec3           eps     = E.transpose() * drho - ref.strain0[gp];    // Gamma - Gamma_0
    const Vec3           kap     = H.transpose() * dPsi - ref.curvature0[gp]; // K - K_0
    const Vec3           N       = CN.cwiseProduct(eps);
    const Vec3           M       = CM.cwiseProduct(kap);
    energy += 0.5 * G.wJ * (eps.dot(N) + kap.dot(M));
    if (results) {
      results->strain[gp]    = eps;
      results->curvature[gp] = kap;
      results->force[gp]     = N;
      results->moment[gp]    = M;
    }
    // dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'
    const Mat3 A = RodriguesTransposeApplyJacobian(Fe, Psi, drho);
    const Mat3 B = RodriguesTransposeApplyJacobian(Fh, Psi, dPsi);
    G.EN         = E * N;
    G.AN_BM      = A.transpose() * N + B.transpose() * M;
    G.HM         = H * M;
    for (int a : others) {
      g_rho[a] += G.wJ * dI[a] * G.EN;
      g_psi[a] += G.wJ * (I[a] * G.AN_BM + dI[a] * G.HM);
    }
    if (!want_tangent) continue;
    const Mat3 ECN = E * CN.asDiagonal(), ACN = A.transpose() * CN.asDiagonal();
    const Mat3 BCM = B.transpose() * CM.asDiagonal(), HCM = H * CM.asDiagonal();
    const Mat3 ECA = ECN * A, ACA = ACN * A, BCB = BCM * B, BCH = BCM * H.transpose();
    const Mat3 P = RodriguesApplyJacobian(Fe, Psi, N), Q = RodriguesApplyJacobian(Fh, Psi, M);
    const Mat3 S = RodriguesTransposeApplyHessian(Fe, Psi, drho, N) + RodriguesTransposeApplyHessian(Fh, Psi, dPsi, M);
    G.ECE        = ECN * E.transpose();
    G.HCH        = HCM * H.transpose();
    G.ECA_P      = ECA + P;
    G.ACA_BCB_S  = ACA + BCB + S;
    G.BCH_QT     = BCH + Q.transpose();
  }
  if (energy_out) *energy_out = energy;

  // Chain rule to nodal (x, theta), with d_a = x_a - x_c, L = Lambda_c:
  //   delta rho_a = L^T (dx_a - dx_c) + M_a dtheta_c,  M_a = L^T hat(d_a)
  //   delta psi_a = P_a (dtheta_a - dtheta_c),         P_a = Hinv(psi_a) L^T
  const Mat3                                  &L  = triads[c];
  const Mat3                                   LT = L.transpose();
  Mat3                                         Pm[NN], Mm[NN];
  RodriguesForm                                Finv[NN];
  Vec3                                         fa[NN], ma[NN]; // nodal force L g_rho_a and moment P_a^T g_psi_a
  Eigen::Map<Eigen::Matrix<double, 6 * NN, 1>> residual(residual_out);
  residual.setZero();
  for (int a : others) {
    Finv[a]       = TangentInverseForm(EvaluateRotationSeries(psi[a].squaredNorm()));
    Pm[a]         = RodriguesMatrix(Finv[a], psi[a]) * LT;
    Mm[a]         = LT * Skew(positions[a] - positions[c]);
    const Vec3 &f = fa[a] = L * g_rho[a];
    const Vec3 &m = ma[a] = Pm[a].transpose() * g_psi[a];
    residual.template segment<3>(6 * a) += f;
    residual.template segment<3>(6 * a + 3) += m;
    residual.template segment<3>(6 * c) -= f;
    residual.template segment<3>(6 * c + 3) += Mm[a].transpose() * g_rho[a] - m;
  }
  if (!want_tangent) return BeamKernelStatus::Ok;

  Eigen::Map<NodalMatrix<NN>> K(tangent_out);
  K.setZero();
  for (int a : others) {
    for (int b : others) {
      // Local stiffness blocks of (a, b), summed over the Gauss points.
      Mat3 Krr = Mat3::Zero(), Krp = Mat3::Zero(), Kpr = Mat3::Zero(), Kpp = Mat3::Zero();
      for (int gp = 0; gp < ref.num_gauss; ++gp) {
        const GaussProducts &G  = gauss[gp];
        const double        *I  = ref.shape[gp];
        const double        *dI = ref.shape_derivative[gp];
        Krr += (G.wJ * dI[a] * dI[b]) * G.ECE;
        Krp += (G.wJ * dI[a] * I[b]) * G.ECA_P;
        Kpr += (G.wJ * I[a] * dI[b]) * G.ECA_P.transpose();
        Kpp += G.wJ * (I[a] * I[b] * G.ACA_BCB_S + I[a] * dI[b] * G.BCH_QT + dI[a] * I[b] * G.BCH_QT.transpose() + dI[a] * dI[b] * G.HCH);
      }
      const Mat3 PaT  = Pm[a].transpose();
      const Mat3 LKrr = L * Krr, LKrp = L * Krp, PKpr = PaT * Kpr, PKpp = PaT * Kpp;
      const Mat3 Nxx = LKrr * LT, Nxt = LKrp * Pm[b], Ntx = PKpr * LT, Ntt = PKpp * Pm[b];
      // The rank-3 part of the map (M_b on dtheta_c) adds to the columns and rows of theta_c.
      const Mat3 Cx = LKrr * Mm[b], Ct = PKpr * Mm[b];
      const Mat3 MaT = Mm[a].transpose();
      const Mat3 Rx = MaT * Krr * LT, Rt = MaT * Krp * Pm[b], Ecc = MaT * Krr * Mm[b];
      auto       add = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) += block; };
      const int  ax = 6 * a, at = 6 * a + 3, bx = 6 * b, bt = 6 * b + 3, cx = 6 * c, ct = 6 * c + 3;
      add(ax, bx, Nxx), add(ax, bt, Nxt), add(at, bx, Ntx), add(at, bt, Ntt);
      add(ax, cx, -Nxx), add(ax, ct, Cx - Nxt), add(at, cx, -Ntx), add(at, ct, Ct - Ntt);
      add(cx, bx, -Nxx), add(cx, bt, -Nxt), add(ct, bx, Rx - Ntx), add(ct, bt, Rt - Ntt);
      add(cx, cx, Nxx), add(cx, ct, Nxt - Cx), add(ct, cx, Ntx - Rx), add(ct, ct, Ntt - Ct - Rt + Ecc);
    }
  }
  // Terms from the configuration dependence of the map at fixed local gradient g:
  //   f_a = L g_rho_a, m_a = P_a^T g_psi_a, G_a = L d(Hinv^T g_psi)/dpsi P_a.
  for (int a : others) {
    const Vec3 &f = fa[a], &m = ma[a];
    const Mat3  Ga = L * RodriguesTransposeApplyJacobian(Finv[a], psi[a], g_psi[a]) * Pm[a];
    const Vec3  d  = positions[a] - positions[c];
    const Mat3  hf = Skew(f), hm = Skew(m);
    K.template block<3, 3>(6 * a, 6 * c + 3) -= hf;
    K.template block<3, 3>(6 * c, 6 * c + 3) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * a) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * c) -= hf;
    K.template block<3, 3>(6 * c + 3, 6 * c + 3) += Skew(d) * hf + hm + Ga;
    K.template block<3, 3>(6 * a + 3, 6 * c + 3) -= hm + Ga;
    K.template block<3, 3>(6 * a + 3, 6 * a + 3) += Ga;
    K.template block<3, 3>(6 * c + 3, 6 * a + 3) -= Ga;
  }
  return BeamKernelStatus::Ok;
}

// Strains (Gamma - Gamma_0, K - K_0) at a Gauss point from the local coordinates.
void GaussStrains(const BeamElementReference &ref, int gp, const Vec3 *rho, const Vec3 *psi, Vec3 *strain, Vec3 *curvature)
{
  const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho, psi);
  const RotationSeries series  = EvaluateRotationSeries(Psi.squaredNorm());
  *strain                      = RodriguesMatrix(ExpForm(series), Psi).transpose() * drho - ref.strain0[gp];
  *curvature                   = RodriguesMatrix(TangentForm(series), Psi).transpose() * dPsi - ref.curvature0[gp];
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

// The maps between nodal variations and local coordinates: Tbar (mid-point, maps the forces) and
// T_{n+1} (end, maps the variations):
//   delta rho_a = L^T (dx_a - dx_c) + L^T hat(d_a) dtheta_c,   delta psi_a = P_a (dtheta_a - dtheta_c),  P_a = Hinv(psi_a) L^T.
template <int NN> struct MidpointMaps {
  Mat3          Lbar, L, LT;
  Vec3          d[NN], dbar[NN], psi_mid[NN];
  Mat3          P[NN];         // Hinv(psi_{a,n+1}) L^T
  Mat3          HinvT_mid[NN]; // Hinv(psi_{a,mid})^T
  Mat3          PbarT[NN];     // Lbar Hinv(psi_{a,mid})^T
  RodriguesForm Finv_mid[NN];
};

// K = Tbar^T K_loc T_{n+1} + (delta Tbar^T) h for one output (mc or corr), row-major 6 NN x 6 NN.
template <int NN>
void MidpointTangent(const BeamElementReference &ref, const int *others, const MidpointGaussBlocks *blocks, const MidpointMaps<NN> &maps, const Vec3 *h_rho,
                     const Vec3 *h_psi, double *tangent_out)
{
  const int                   c = ref.reference_node;
  Eigen::Map<NodalMatrix<NN>> K(tangent_out);
  K.setZero();
  auto add = [&K](int row, int column, const Mat3 &block) { K.template block<3, 3>(row, column) += block; };
  for (int o = 0; o < NN - 1; ++o) {
    const int  a     = others[o];
    const Mat3 hdbar = Skew(maps.dbar[a]);
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
      const Mat3 LKrr = maps.Lbar * Krr, LKrp = maps.Lbar * Krp, PKpr = maps.PbarT[a] * Kpr, PKpp = maps.PbarT[a] * Kpp;
      const Mat3 Nxx = LKrr * maps.LT, Nxt = LKrp * maps.P[b], Ntx = PKpr * maps.LT, Ntt = PKpp * maps.P[b];
      const Mat3 hd  = Skew(maps.d[b]);
      const Mat3 Nxc = Nxx * hd - Nxt, Ntc = Ntx * hd - Ntt;                                   // theta_c columns
      const Mat3 Cxx = -hdbar * Nxx - Ntx, Cxt = -hdbar * Nxt - Ntt, Cxc = -hdbar * Nxc - Ntc; // theta_c rows
      const int  ax = 6 * a, at = 6 * a + 3, bx = 6 * b, bt = 6 * b + 3, cx = 6 * c, ct = 6 * c + 3;
      add(ax, bx, Nxx), add(ax, bt, Nxt), add(ax, cx, -Nxx), add(ax, ct, Nxc);
      add(at, bx, Ntx), add(at, bt, Ntt), add(at, cx, -Ntx), add(at, ct, Ntc);
      add(cx, bx, -Nxx), add(cx, bt, -Nxt), add(cx, cx, Nxx), add(cx, ct, -Nxc);
      add(ct, bx, Cxx), add(ct, bt, Cxt), add(ct, cx, -Cxx), add(ct, ct, Cxc);
    }
  }
  // Variation of Tbar at fixed h, with g_a = L h_rho_a, w_a = L Hinv(psi_mid)^T h_psi_a:
  //   delta f_a = -hat(g_a) dtheta_c / 2
  //   delta m_a = -hat(w_a) dtheta_c / 2 + W_a (dtheta_a - dtheta_c),  W_a = Lbar d(Hinv^T h_psi_a)/dpsi|_mid P_a / 2
  //   delta (-dbar_a x f_a) = hat(f_a) (dx_a - dx_c) / 2 - hat(dbar_a) delta f_a
  for (int o = 0; o < NN - 1; ++o) {
    const int  a  = others[o];
    const Vec3 g  = maps.L * h_rho[a];
    const Vec3 f  = maps.Lbar * h_rho[a];
    const Vec3 w  = maps.L * (maps.HinvT_mid[a] * h_psi[a]);
    const Mat3 W  = 0.5 * maps.Lbar * RodriguesTransposeApplyJacobian(maps.Finv_mid[a], maps.psi_mid[a], h_psi[a]) * maps.P[a];
    const Mat3 hg = 0.5 * Skew(g), hf = 0.5 * Skew(f), hw = 0.5 * Skew(w);
    const int  ax = 6 * a, at = 6 * a + 3, cx = 6 * c, ct = 6 * c + 3;
    K.template block<3, 3>(ax, ct) -= hg;
    K.template block<3, 3>(cx, ct) += hg;
    K.template block<3, 3>(at, at) += W;
    K.template block<3, 3>(at, ct) -= hw + W;
    K.template block<3, 3>(ct, at) -= W;
    K.template block<3, 3>(ct, ct) += hw + W + Skew(maps.dbar[a]) * hg;
    K.template block<3, 3>(ct, ax) += hf;
    K.template block<3, 3>(ct, cx) -= hf;
  }
}

template <int NN>
BeamKernelStatus MidpointForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start, const Mat3 *triads_start,
                                const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction, double *tangent_mc,
                                double *tangent_correction, double *end_residual_out, double *energy_start_out, double *energy_end_out,
                                EnergyCorrection correction)
{
  const int  c                  = ref.reference_node;
  const bool correction_moments = correction == EnergyCorrection::Resultants; // (N_d, M_d), else (N_d, 0)
  Vec3       rho_n[NN], psi_n[NN], rho_1[NN], psi_1[NN], rho_m[NN], psi_m[NN];
  if (!LocalCoordinates(NN, c, positions_start, triads_start, rho_n, psi_n)) return BeamKernelStatus::RotationTooLarge;
  if (!LocalCoordinates(NN, c, positions, triads, rho_1, psi_1)) return BeamKernelStatus::RotationTooLarge;
  int others[NN - 1];
  for (int a = 0, o = 0; a < NN; ++a)
    if (a != c) others[o++] = a;
  for (int a = 0; a < NN; ++a) {
    rho_m[a] = 0.5 * (rho_n[a] + rho_1[a]);
    psi_m[a] = 0.5 * (psi_n[a] + psi_1[a]);
  }
  const bool  want_tangent = tangent_mc || tangent_correction;
  const bool  want_end     = want_tangent || end_residual_out; // the end-point operators A_1, B_1
  const Vec3 &CN = section.axial_shear, &CM = section.torsion_bending;
  Vec3        h_rho[NN], h_psi[NN], k_rho[NN], k_psi[NN], g_rho[NN], g_psi[NN];
  for (int a = 0; a < NN; ++a) h_rho[a].setZero(), h_psi[a].setZero(), k_rho[a].setZero(), k_psi[a].setZero(), g_rho[a].setZero(), g_psi[a].setZero();
  MidpointGaussBlocks blocks_mc[kBeamMaxGauss], blocks_corr[kBeamMaxGauss];
  double              energy_n = 0.0, energy_1 = 0.0;
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const double *I = ref.shape[gp], *dI = ref.shape_derivative[gp];
    const double  wJ = ref.weight_jacobian[gp];
    // Start and end of the step: strains and stresses; at the end also D(q_{n+1}).
    Vec3 eps_n, kap_n;
    GaussStrains(ref, gp, rho_n, psi_n, &eps_n, &kap_n);
    const GaussInterpolation end     = InterpolateAtGauss(ref, gp, rho_1, psi_1);
    const RotationSeries     series1 = EvaluateRotationSeries(end.Psi.squaredNorm());
    const RodriguesForm      Fe1 = ExpForm(series1), Fh1 = TangentForm(series1);
    const Mat3               E1 = RodriguesMatrix(Fe1, end.Psi), H1 = RodriguesMatrix(Fh1, end.Psi);
    const Vec3               eps_1 = E1.transpose() * end.drho - ref.strain0[gp];
    const Vec3               kap_1 = H1.transpose() * end.dPsi - ref.curvature0[gp];
    const Vec3               N_n = CN.cwiseProduct(eps_n), M_n = CM.cwiseProduct(kap_n), N_1 = CN.cwiseProduct(eps_1), M_1 = CM.cwiseProduct(kap_1);
    energy_n += 0.5 * wJ * (eps_n.dot(N_n) + kap_n.dot(M_n));
    energy_1 += 0.5 * wJ * (eps_1.dot(N_1) + kap_1.dot(M_1));
    const Vec3 N_mid = 0.5 * (N_n + N_1), M_mid = 0.5 * (M_n + M_1), N_d = N_1 - N_n, M_d = correction_moments ? Vec3(M_1 - M_n) : Vec3::Zero();
    // D(q_mid): dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'
    const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho_m, psi_m);
    const RotationSeries series  = EvaluateRotationSeries(Psi.squaredNorm());
    const RodriguesForm  Fe = ExpForm(series), Fh = TangentForm(series);
    const Mat3           E = RodriguesMatrix(Fe, Psi), H = RodriguesMatrix(Fh, Psi);
    const Mat3           A = RodriguesTransposeApplyJacobian(Fe, Psi, drho), B = RodriguesTransposeApplyJacobian(Fh, Psi, dPsi);
    const Vec3           EN = E * N_mid, AN_BM = A.transpose() * N_mid + B.transpose() * M_mid, HM = H * M_mid;
    const Vec3           ENd = E * N_d, ANd = A.transpose() * N_d + B.transpose() * M_d, HMd = H * M_d;
    for (int a : others) {
      h_rho[a] += wJ * dI[a] * EN;
      h_psi[a] += wJ * (I[a] * AN_BM + dI[a] * HM);
      k_rho[a] += wJ * dI[a] * ENd;
      k_psi[a] += wJ * (I[a] * ANd + dI[a] * HMd);
    }
    if (!want_end) continue;
    const Mat3 A1 = RodriguesTransposeApplyJacobian(Fe1, end.Psi, end.drho), B1 = RodriguesTransposeApplyJacobian(Fh1, end.Psi, end.dPsi);
    if (end_residual_out) {
      const Vec3 EN1 = E1 * N_1, AN_BM1 = A1.transpose() * N_1 + B1.transpose() * M_1, HM1 = H1 * M_1;
      for (int a : others) {
        g_rho[a] += wJ * dI[a] * EN1;
        g_psi[a] += wJ * (I[a] * AN_BM1 + dI[a] * HM1);
      }
    }
    if (!want_tangent) continue;
    // Material part D(q_mid)^T C D(q_{n+1}), shared by both outputs (s = 1/2 for mc, 1 for corr).
    const Mat3 ECN = E * CN.asDiagonal(), ACN = A.transpose() * CN.asDiagonal(), BCM = B.transpose() * CM.asDiagonal(), HCM = H * CM.asDiagonal();
    const Mat3 rr = ECN * E1.transpose(), rp = ECN * A1, pr = ACN * E1.transpose();
    const Mat3 pd = BCM * H1.transpose(), dp = HCM * B1, dd = HCM * H1.transpose();
    // Geometric part G(q_mid, S)/2 for S_mid (mc) and S_d (corr).
    // `moments` = 0 drops the variation of the bending and torsion stresses (the (N_d, 0) correction).
    auto fill = [&](MidpointGaussBlocks *G, double s, const Vec3 &N, const Vec3 &M, double moments) {
      const Mat3 P = RodriguesApplyJacobian(Fe, Psi, N), Q = RodriguesApplyJacobian(Fh, Psi, M);
      const Mat3 Sg = RodriguesTransposeApplyHessian(Fe, Psi, drho, N) + RodriguesTransposeApplyHessian(Fh, Psi, dPsi, M);
      G->wJ         = wJ;
      G->rr         = s * rr;
      G->rp         = s * rp + 0.5 * P;
      G->pr         = s * pr + 0.5 * P.transpose();
      G->pp         = s * (ACN * A1 + moments * (BCM * B1)) + 0.5 * Sg;
      G->pd         = s * moments * pd + 0.5 * Q.transpose();
      G->dp         = s * moments * dp + 0.5 * Q;
      G->dd         = s * moments * dd;
    };
    if (tangent_mc) fill(&blocks_mc[gp], 0.5, N_mid, M_mid, 1.0);
    if (tangent_correction) fill(&blocks_corr[gp], 1.0, N_d, M_d, correction_moments ? 1.0 : 0.0);
  }
  if (energy_start_out) *energy_start_out = energy_n;
  if (energy_end_out) *energy_end_out = energy_1;

  MidpointMaps<NN> maps;
  maps.Lbar = 0.5 * (triads_start[c] + triads[c]);
  maps.L    = triads[c];
  maps.LT   = maps.L.transpose();
  for (int i = 0; i < 6 * NN; ++i) force_mc[i] = force_correction[i] = 0.0;
  if (end_residual_out)
    for (int i = 0; i < 6 * NN; ++i) end_residual_out[i] = 0.0;
  for (int a : others) {
    maps.dbar[a]      = 0.5 * ((positions_start[a] - positions_start[c]) + (positions[a] - positions[c]));
    maps.d[a]         = positions[a] - positions[c];
    maps.psi_mid[a]   = psi_m[a];
    maps.Finv_mid[a]  = TangentInverseForm(EvaluateRotationSeries(psi_m[a].squaredNorm()));
    maps.HinvT_mid[a] = RodriguesMatrix(maps.Finv_mid[a], psi_m[a]).transpose();
    maps.PbarT[a]     = maps.Lbar * maps.HinvT_mid[a];   // (H^{-1}(psi_mid) Lbar^T)^T
    const Mat3 MT     = -Skew(maps.dbar[a]) * maps.Lbar; // (Lbar^T hat(dbar))^T
    for (int which = 0; which < 2; ++which) {
      double     *out = which == 0 ? force_mc : force_correction;
      const Vec3 &hr = which == 0 ? h_rho[a] : k_rho[a], &hp = which == 0 ? h_psi[a] : k_psi[a];
      const Vec3  f = maps.Lbar * hr, m = maps.PbarT[a] * hp, mc = MT * hr - m;
      for (int i = 0; i < 3; ++i) {
        out[6 * a + i] += f(i);
        out[6 * a + 3 + i] += m(i);
        out[6 * c + i] -= f(i);
        out[6 * c + 3 + i] += mc(i);
      }
    }
    if (!want_end) continue;
    maps.P[a] = RodriguesMatrix(TangentInverseForm(EvaluateRotationSeries(psi_1[a].squaredNorm())), psi_1[a]) * maps.LT;
    if (end_residual_out) {
      // r_{n+1} = T_{n+1}^T g: the gradient of the end strain energy (as BeamInternalForces).
      const Vec3 f = maps.L * g_rho[a], m = maps.P[a].transpose() * g_psi[a], mc = (maps.LT * Skew(maps.d[a])).transpose() * g_rho[a] - m;
      for (int i = 0; i < 3; ++i) {
        end_residual_out[6 * a + i] += f(i);
        end_residual_out[6 * a + 3 + i] += m(i);
        end_residual_out[6 * c + i] -= f(i);
        end_residual_out[6 * c + 3 + i] += mc(i);
      }
    }
  }
  if (tangent_mc) MidpointTangent<NN>(ref, others, blocks_mc, maps, h_rho, h_psi, tangent_mc);
  if (tangent_correction) MidpointTangent<NN>(ref, others, blocks_corr, maps, k_rho, k_psi, tangent_correction);
  return BeamKernelStatus::Ok;
}

} // namespace

BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *tangent_mc, double *tangent_correction, double *end_residual, double *strain_energy_start,
                                            double *strain_energy_end, EnergyCorrection correction)
{
  if (ref.num_nodes == 2)
    return MidpointForces<2>(ref, section, positions_start, triads_start, positions, triads, force_mc, force_correction, tangent_mc, tangent_correction,
                             end_residual, strain_energy_start, strain_energy_end, correction);
  return MidpointForces<3>(ref, section, positions_start, triads_start, positions, triads, force_mc, force_correction, tangent_mc, tangent_correction,
                           end_residual, strain_energy_start, strain_energy_end, correction);
}

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

} // namespace msflex
