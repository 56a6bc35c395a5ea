#include "output/results.hpp"

#include "joints/joint_model.hpp"

#include <Eigen/Eigenvalues>
#include <H5pubconf.h>

#include <algorithm>
#include <cmath>

#ifndef H5_HAVE_PARALLEL
#error "msflex needs the MPI build of HDF5 (Debian: libhdf5-openmpi-dev)"
#endif

namespace msflex {

// Principal moments (ascending) and axes (columns, right-handed) of a rigid body's inertia about
// its centre of mass, and the semi-axes a_k of the uniform solid ellipsoid of the same mass and
// inertia: I_k = m (a_i^2 + a_j^2) / 5 for {i, j, k} = {1, 2, 3}, so a_k^2 = 5 (I_i + I_j - I_k) / (2 m)
// (0 where round-off makes it negative). The axes drawn per frame are R (a_k e_k).
BodyPrincipalAxes RigidBodyPrincipalAxes(const RigidBody &body)
{
  BodyPrincipalAxes                         principal;
  const Eigen::SelfAdjointEigenSolver<Mat3> solver(0.5 * (body.inertia + body.inertia.transpose()));
  principal.moments = solver.eigenvalues();
  principal.axes    = solver.eigenvectors();
  // A sign that does not depend on the solver: each axis's largest component positive, then the
  // third axis turned to make the triad right-handed.
  for (int k = 0; k < 3; ++k) {
    Eigen::Index largest;
    principal.axes.col(k).cwiseAbs().maxCoeff(&largest);
    if (principal.axes(largest, k) < 0) principal.axes.col(k) *= -1.0;
  }
  if (principal.axes.determinant() < 0) principal.axes.col(2) *= -1.0;
  const double trace = principal.moments.sum();
  for (int k = 0; k < 3; ++k) principal.semi_axes(k) = body.mass > 0 ? std::sqrt(std::max(0.0, 2.5 * (trace - 2.0 * principal.moments(k)) / body.mass)) : 0.0;
  return principal;
}

// The rigid bodies: what they are (mass, inertia, where) and their principal axes.
static void AddRigidBodiesToMesh(const Model &model, OutputMesh *mesh)
{
  for (const RigidBody &body : model.rigid_bodies) {
    const BodyPrincipalAxes principal = RigidBodyPrincipalAxes(body);
    mesh->body_names.push_back(model.nodes[body.node].name);
    mesh->body_node.push_back(body.node);
    mesh->body_mass.push_back(body.mass);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) mesh->body_inertia.push_back(body.inertia(i, j));
      mesh->body_offset.push_back(body.offset(i));
      mesh->body_principal_moments.push_back(principal.moments(i));
      mesh->body_semi_axes.push_back(principal.semi_axes(i));
    }
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) mesh->body_principal_axes.push_back(principal.axes(i, k));
  }
}

// The ground markers: each joint to the ground (at its slave's reference position, the joint
// axes) and each node whose six DOFs are fixed (the global axes).
static void AddGroundToMesh(const Model &model, OutputMesh *mesh)
{
  const auto add = [&](const std::string &name, const char *kind, const Vec3 &position, const Mat3 &axes) {
    mesh->ground_names.push_back(name);
    mesh->ground_kinds.push_back(kind);
    for (int i = 0; i < 3; ++i) mesh->ground_position.push_back(position(i));
    for (int k = 0; k < 3; ++k)
      for (int i = 0; i < 3; ++i) mesh->ground_axes.push_back(axes(i, k));
  };
  for (const Joint &joint : model.joints)
    if (joint.master < 0) add(joint.name, "joint", model.nodes[joint.slave].position, joint.axes);
  std::vector<int> fixed_dofs(model.nodes.size(), 0); // bit k: DOF k fixed by some support
  for (const Support &support : model.supports)
    for (const int node : support.nodes)
      for (int k = 0; k < 6; ++k)
        if (support.kind[k] == Support::Kind::Fixed) fixed_dofs[node] |= 1 << k;
  for (size_t n = 0; n < model.nodes.size(); ++n)
    if (fixed_dofs[n] == 0x3f) add(model.nodes[n].name, "support", model.nodes[n].position, Mat3::Identity());
}

void BuildOutputMesh(const Model &model, OutputMesh *mesh)
{
  mesh->node_coordinates.clear();
  mesh->node_names.clear();
  for (const Node &node : model.nodes) {
    for (int i = 0; i < 3; ++i) mesh->node_coordinates.push_back(node.position(i));
    mesh->node_names.push_back(node.name);
  }
  mesh->element_nodes.clear();
  mesh->element_order.clear();
  mesh->element_beam.clear();
  for (const BeamElement &element : model.elements) {
    for (int a = 0; a < 3; ++a) mesh->element_nodes.push_back(a <= element.order ? element.nodes[a] : -1);
    mesh->element_order.push_back(element.order);
    mesh->element_beam.push_back(element.beam);
  }
  mesh->beam_names.clear();
  for (const Beam &beam : model.beams) mesh->beam_names.push_back(beam.name);
  for (const Joint &joint : model.joints) {
    mesh->joint_names.push_back(joint.name);
    mesh->joint_types.push_back(joint.type);
    mesh->joint_master.push_back(joint.master);
    mesh->joint_slave.push_back(joint.slave);
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) mesh->joint_axes.push_back(joint.axes(i, c));
    const Vec3 offset = JointReferenceOffset(model, joint);
    for (int i = 0; i < 3; ++i) mesh->joint_offset.push_back(offset(i));
  }
  mesh->analysis_type = model.analysis.type;
  AddRigidBodiesToMesh(model, mesh);
  AddGroundToMesh(model, mesh);
}

// Position (3), displacement (3), quaternion (4), tracked rotation angle (1), velocity (3) and
// spatial angular velocity (3) of a node.
constexpr int kNodeRecordSize = 17;
static void   PackNodeRecord(const Model &model, int node, const NodeState &state, double *out)
{
  const Quaternion q = NodeStateCurrentQuaternion(state);
  for (int i = 0; i < 3; ++i) {
    out[i]     = state.position(i);
    out[3 + i] = state.position(i) - model.nodes[node].position(i);
  }
  out[6] = q.w, out[7] = q.x, out[8] = q.y, out[9] = q.z;
  out[10]      = QuaternionTrackedAngle(q);
  const Vec3 w = QuaternionToMatrix(state.rotation_start) * state.rotation_motion.velocity;
  for (int i = 0; i < 3; ++i) {
    out[11 + i] = state.translation_motion.velocity(i);
    out[14 + i] = w(i);
  }
}

// Appends one node record to the frame's per-node arrays (velocities only when requested).
static void AppendNodeRecord(const double *in, bool with_velocities, OutputFrame *frame)
{
  frame->position.insert(frame->position.end(), in, in + 3);
  frame->displacement.insert(frame->displacement.end(), in + 3, in + 6);
  frame->rotation.insert(frame->rotation.end(), in + 6, in + 10);
  if (with_velocities) {
    frame->velocity.insert(frame->velocity.end(), in + 11, in + 14);
    frame->angular_velocity.insert(frame->angular_velocity.end(), in + 14, in + 17);
  }
}

// The rigid bodies on this rank's owned nodes: centre of mass x + R c, principal axes R (a_k e_k)
// and the node's rotation quaternion (rows: the bodies' numbers in the whole model).
static void AppendRigidBodyRows(const Model &model, const DofMap &map, const std::vector<NodeState> &nodes, OutputFrame *frame)
{
  for (size_t b = 0; b < model.rigid_bodies.size(); ++b) {
    const RigidBody &body = model.rigid_bodies[b];
    const int        l    = map.node_to_local[body.node];
    if (l < 0 || l >= map.num_owned_nodes) continue; // a ghost's body is written by the node's owner
    const NodeState        &state     = nodes[l];
    const BodyPrincipalAxes principal = RigidBodyPrincipalAxes(body);
    const Vec3              center    = state.position + state.rotation * body.offset;
    const Quaternion        q         = NodeStateCurrentQuaternion(state);
    frame->body_rows.push_back(map.global_rigid_bodies[b]);
    for (int i = 0; i < 3; ++i) frame->body_center.push_back(center(i));
    for (int k = 0; k < 3; ++k) {
      const Vec3 axis = state.rotation * (principal.semi_axes(k) * principal.axes.col(k));
      for (int i = 0; i < 3; ++i) frame->body_axes.push_back(axis(i));
    }
    frame->body_rotation.insert(frame->body_rotation.end(), {q.w, q.x, q.y, q.z});
  }
}

// The joints this rank owns (those of its slave nodes): the slave node's position and the joint
// axes carried by the master, R_master a_k (the reference axes for a joint to the ground).
static void AppendJointRows(MPI_Comm comm, const Model &model, const DofMap &map, const std::vector<NodeState> &nodes, OutputFrame *frame)
{
  PetscMPIInt rank;
  MPI_Comm_rank(comm, &rank);
  for (size_t j = 0; j < model.joints.size(); ++j) {
    if (map.joint_rank[j] != rank) continue;
    const Joint &joint  = model.joints[j];
    const Vec3  &slave  = nodes[map.node_to_local[joint.slave]].position;
    const Mat3   master = joint.master < 0 ? Mat3::Identity() : nodes[map.node_to_local[joint.master]].rotation;
    frame->joint_rows.push_back(map.global_joints[j]);
    for (int i = 0; i < 3; ++i) frame->joint_position.push_back(slave(i));
    for (int k = 0; k < 3; ++k) {
      const Vec3 axis = master * joint.axes.col(k);
      for (int i = 0; i < 3; ++i) frame->joint_axes.push_back(axis(i));
    }
  }
}

// A distributed frame: each rank holds the rows of the nodes and elements it owns, which the
// output file writes collectively (parallel HDF5). No communication here.
PetscErrorCode GatherFrame(MPI_Comm comm, const Model &model, const Assembler &assembler, const std::vector<ElementResults> &element_results, int step,
                           double time, bool with_velocities, OutputFrame *frame)
{
  PetscFunctionBeginUser;
  const DofMap                 &map   = assembler.Map();
  const std::vector<NodeState> &nodes = assembler.LocalNodes();
  *frame                              = OutputFrame{};
  frame->step                         = step;
  frame->time                         = time;
  frame->distributed                  = true;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    double in[kNodeRecordSize];
    PackNodeRecord(model, map.local_nodes[l], nodes[l], in);
    frame->node_rows.push_back(map.global_nodes[map.local_nodes[l]]);
    AppendNodeRecord(in, with_velocities, frame);
  }
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const ElementResults &r = element_results[k];
    frame->element_rows.push_back(map.global_elements[map.local_elements[k]]);
    frame->element_first_segment.push_back(map.element_first_segment[map.local_elements[k]]);
    const BeamElement &element = model.elements[map.local_elements[k]];
    frame->element_segment_count.push_back(element.order);
    // Section triad at each segment's first node: the node's rotation times the reference triad.
    for (int a = 0; a < element.order; ++a) {
      const Mat3 triad = nodes[map.node_to_local[element.nodes[a]]].rotation * element.reference_triads[a];
      for (int axis = 0; axis < 3; ++axis)
        for (int i = 0; i < 3; ++i) frame->segment_triads.push_back(triad(i, axis));
    }
    for (int i = 0; i < 3; ++i) frame->element_strains.push_back(r.strain(i));
    for (int i = 0; i < 3; ++i) frame->element_strains.push_back(r.curvature(i));
    for (int i = 0; i < 3; ++i) frame->element_resultants.push_back(r.force(i));
    for (int i = 0; i < 3; ++i) frame->element_resultants.push_back(r.moment(i));
  }
  AppendRigidBodyRows(model, map, nodes, frame);
  AppendJointRows(comm, model, map, nodes, frame);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SampleProbes(MPI_Comm comm, const Model &model, const Assembler &assembler, std::vector<ProbeSample> *samples)
{
  PetscFunctionBeginUser;
  const DofMap                 &map   = assembler.Map();
  const std::vector<NodeState> &nodes = assembler.LocalNodes();
  const size_t                  count = model.probes.size();
  std::vector<double>           local(kNodeRecordSize * count, 0.0), global(kNodeRecordSize * count, 0.0);
  for (size_t p = 0; p < count; ++p) {
    const int node = model.probes[p].node; // -1: not held here (restricted model)
    const int l    = node >= 0 ? map.node_to_local[node] : -1;
    if (l >= 0 && l < map.num_owned_nodes) PackNodeRecord(model, node, nodes[l], &local[kNodeRecordSize * p]);
  }
  PetscCall(MPIU_Allreduce(local.data(), global.data(), (PetscMPIInt)global.size(), MPI_DOUBLE, MPI_SUM, comm));
  samples->assign(count, ProbeSample{});
  for (size_t p = 0; p < count; ++p) {
    ProbeSample  &sample = (*samples)[p];
    const double *in     = &global[kNodeRecordSize * p];
    sample.name          = model.probes[p].name;
    for (int i = 0; i < 3; ++i) {
      sample.position[i]     = in[i];
      sample.displacement[i] = in[3 + i];
    }
    for (int i = 0; i < 4; ++i) sample.rotation[i] = in[6 + i];
    sample.rotation_angle = in[10];
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
