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

} // namespace

BeamKernelStatus BeamMidpointInternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions_start,
                                            const Mat3 *triads_start, const Vec3 *positions, const Mat3 *triads, double *force_mc, double *force_correction,
                                            double *strain_energy_start, double *strain_energy_end)
{
  const int nn = ref.num_nodes, c = ref.reference_node;
  Vec3      rho_n[kBeamMaxNodes], psi_n[kBeamMaxNodes], rho_1[kBeamMaxNodes], psi_1[kBeamMaxNodes], rho_m[kBeamMaxNodes], psi_m[kBeamMaxNodes];
  if (!LocalCoordinates(nn, c, positions_start, triads_start, rho_n, psi_n)) return BeamKernelStatus::RotationTooLarge;
  if (!LocalCoordinates(nn, c, positions, triads, rho_1, psi_1)) return BeamKernelStatus::RotationTooLarge;
  for (int a = 0; a < nn; ++a) {
    rho_m[a] = 0.5 * (rho_n[a] + rho_1[a]);
    psi_m[a] = 0.5 * (psi_n[a] + psi_1[a]);
  }
  const Vec3 &CN = section.axial_shear, &CM = section.torsion_bending;
  Vec3        h_rho[kBeamMaxNodes], h_psi[kBeamMaxNodes], k_rho[kBeamMaxNodes], k_psi[kBeamMaxNodes];
  for (int a = 0; a < nn; ++a) h_rho[a].setZero(), h_psi[a].setZero(), k_rho[a].setZero(), k_psi[a].setZero();
  double energy_n = 0.0, energy_1 = 0.0;
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    Vec3 eps_n, kap_n, eps_1, kap_1;
    GaussStrains(ref, gp, rho_n, psi_n, &eps_n, &kap_n);
    GaussStrains(ref, gp, rho_1, psi_1, &eps_1, &kap_1);
    const Vec3   N_n = CN.cwiseProduct(eps_n), M_n = CM.cwiseProduct(kap_n), N_1 = CN.cwiseProduct(eps_1), M_1 = CM.cwiseProduct(kap_1);
    const double wJ = ref.weight_jacobian[gp];
    energy_n += 0.5 * wJ * (eps_n.dot(N_n) + kap_n.dot(M_n));
    energy_1 += 0.5 * wJ * (eps_1.dot(N_1) + kap_1.dot(M_1));
    const Vec3 N_mid = 0.5 * (N_n + N_1), M_mid = 0.5 * (M_n + M_1), N_d = N_1 - N_n, M_d = M_1 - M_n;
    // D(q_mid): dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'
    const double *I = ref.shape[gp], *dI = ref.shape_derivative[gp];
    const auto [Psi, dPsi, drho] = InterpolateAtGauss(ref, gp, rho_m, psi_m);
    const RotationSeries series  = EvaluateRotationSeries(Psi.squaredNorm());
    const RodriguesForm  Fe = ExpForm(series), Fh = TangentForm(series);
    const Mat3           E = RodriguesMatrix(Fe, Psi), H = RodriguesMatrix(Fh, Psi);
    const Mat3           A = RodriguesTransposeApplyJacobian(Fe, Psi, drho), B = RodriguesTransposeApplyJacobian(Fh, Psi, dPsi);
    const Vec3           EN = E * N_mid, AN_BM = A.transpose() * N_mid + B.transpose() * M_mid, HM = H * M_mid;
    const Vec3           ENd = E * N_d, ANd = A.transpose() * N_d + B.transpose() * M_d, HMd = H * M_d;
    for (int a = 0; a < nn; ++a) {
      if (a == c) continue;
      h_rho[a] += wJ * dI[a] * EN;
      h_psi[a] += wJ * (I[a] * AN_BM + dI[a] * HM);
      k_rho[a] += wJ * dI[a] * ENd;
      k_psi[a] += wJ * (I[a] * ANd + dI[a] * HMd);
    }
  }
  if (strain_energy_start) *strain_energy_start = energy_n;
  if (strain_energy_end) *strain_energy_end = energy_1;

  const Mat3 L = 0.5 * (triads_start[c] + triads[c]);
  for (int i = 0; i < 6 * nn; ++i) force_mc[i] = force_correction[i] = 0.0;
  for (int a = 0; a < nn; ++a) {
    if (a == c) continue;
    const Vec3 d_mid = 0.5 * ((positions_start[a] - positions_start[c]) + (positions[a] - positions[c]));
    const Mat3 PT    = L * TangentHInverse(psi_m[a]).transpose(); // (H^{-1}(psi_mid) L^T)^T
    const Mat3 MT    = -Skew(d_mid) * L;                          // (L^T hat(d_mid))^T
    for (int which = 0; which < 2; ++which) {
      double     *out = which == 0 ? force_mc : force_correction;
      const Vec3 &hr = which == 0 ? h_rho[a] : k_rho[a], &hp = which == 0 ? h_psi[a] : k_psi[a];
      const Vec3  f = L * hr, m = PT * hp, mc = MT * hr - m;
      for (int i = 0; i < 3; ++i) {
        out[6 * a + i] += f(i);
        out[6 * a + 3 + i] += m(i);
        out[6 * c + i] -= f(i);
        out[6 * c + 3 + i] += mc(i);
      }
    }
  }
  return BeamKernelStatus::Ok;
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
