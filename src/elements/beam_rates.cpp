#include "elements/beam_rates.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

constexpr double kPi = 3.14159265358979323846;

} // namespace

BeamKernelStatus BeamStrainRates(const BeamElementReference &ref, const Vec3 *positions, const Mat3 *triads, const Vec3 *velocities,
                                 const Vec3 *angular_velocities, Vec3 *strain, Vec3 *curvature, Vec3 *strain_rate, Vec3 *curvature_rate)
{
  const int  n = ref.num_nodes, c = ref.reference_node;
  const Mat3 LT = triads[c].transpose();
  Vec3       rho[kBeamMaxNodes], psi[kBeamMaxNodes], rho_rate[kBeamMaxNodes], psi_rate[kBeamMaxNodes];
  for (int a = 0; a < n; ++a) {
    if (a == c) {
      rho[a].setZero(), psi[a].setZero(), rho_rate[a].setZero(), psi_rate[a].setZero();
      continue;
    }
    const Vec3 d = positions[a] - positions[c];
    rho[a]       = LT * d;
    psi[a]       = LogSO3(LT * triads[a]);
    if (psi[a].norm() > 0.95 * kPi) return BeamKernelStatus::RotationTooLarge;
    rho_rate[a] = LT * (velocities[a] - velocities[c] - angular_velocities[c].cross(d));
    psi_rate[a] = TangentHInverse(psi[a]) * (LT * (angular_velocities[a] - angular_velocities[c]));
  }
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    Vec3 Psi = Vec3::Zero(), dPsi = Vec3::Zero(), drho = Vec3::Zero(), Psi_rate = Vec3::Zero(), dPsi_rate = Vec3::Zero(), drho_rate = Vec3::Zero();
    for (int a = 0; a < n; ++a) {
      const double I = ref.shape[gp][a], dI = ref.shape_derivative[gp][a];
      Psi += I * psi[a], dPsi += dI * psi[a], drho += dI * rho[a];
      Psi_rate += I * psi_rate[a], dPsi_rate += dI * psi_rate[a], drho_rate += dI * rho_rate[a];
    }
    const RotationSeries series = EvaluateRotationSeries(Psi.squaredNorm());
    const RodriguesForm  Fe = ExpForm(series), Fh = TangentForm(series);
    const Mat3           E = RodriguesMatrix(Fe, Psi), H = RodriguesMatrix(Fh, Psi);
    if (strain) strain[gp] = E.transpose() * drho - ref.strain0[gp];
    if (curvature) curvature[gp] = H.transpose() * dPsi - ref.curvature0[gp];
    strain_rate[gp]    = RodriguesTransposeApplyJacobian(Fe, Psi, drho) * Psi_rate + E.transpose() * drho_rate;
    curvature_rate[gp] = RodriguesTransposeApplyJacobian(Fh, Psi, dPsi) * Psi_rate + H.transpose() * dPsi_rate;
  }
  return BeamKernelStatus::Ok;
}

BeamKernelStatus BeamStrainAccelerations(const BeamElementReference &ref, const Vec3 *positions, const Mat3 *triads, const Vec3 *velocities,
                                         const Vec3 *angular_velocities, const Vec3 *accelerations, const Vec3 *angular_accelerations,
                                         Vec3 *strain_acceleration, Vec3 *curvature_acceleration)
{
  const int n = ref.num_nodes;
  // D(q) (a, wdot): the rates of the accelerations.
  BeamKernelStatus status =
      BeamStrainRates(ref, positions, triads, accelerations, angular_accelerations, nullptr, nullptr, strain_acceleration, curvature_acceleration);
  if (status != BeamKernelStatus::Ok) return status;
  // d/ds D(q(s)) qdot at s = 0, q(s) = (x + s v, exp(s hat(w)) Lambda), by a central difference.
  double speed = 0.0;
  for (int a = 0; a < n; ++a) speed = std::max(speed, std::max(velocities[a].norm() / ref.length, angular_velocities[a].norm()));
  if (!(speed > 0.0)) return BeamKernelStatus::Ok;
  const double h = 1e-5 / speed;
  Vec3         shifted_positions[kBeamMaxNodes];
  Mat3         shifted_triads[kBeamMaxNodes];
  Vec3         strain_plus[kBeamMaxGauss], curvature_plus[kBeamMaxGauss], strain_minus[kBeamMaxGauss], curvature_minus[kBeamMaxGauss];
  for (int sign = -1; sign <= 1; sign += 2) {
    for (int a = 0; a < n; ++a) {
      shifted_positions[a] = positions[a] + sign * h * velocities[a];
      shifted_triads[a]    = ExpSO3(sign * h * angular_velocities[a]) * triads[a];
    }
    status = BeamStrainRates(ref, shifted_positions, shifted_triads, velocities, angular_velocities, nullptr, nullptr, sign > 0 ? strain_plus : strain_minus,
                             sign > 0 ? curvature_plus : curvature_minus);
    if (status != BeamKernelStatus::Ok) return status;
  }
  for (int gp = 0; gp < ref.num_gauss; ++gp) {
    strain_acceleration[gp] += (strain_plus[gp] - strain_minus[gp]) / (2.0 * h);
    curvature_acceleration[gp] += (curvature_plus[gp] - curvature_minus[gp]) / (2.0 * h);
  }
  return BeamKernelStatus::Ok;
}

} // namespace msflex
