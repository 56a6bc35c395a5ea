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

} // namespace msflex
