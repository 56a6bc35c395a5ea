// Nodal state of the nodes a rank holds (owned and ghosts). Within a step the unknown is the
// increment from the start of the step (DESIGN.md §3): x = x_n + u, Lambda = exp(hat(omega)) Lambda_n.
// Ghost nodes receive the same increments as their owners (scattered), so no rotation ever
// travels between ranks mid-step.
#pragma once

#include "integrators/time_scheme.hpp"
#include "math/rotation.hpp"

#include <vector>

namespace msflex {

struct NodeState {
  // At the start of the step (the last converged state).
  Vec3       position_start = Vec3::Zero();
  Quaternion rotation_start; // rotation from the reference configuration, tracked (see rotation.hpp)
  // Increment from the start of the step: the Newton unknowns (or prescribed values).
  Vec3 displacement_increment = Vec3::Zero();
  Vec3 rotation_increment     = Vec3::Zero();
  // Current configuration, derived from the two above by UpdateCurrent().
  Vec3 position         = Vec3::Zero();
  Mat3 rotation         = Mat3::Identity();
  Mat3 rotation_tangent = Mat3::Identity(); // H(omega): d theta = H(omega) d omega

  // Dynamics at the start of the step: translation in global axes, rotation in the node's body
  // frame (W, Wdot and the Newmark family's pseudo-acceleration).
  MotionState translation_motion, rotation_motion;
  // Dynamics at the end of the step, derived from the increments by the time scheme.
  MotionUpdate translation_update;
  Vec3         tangent_scaled_increment  = Vec3::Zero();     // alpha = 2 tan(|omega|/2) omega/|omega|
  Mat3         tangent_scaled_derivative = Mat3::Identity(); // d alpha / d omega
};

// Recomputes position, rotation and rotation_tangent from the start state and the increments.
void NodeStateUpdateCurrent(NodeState *node);
// Makes the current configuration the new start of step and clears the increments.
void NodeStateCommit(NodeState *node);
// The tracked quaternion of the current rotation: q(omega) * q_n.
Quaternion NodeStateCurrentQuaternion(const NodeState &node);

} // namespace msflex
