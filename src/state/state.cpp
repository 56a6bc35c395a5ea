#include "state/state.hpp"

namespace msflex {

void NodeStateUpdateCurrent(NodeState *node)
{
  node->position         = node->position_start + node->displacement_increment;
  node->rotation         = ExpSO3(node->rotation_increment) * QuaternionToMatrix(node->rotation_start);
  node->rotation_tangent = TangentH(node->rotation_increment);
}

Quaternion NodeStateCurrentQuaternion(const NodeState &node)
{
  return QuaternionNormalize(QuaternionMultiply(QuaternionFromRotationVector(node.rotation_increment), node.rotation_start));
}

void NodeStateCommit(NodeState *node)
{
  node->rotation_start         = NodeStateCurrentQuaternion(*node);
  node->position_start         = node->position_start + node->displacement_increment;
  node->displacement_increment = Vec3::Zero();
  node->rotation_increment     = Vec3::Zero();
  NodeStateUpdateCurrent(node);
}

} // namespace msflex
