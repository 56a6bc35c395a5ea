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

template <int NN>
using LocalVector = Eigen::Matrix<double, 6 * (NN - 1), 1>;
template <int NN>
using LocalMatrix = Eigen::Matrix<double, 6 * (NN - 1), 6 * (NN - 1)>;
template <int NN>
using NodalMatrix = Eigen::Matrix<double, 6 * NN, 6 * NN, Eigen::RowMajor>;

template <int NN>
BeamKernelStatus InternalForces(const BeamElementReference &ref, const BeamSectionStiffness &section, const Vec3 *positions, const Mat3 *triads,
                                double *residual_out, double *tangent_out, double *energy_out, BeamGaussResults *results)
{
  constexpr int NL = 6 * (NN - 1); // local coordinates: (rho_a, psi_a) of the non-reference nodes
  const int     c  = ref.reference_node;
  Vec3          rho[NN], psi[NN];
  if (!LocalCoordinates(NN, c, positions, triads, rho, psi)) return BeamKernelStatus::RotationTooLarge;

  // Map non-reference node a to its slot in the local vector.
  int slot[NN], others[NN - 1];
  for (int a = 0, o = 0; a < NN; ++a) {
    slot[a] = (a == c) ? -1 : o;
    if (a != c) others[o++] = a;
  }

  const bool        want_tangent = tangent_out != nullptr;
  LocalVector<NN>   g_local      = LocalVector<NN>::Zero();
  LocalMatrix<NN>   K_local      = LocalMatrix<NN>::Zero();
  double            energy       = 0.0;
  const Vec3       &CN           = section.axial_shear;
  const Vec3       &CM           = section.torsion_bending;

  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    const double *I  = ref.shape[gp];
    const double *dI = ref.shape_derivative[gp];
    const double  wJ = ref.weight_jacobian[gp];
    Vec3          Psi = Vec3::Zero(), dPsi = Vec3::Zero(), drho = Vec3::Zero();
    for (int a = 0; a < NN; ++a) {
      Psi += I[a] * psi[a];
      dPsi += dI[a] * psi[a];
      drho += dI[a] * rho[a];
    }
    const RotationSeries series = EvaluateRotationSeries(Psi.squaredNorm());
    const RodriguesForm  Fe     = ExpForm(series);
    const RodriguesForm  Fh     = TangentForm(series);
    const Mat3           E      = RodriguesMatrix(Fe, Psi);
    const Mat3           Hm     = RodriguesMatrix(Fh, Psi);
    const Vec3           Gamma  = E.transpose() * drho;
    const Vec3           Kappa  = Hm.transpose() * dPsi;
    const Vec3           eps    = Gamma - ref.strain0[gp];
    const Vec3           kap    = Kappa - ref.curvature0[gp];
    const Vec3           N      = CN.cwiseProduct(eps);
    const Vec3           M      = CM.cwiseProduct(kap);
    energy += 0.5 * wJ * (eps.dot(N) + kap.dot(M));
    if (results) {
      results->strain[gp]    = eps;
      results->curvature[gp] = kap;
      results->force[gp]     = N;
      results->moment[gp]    = M;
    }
    // dGamma = A dPsi + E^T drho',  dK = B dPsi + H^T dPsi'
    const Mat3 A = RodriguesTransposeApplyJacobian(Fe, Psi, drho);
    const Mat3 B = RodriguesTransposeApplyJacobian(Fh, Psi, dPsi);

    // Strain-displacement blocks D_a = d(Gamma, K)/d(rho_a, psi_a).
    Eigen::Matrix<double, 6, 6> D[NN];
    for (int a : others) {
      D[a].setZero();
      D[a].template block<3, 3>(0, 0) = dI[a] * E.transpose();
      D[a].template block<3, 3>(0, 3) = I[a] * A;
      D[a].template block<3, 3>(3, 3) = I[a] * B + dI[a] * Hm.transpose();
    }
    Eigen::Matrix<double, 6, 1> stress;
    stress << N, M;
    for (int a : others) g_local.template segment<6>(6 * slot[a]) += wJ * D[a].transpose() * stress;
    if (!want_tangent) continue;

    // Material part: D_a^T C D_b.
    Eigen::Matrix<double, 6, 1> Cdiag;
    Cdiag << CN, CM;
    for (int a : others) {
      const Eigen::Matrix<double, 6, 6> DaC = D[a].transpose() * Cdiag.asDiagonal();
      for (int b : others) K_local.template block<6, 6>(6 * slot[a], 6 * slot[b]) += wJ * DaC * D[b];
    }
    // Geometric part: second derivatives of N.Gamma + M.K at fixed N, M.
    const Mat3 P  = RodriguesApplyJacobian(Fe, Psi, N);                 // d(E N)/dPsi
    const Mat3 Q  = RodriguesApplyJacobian(Fh, Psi, M);                 // d(H M)/dPsi
    const Mat3 Sg = RodriguesTransposeApplyHessian(Fe, Psi, drho, N);   // d2(N.E^T rho')/dPsi2
    const Mat3 Sk = RodriguesTransposeApplyHessian(Fh, Psi, dPsi, M);   // d2(M.H^T Psi')/dPsi2
    for (int a : others) {
      for (int b : others) {
        auto Kab = K_local.template block<6, 6>(6 * slot[a], 6 * slot[b]);
        Kab.template block<3, 3>(0, 3) += wJ * dI[a] * I[b] * P;
        Kab.template block<3, 3>(3, 0) += wJ * I[a] * dI[b] * P.transpose();
        Kab.template block<3, 3>(3, 3) += wJ * (I[a] * I[b] * (Sg + Sk) + dI[a] * I[b] * Q + I[a] * dI[b] * Q.transpose());
      }
    }
  }

  // Chain rule to nodal (x, theta): delta rho_a = Lc^T (dx_a - dx_c + hat(d_a) dtheta_c),
  // delta psi_a = Hinv(psi_a) Lc^T (dtheta_a - dtheta_c), d_a = x_a - x_c.
  const Mat3                                   Lc  = triads[c];
  const Mat3                                   LcT = Lc.transpose();
  Eigen::Matrix<double, NL, 6 * NN>            T   = Eigen::Matrix<double, NL, 6 * NN>::Zero();
  Mat3                                         Hinv[NN];
  RodriguesForm                                Finv[NN];
  for (int a : others) {
    const int o = 6 * slot[a];
    Finv[a]     = TangentInverseForm(EvaluateRotationSeries(psi[a].squaredNorm()));
    Hinv[a]     = RodriguesMatrix(Finv[a], psi[a]);
    const Vec3 d = positions[a] - positions[c];
    T.template block<3, 3>(o, 6 * a)         = LcT;
    T.template block<3, 3>(o, 6 * c)         = -LcT;
    T.template block<3, 3>(o, 6 * c + 3)     = LcT * Skew(d);
    T.template block<3, 3>(o + 3, 6 * a + 3) = Hinv[a] * LcT;
    T.template block<3, 3>(o + 3, 6 * c + 3) = -Hinv[a] * LcT;
  }
  Eigen::Map<Eigen::Matrix<double, 6 * NN, 1>> residual(residual_out);
  residual = T.transpose() * g_local;
  if (energy_out) *energy_out = energy;
  if (!want_tangent) return BeamKernelStatus::Ok;

  Eigen::Map<NodalMatrix<NN>> K(tangent_out);
  K = T.transpose() * K_local * T;
  // Terms from the configuration dependence of T at fixed local gradient g:
  //   f_a = Lc g_rho_a, m_a = Lc Hinv_a^T g_psi_a, G_a = Lc d(Hinv^T g_psi)/dpsi Hinv_a Lc^T.
  for (int a : others) {
    const int  o   = 6 * slot[a];
    const Vec3 f   = Lc * g_local.template segment<3>(o);
    const Vec3 gps = g_local.template segment<3>(o + 3);
    const Vec3 m   = Lc * (Hinv[a].transpose() * gps);
    const Mat3 G   = Lc * RodriguesTransposeApplyJacobian(Finv[a], psi[a], gps) * Hinv[a] * LcT;
    const Vec3 d   = positions[a] - positions[c];
    const Mat3 hf = Skew(f), hm = Skew(m);
    K.template block<3, 3>(6 * a, 6 * c + 3) -= hf;
    K.template block<3, 3>(6 * c, 6 * c + 3) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * a) += hf;
    K.template block<3, 3>(6 * c + 3, 6 * c) -= hf;
    K.template block<3, 3>(6 * c + 3, 6 * c + 3) += Skew(d) * hf + hm + G;
    K.template block<3, 3>(6 * a + 3, 6 * c + 3) -= hm + G;
    K.template block<3, 3>(6 * a + 3, 6 * a + 3) += G;
    K.template block<3, 3>(6 * c + 3, 6 * a + 3) -= G;
  }
  return BeamKernelStatus::Ok;
}

} // namespace

BeamKernelStatus BeamElementSetup(int num_nodes, const Vec3 *reference_positions, const Mat3 *reference_triads, BeamElementReference *ref)
{
  if (num_nodes != 2 && num_nodes != 3) return BeamKernelStatus::DegenerateGeometry;
  ref->num_nodes      = num_nodes;
  ref->num_gauss      = num_nodes - 1; // reduced integration
  ref->reference_node = (num_nodes == 2) ? 0 : 1;
  const double gauss_point[2][2]  = {{0.0, 0.0}, {-1.0 / std::sqrt(3.0), 1.0 / std::sqrt(3.0)}};
  const double gauss_weight[2][2] = {{2.0, 0.0}, {1.0, 1.0}};

  // Scale for the degeneracy test: the element's extent.
  double extent = 0.0;
  for (int a = 1; a < num_nodes; ++a) extent = std::max(extent, (reference_positions[a] - reference_positions[0]).norm());
  if (!(extent > 0.0)) return BeamKernelStatus::DegenerateGeometry;

  Vec3 rho[kBeamMaxNodes], psi[kBeamMaxNodes];
  if (!LocalCoordinates(num_nodes, ref->reference_node, reference_positions, reference_triads, rho, psi))
    return BeamKernelStatus::RotationTooLarge;

  for (int gp = 0; gp < ref->num_gauss; ++gp) {
    double I[kBeamMaxNodes], dI_dxi[kBeamMaxNodes];
    LagrangeShape(num_nodes, gauss_point[num_nodes - 2][gp], I, dI_dxi);
    Vec3 dX_dxi = Vec3::Zero();
    for (int a = 0; a < num_nodes; ++a) dX_dxi += dI_dxi[a] * reference_positions[a];
    const double jacobian = dX_dxi.norm();
    if (jacobian < 1e-12 * extent) return BeamKernelStatus::DegenerateGeometry;
    ref->weight_jacobian[gp] = gauss_weight[num_nodes - 2][gp] * jacobian;
    Vec3 Psi = Vec3::Zero(), dPsi = Vec3::Zero(), drho = Vec3::Zero();
    for (int a = 0; a < num_nodes; ++a) {
      ref->shape[gp][a]            = I[a];
      ref->shape_derivative[gp][a] = dI_dxi[a] / jacobian;
      Psi += I[a] * psi[a];
      dPsi += ref->shape_derivative[gp][a] * psi[a];
      drho += ref->shape_derivative[gp][a] * rho[a];
    }
    ref->strain0[gp]    = ExpSO3(Psi).transpose() * drho;
    ref->curvature0[gp] = TangentH(Psi).transpose() * dPsi;
  }

  // Length and consistent nodal lengths with 3-point Gauss (exact for straight elements).
  const double xi3[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w3[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  ref->length         = 0.0;
  for (int a = 0; a < kBeamMaxNodes; ++a) ref->nodal_length[a] = 0.0;
  for (int q = 0; q < 3; ++q) {
    double I[kBeamMaxNodes], dI_dxi[kBeamMaxNodes];
    LagrangeShape(num_nodes, xi3[q], I, dI_dxi);
    Vec3 dX_dxi = Vec3::Zero();
    for (int a = 0; a < num_nodes; ++a) dX_dxi += dI_dxi[a] * reference_positions[a];
    const double ds = w3[q] * dX_dxi.norm();
    ref->length += ds;
    for (int a = 0; a < num_nodes; ++a) ref->nodal_length[a] += I[a] * ds;
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
