// The start-of-step state of the assembler as fixed-size records, for checkpoints and restarts
// (assembler.hpp, "Checkpoints"). Only start-of-step values are kept: everything else (current
// configuration, slave expansions, loads, the time scheme's coefficients) follows from them and
// the time at the next BeginStep, so a restarted run repeats the original one to the last bit.
#include "assembly/assembler.hpp"

namespace msflex {

namespace {

void PutVec3(const Vec3 &v, double *out)
{
  for (int i = 0; i < 3; ++i) out[i] = v(i);
}

Vec3 GetVec3(const double *in) { return Vec3(in[0], in[1], in[2]); }

void PutMotion(const MotionState &motion, double *out)
{
  PutVec3(motion.velocity, out);
  PutVec3(motion.acceleration, out + 3);
  PutVec3(motion.pseudo_acceleration, out + 6);
}

MotionState GetMotion(const double *in) { return {GetVec3(in), GetVec3(in + 3), GetVec3(in + 6)}; }

} // namespace

void Assembler::ExportState(StateRecords *nodes, StateRecords *joints, StateRecords *bodies) const
{
  const DofMap &map = *map_;
  PetscMPIInt   rank;
  MPI_Comm_rank(comm_, &rank);
  *nodes = *joints = *bodies = StateRecords{};
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s = nodes_[l];
    double           record[kNodeStateSize];
    PutVec3(s.position_start, record);
    record[3] = s.rotation_start.w, record[4] = s.rotation_start.x, record[5] = s.rotation_start.y, record[6] = s.rotation_start.z;
    PutMotion(s.translation_motion, record + 7);
    PutMotion(s.rotation_motion, record + 16);
    nodes->numbers.push_back(map.global_nodes[map.local_nodes[l]]);
    nodes->values.insert(nodes->values.end(), record, record + kNodeStateSize);
  }
  for (const LocalJoint &J : joints_) {
    const int joint = map.local_joints[J.local_index];
    if (map.joint_rank[joint] != rank) continue;
    double record[kJointStateSize];
    for (int c = 0; c < kJointMaxReleased; ++c) record[c] = J.start.q[c];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) record[kJointMaxReleased + 3 * i + k] = J.start.free_rotation_start(i, k);
    joints->numbers.push_back(map.global_joints[joint]);
    joints->values.insert(joints->values.end(), record, record + kJointStateSize);
  }
  for (const LocalRigidBody &body : rigid_bodies_) {
    double record[kRigidBodyStateSize];
    PutMotion(body.centre_of_mass, record);
    bodies->numbers.push_back(body.global_index);
    bodies->values.insert(bodies->values.end(), record, record + kRigidBodyStateSize);
  }
}

void Assembler::StateNumbers(std::vector<int> *nodes, std::vector<int> *joints, std::vector<int> *bodies) const
{
  const DofMap &map = *map_;
  nodes->clear(), joints->clear(), bodies->clear();
  for (size_t l = 0; l < nodes_.size(); ++l) nodes->push_back(map.global_nodes[map.local_nodes[l]]);
  for (const LocalJoint &J : joints_) joints->push_back(map.global_joints[map.local_joints[J.local_index]]);
  for (const LocalRigidBody &body : rigid_bodies_) bodies->push_back(body.global_index);
}

PetscErrorCode Assembler::ImportState(const std::vector<double> &nodes, const std::vector<double> &joints, const std::vector<double> &bodies)
{
  PetscFunctionBeginUser;
  PetscCheck(nodes.size() == kNodeStateSize * nodes_.size() && joints.size() == kJointStateSize * joints_.size() &&
                 bodies.size() == kRigidBodyStateSize * rigid_bodies_.size(),
             PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "state records do not match the local nodes, joints and rigid bodies");
  for (size_t l = 0; l < nodes_.size(); ++l) {
    const double *record = &nodes[kNodeStateSize * l];
    NodeState    &s      = nodes_[l];
    s.position_start     = GetVec3(record);
    s.rotation_start     = Quaternion{record[3], record[4], record[5], record[6]};
    s.translation_motion = GetMotion(record + 7);
    s.rotation_motion    = GetMotion(record + 16);
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
    NodeStateUpdateCurrent(&s);
  }
  for (size_t j = 0; j < joints_.size(); ++j) {
    const double *record = &joints[kJointStateSize * j];
    LocalJoint   &J      = joints_[j];
    for (int c = 0; c < kJointMaxReleased; ++c) J.start.q[c] = record[c], J.increment[c] = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) J.start.free_rotation_start(i, k) = record[kJointMaxReleased + 3 * i + k];
  }
  for (size_t b = 0; b < rigid_bodies_.size(); ++b) rigid_bodies_[b].centre_of_mass = GetMotion(&bodies[kRigidBodyStateSize * b]);
  UpdateSlaves();
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
