// From a model's Joint (input data) to the kinematics kernel's JointGeometry.
#pragma once

#include "joints/joint_kinematics.hpp"
#include "model/model.hpp"

namespace msflex {

// The joint's geometry; `offset` is the slave's reference position minus the master's (zero for
// a joint to the ground, whose frame sits at the slave's reference position). The spline arrays
// point into `joint`, which must outlive the result.
JointGeometry JointGeometryOf(const Joint &joint, const Vec3 &offset = Vec3::Zero());

// The joint's reference offset in `model`.
Vec3 JointReferenceOffset(const Model &model, const Joint &joint);

// The index among the joint's released coordinates of the translation along (axis_dof 0..2:
// tx ty tz) or the rotation about (3..5: rx ry rz) a joint axis; -1 when the joint does not
// release it as a coordinate of its own (a free rotation has none).
int JointCoordinateOfAxis(const Joint &joint, int axis_dof);

} // namespace msflex
