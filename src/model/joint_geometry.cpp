#include "model/joint_geometry.hpp"

namespace msflex {

JointGeometry JointGeometryOf(const Joint &joint, const Vec3 &offset)
{
  JointGeometry g;
  g.axes             = joint.axes;
  g.offset           = offset;
  g.num_translations = joint.num_translations;
  for (int i = 0; i < 3; ++i) g.translation_axis[i] = joint.translation_axis[i];
  g.rotation         = joint.rotation;
  g.rotation_axis[0] = joint.rotation_axis[0];
  g.rotation_axis[1] = joint.rotation_axis[1];
  g.dependence       = joint.dependence;
  g.dependent_axis   = joint.dependent_axis;
  g.coefficient      = joint.coefficient;
  if (joint.dependence == Joint::Dependence::Table)
    g.profile = {joint.profile_period, (int)joint.profile_knots.size(), joint.profile_knots.data(), joint.profile_values.data(), joint.profile_second.data()};
  return g;
}

Vec3 JointReferenceOffset(const Model &model, const Joint &joint)
{
  if (joint.master < 0) return Vec3::Zero();
  return model.nodes[joint.slave].position - model.nodes[joint.master].position;
}

int JointCoordinateOfAxis(const Joint &joint, int axis_dof)
{
  if (axis_dof < 3) {
    for (int k = 0; k < joint.num_translations; ++k)
      if (joint.translation_axis[k] == axis_dof) return k;
    return -1;
  }
  const int rotations = joint.rotation == Joint::Rotation::OneAxis ? 1 : joint.rotation == Joint::Rotation::TwoAxes ? 2 : 0;
  for (int k = 0; k < rotations; ++k)
    if (joint.rotation_axis[k] == axis_dof - 3) return joint.num_translations + k;
  return -1;
}

} // namespace msflex
