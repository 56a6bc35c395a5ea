#include "elements/loads.hpp"

namespace msflex {

void BeamLineLoad(const BeamElementReference &ref, const Vec3 &force_per_length, double *residual)
{
  for (int a = 0; a < ref.num_nodes; ++a)
    for (int i = 0; i < 3; ++i) residual[6 * a + i] -= ref.nodal_length[a] * force_per_length(i);
}

void NodalLoadForces(const NodalLoadValues &load, double weight_start, double weight_end, const Mat3 &rotation_start, const Mat3 &rotation_end, Vec6 *residual,
                     Mat6 *tangent)
{
  const Vec3 f_end = rotation_end * load.follower_force_end, m_end = rotation_end * load.follower_moment_end;
  residual->head<3>() = -(weight_start * (load.dead_force_start + rotation_start * load.follower_force_start) + weight_end * (load.dead_force_end + f_end));
  residual->tail<3>() = -(weight_start * (load.dead_moment_start + rotation_start * load.follower_moment_start) + weight_end * (load.dead_moment_end + m_end));
  if (!tangent) return;
  tangent->setZero();
  tangent->block<3, 3>(0, 3) = weight_end * Skew(f_end);
  tangent->block<3, 3>(3, 3) = weight_end * Skew(m_end);
}

void OffsetPointWeight(const Vec3 &weight, const Vec3 &offset_start, const Vec3 &offset_end, double arm_weight_start, double arm_weight_end, Vec6 *residual,
                       Mat6 *tangent)
{
  const Vec3 arm      = arm_weight_start * offset_start + arm_weight_end * offset_end;
  residual->head<3>() = -weight;
  residual->tail<3>() = -arm.cross(weight);
  if (!tangent) return;
  tangent->setZero();
  tangent->block<3, 3>(3, 3) = -arm_weight_end * Skew(weight) * Skew(offset_end);
}

} // namespace msflex
