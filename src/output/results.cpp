#include "output/results.hpp"

#include "model/joint_geometry.hpp"

#include <Eigen/Eigenvalues>
#include <H5pubconf.h>

#include <algorithm>
#include <cmath>
#include <cstring>

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
// Rank 0 receives every rank's `count` items of `type` (element_size bytes each), in rank order,
// into *received; the other ranks receive nothing. Collective.
static PetscErrorCode GatherToRoot(MPI_Comm comm, const void *send, int count, MPI_Datatype type, std::vector<char> *received, size_t element_size)
{
  PetscMPIInt rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  if (size == 1) { // a copy: no count tables to allocate, nothing to gather (a history row per step)
    const char *bytes = static_cast<const char *>(send);
    received->assign(bytes, bytes + element_size * (size_t)count);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  std::vector<int> counts(rank == 0 ? size : 0), offsets(rank == 0 ? size : 0);
  PetscCallMPI(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm));
  int total = 0;
  for (int r = 0; r < (int)counts.size(); ++r) offsets[r] = total, total += counts[r];
  received->resize(element_size * (size_t)total);
  PetscCallMPI(MPI_Gatherv(send, count, type, received->data(), counts.data(), offsets.data(), type, 0, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static void AddRigidBodiesToMesh(const Model &model, OutputMesh *mesh)
{
  for (const RigidBody &body : model.rigid_bodies) {
    const BodyPrincipalAxes principal = RigidBodyPrincipalAxes(body);
    mesh->body_names.push_back(body.name.empty() ? model.nodes[body.node].name : body.name); // its own name when given, else its node's
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
// axes), each node whose six DOFs are fixed ("support", the global axes), and each node whose
// three translations are fixed and some rotation not ("pin": a hinge, a ball or a driven shaft's
// bearing, which stays where it is; a1 along its one free or prescribed rotation's global axis
// when it has one, a2 and a3 the next two axes in cyclic order, else the global axes). A node with
// a free or prescribed translation moves and gets no fixed marker.
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
  for (size_t n = 0; n < model.nodes.size(); ++n) {
    if (fixed_dofs[n] == 0x3f) add(model.nodes[n].name, "support", model.nodes[n].position, Mat3::Identity());
    else if ((fixed_dofs[n] & 0x7) == 0x7) {
      const int rotations = fixed_dofs[n] >> 3, moving = 7 & ~rotations; // bit k: rotation about global axis k not fixed
      Mat3      axes = Mat3::Identity();
      if (moving == 1 || moving == 2 || moving == 4) {
        const int k = moving == 1 ? 0 : moving == 2 ? 1 : 2;
        for (int c = 0; c < 3; ++c) axes.col(c) = Mat3::Identity().col((k + c) % 3);
      }
      add(model.nodes[n].name, "pin", model.nodes[n].position, axes);
    }
  }
}

// The force elements, each drawn as a segment between nodes: a two-node element's nodes; a
// coordinate element's joint's master and slave, or the slave twice (a point) for a joint to the
// ground.
static void AddForceElementsToMesh(const Model &model, OutputMesh *mesh)
{
  mesh->force_element_names.clear();
  mesh->force_element_kinds.clear();
  mesh->force_element_nodes.clear();
  for (const ForceElement &element : model.force_elements) {
    std::array<int, 2> nodes = element.nodes;
    const char        *kind  = "coordinate";
    if (element.kind == ForceElement::Kind::Coordinate) {
      const Joint &joint = model.joints[element.joint];
      nodes              = {{joint.master >= 0 ? joint.master : joint.slave, joint.slave}};
    } else kind = element.kind == ForceElement::Kind::SpringDamper ? "spring_damper" : "bushing";
    mesh->force_element_names.push_back(element.name);
    mesh->force_element_kinds.push_back(kind);
    mesh->force_element_nodes.insert(mesh->force_element_nodes.end(), nodes.begin(), nodes.end());
  }
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
    mesh->joint_types.push_back(JointKindName(joint.kind));
    mesh->joint_master.push_back(joint.master);
    mesh->joint_slave.push_back(joint.slave);
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) mesh->joint_axes.push_back(joint.axes(i, c));
    const Vec3 offset = JointReferenceOffset(model, joint);
    for (int i = 0; i < 3; ++i) mesh->joint_offset.push_back(offset(i));
  }
  mesh->analysis_type = AnalysisTypeName(model.analysis.type);
  AddRigidBodiesToMesh(model, mesh);
  AddGroundToMesh(model, mesh);
  AddForceElementsToMesh(model, mesh);
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

// The rigid bodies of the State (those on this rank's owned nodes): centre of mass x + R c,
// principal axes R (a_k e_k) and the node's rotation quaternion (rows: the bodies' numbers in the
// whole model).
static void AppendRigidBodyRows(const Model &model, const State &state, OutputFrame *frame)
{
  for (const RigidBodyState &B : state.bodies) {
    const NodeState        &node      = state.nodes[B.local_node];
    const BodyPrincipalAxes principal = RigidBodyPrincipalAxes(model.rigid_bodies[B.body]);
    const Vec3              center    = node.position + node.rotation * B.offset;
    const Quaternion        q         = NodeStateCurrentQuaternion(node);
    frame->body_rows.push_back(B.global_index);
    for (int i = 0; i < 3; ++i) frame->body_center.push_back(center(i));
    for (int k = 0; k < 3; ++k) {
      const Vec3 axis = node.rotation * (principal.semi_axes(k) * principal.axes.col(k));
      for (int i = 0; i < 3; ++i) frame->body_axes.push_back(axis(i));
    }
    frame->body_rotation.insert(frame->body_rotation.end(), {q.w, q.x, q.y, q.z});
  }
}

// The joints of the State this rank owns (those of its slave nodes): the slave node's position and
// the joint axes carried by the master, R_master a_k (the reference axes for a joint to the ground).
static void AppendJointRows(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, OutputFrame *frame)
{
  PetscMPIInt rank;
  MPI_Comm_rank(comm, &rank);
  for (const JointState &J : state.joints) {
    if (map.joint_rank[J.joint] != rank) continue;
    const Joint &joint  = model.joints[J.joint];
    const Vec3  &slave  = state.nodes[J.local_slave].position;
    const Mat3   master = J.local_master < 0 ? Mat3::Identity() : state.nodes[J.local_master].rotation;
    frame->joint_rows.push_back(map.global_joints[J.joint]);
    for (int i = 0; i < 3; ++i) frame->joint_position.push_back(slave(i));
    for (int k = 0; k < 3; ++k) {
      const Vec3 axis = master * joint.axes.col(k);
      for (int i = 0; i < 3; ++i) frame->joint_axes.push_back(axis(i));
    }
  }
}

// A distributed frame: each rank holds the rows of the nodes and elements it owns, which the
// output file writes collectively (parallel HDF5). No communication here.
PetscErrorCode GatherFrame(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, const std::vector<ElementResults> &element_results,
                           int step, double time, bool with_velocities, OutputFrame *frame)
{
  PetscFunctionBeginUser;
  const std::vector<NodeState> &nodes = state.nodes;
  frame->Clear(); // keeps the arrays' capacity for the next frame
  frame->step        = step;
  frame->time        = time;
  frame->distributed = true;
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
  AppendRigidBodyRows(model, state, frame);
  AppendJointRows(comm, model, map, state, frame);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SampleProbes(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, std::vector<ProbeSample> *samples,
                            std::vector<double> *scratch)
{
  PetscMPIInt size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const std::vector<NodeState> &nodes = state.nodes;
  const size_t                  count = model.probes.size();
  std::vector<double>           own;
  std::vector<double>          &records = scratch ? *scratch : own; // kept from row to row by the caller
  records.assign(kNodeRecordSize * count, 0.0);
  for (size_t p = 0; p < count; ++p) {
    const Probe &probe = model.probes[p];
    const int    node  = probe.node; // -1: not held here (restricted model)
    const int    l     = node >= 0 ? map.node_to_local[node] : -1;
    if (probe.kind != Probe::Kind::Point || l < 0 || l >= map.num_owned_nodes) continue;
    double *record = &records[kNodeRecordSize * p];
    PackNodeRecord(model, node, nodes[l], record);
    // A point at `offset` from the node (in the node's frame, given at the reference).
    const Vec3 point = nodes[l].rotation * probe.offset;
    for (int i = 0; i < 3; ++i) record[i] += point(i), record[3 + i] += point(i) - probe.offset(i);
  }
  // Each record is held by one rank and zero on the others.
  if (size > 1 && count > 0) PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, records.data(), (PetscMPIInt)records.size(), MPI_DOUBLE, MPI_SUM, comm));
  // The samples are overwritten in place: a row allocates nothing once the first has named them.
  size_t written = 0;
  for (size_t p = 0; p < count; ++p) {
    if (model.probes[p].kind != Probe::Kind::Point) continue;
    if (written == samples->size()) samples->emplace_back();
    ProbeSample  &sample = (*samples)[written++];
    const double *in     = &records[kNodeRecordSize * p];
    sample.name          = model.probes[p].name;
    for (int i = 0; i < 3; ++i) {
      sample.position[i]     = in[i];
      sample.displacement[i] = in[3 + i];
    }
    for (int i = 0; i < 4; ++i) sample.rotation[i] = in[6 + i];
    sample.rotation_angle = in[10];
  }
  samples->resize(written);
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Gathers the ranks' series names ('\0'-terminated in `local_names`) and their places
// (`local_orders`) to rank 0, which puts the names in the order of the places (ties in the order
// gathered) and records each gathered position's place in *permutation. Collective.
static PetscErrorCode GatherNamesInOrder(MPI_Comm comm, const std::string &local_names, const std::vector<double> &local_orders,
                                         std::vector<std::string> *names, std::vector<size_t> *permutation)
{
  std::vector<char> gathered_names, gathered_orders;
  PetscFunctionBeginUser;
  PetscCall(GatherToRoot(comm, local_names.data(), (int)local_names.size(), MPI_CHAR, &gathered_names, 1));
  PetscCall(GatherToRoot(comm, local_orders.data(), (int)local_orders.size(), MPI_DOUBLE, &gathered_orders, sizeof(double)));
  std::vector<std::string> unordered;
  for (size_t start = 0; start < gathered_names.size();) {
    const size_t end = std::find(gathered_names.begin() + (std::ptrdiff_t)start, gathered_names.end(), '\0') - gathered_names.begin();
    unordered.emplace_back(gathered_names.data() + start, end - start);
    start = end + 1;
  }
  const double       *orders = reinterpret_cast<const double *>(gathered_orders.data());
  std::vector<size_t> sorted(unordered.size());
  for (size_t i = 0; i < sorted.size(); ++i) sorted[i] = i;
  std::stable_sort(sorted.begin(), sorted.end(), [&](size_t a, size_t b) { return orders[a] < orders[b]; });
  permutation->assign(sorted.size(), 0);
  names->resize(sorted.size());
  for (size_t place = 0; place < sorted.size(); ++place) (*permutation)[sorted[place]] = place, (*names)[place] = unordered[sorted[place]];
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The history series the ranks hold, on rank 0 in the model's order: the names and places
// (`local_names`, `local_orders`, only needed until cache->gathered) are gathered once, the values
// at every row; *names and *values on rank 0, empty elsewhere. `what` names the series in a
// message. Collective.
static PetscErrorCode GatherSeriesInOrder(MPI_Comm comm, const char *what, const std::string &local_names, const std::vector<double> &local_orders,
                                          const std::vector<double> &local_values, HistoryGather *cache, std::vector<std::string> *names,
                                          std::vector<double> *values)
{
  PetscMPIInt        rank;
  std::vector<char> &gathered_values = cache->gathered_values;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (!cache->gathered) {
    PetscCall(GatherNamesInOrder(comm, local_names, local_orders, &cache->names, &cache->permutation));
    cache->gathered = true;
  }
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  // One rank holds every series: its values are permuted where they are, without a gathered copy.
  if (size > 1) PetscCall(GatherToRoot(comm, local_values.data(), (int)local_values.size(), MPI_DOUBLE, &gathered_values, sizeof(double)));
  if (names) names->clear();
  values->clear();
  if (rank == 0) {
    const size_t count    = cache->names.size();
    const size_t received = size > 1 ? gathered_values.size() / sizeof(double) : local_values.size();
    if (names) *names = cache->names;
    values->resize(count);
    PetscCheck(received == count, PETSC_COMM_SELF, PETSC_ERR_PLIB, "%s: %zu values for %zu series", what, received, count);
    const double *in = size > 1 ? reinterpret_cast<const double *>(gathered_values.data()) : local_values.data();
    for (size_t i = 0; i < count; ++i) (*values)[cache->permutation[i]] = in[i];
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode JointHistory(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, HistoryGather *cache, std::vector<std::string> *names,
                            std::vector<double> *values)
{
  static const char *const translation_names[3] = {"tx", "ty", "tz"}, *rotation_names[3] = {"rx", "ry", "rz"};
  static const char *const reaction_names[6] = {"force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z"};
  PetscMPIInt              rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  // Owned joints in slot order; the series names are only built (and gathered to rank 0) once.
  std::vector<const JointState *> &owned = cache->owned_joints; // scratch: no allocation per row
  owned.clear();
  for (const JointState &J : state.joints)
    if (map.joint_rank[J.joint] == rank) owned.push_back(&J);
  std::sort(owned.begin(), owned.end(), [&](const JointState *a, const JointState *b) { return map.joint_slot[a->joint] < map.joint_slot[b->joint]; });
  const bool           need_names = !cache->gathered;
  std::vector<double> &local      = cache->local_values, local_orders;
  std::string          local_names; // '\0'-terminated series names
  local.clear();
  for (const JointState *J : owned) {
    const Joint            &joint = model.joints[J->joint];
    const JointCoordinates &q     = J->start;
    const int               nt    = joint.num_translations;
    const size_t            first = local_orders.size(); // the joint's first series (fewer than 64 per joint)
    // The name (base + suffix) and the series' place (the joint's index in the model, then the
    // series' within the joint) are only made when they are needed, not for every row.
    auto add = [&](const char *base, double value, const char *suffix = "") {
      if (need_names) {
        local_names += joint.name + "." + base + suffix + '\0';
        local_orders.push_back(64.0 * map.global_joints[J->joint] + (double)(local_orders.size() - first));
      }
      local.push_back(value);
    };
    for (int c = 0; c < nt; ++c) {
      add(translation_names[joint.translation_axis[c]], q.q[c]);
      add(translation_names[joint.translation_axis[c]], J->rate[c], "_rate");
    }
    if (joint.rotation == Joint::Rotation::Free) {
      const Vec3 rotation = joint.axes.transpose() * LogSO3(q.free_rotation_start);
      for (int i = 0; i < 3; ++i) add(rotation_names[i], rotation(i));
    } else {
      const int nr = joint.rotation == Joint::Rotation::OneAxis ? 1 : joint.rotation == Joint::Rotation::TwoAxes ? 2 : 0;
      for (int c = 0; c < nr; ++c) {
        add(rotation_names[joint.rotation_axis[c]], q.q[nt + c]);
        add(rotation_names[joint.rotation_axis[c]], J->rate[nt + c], "_rate");
      }
    }
    if (joint.dependence != Joint::Dependence::None) {
      double f, df, ddf, f0, df0, ddf0;
      JointDependentTranslation(J->geometry, q.q[nt], &f, &df, &ddf);
      JointDependentTranslation(J->geometry, 0.0, &f0, &df0, &ddf0);
      add(translation_names[joint.dependent_axis], f - f0);
    }
    for (int i = 0; i < 6; ++i) add(reaction_names[i], J->reaction(i));
    // On the coordinate as the drive names it: a screw driven by its translation, the force along it.
    if (joint.driven_coordinate >= 0) add("drive_force", J->drive_force / joint.drive_coordinate_scale);
  }
  // On rank 0 in the order of the joints in the model, whatever the partition: the history's
  // columns are the same on any number of ranks (a restart may change it).
  PetscCall(GatherSeriesInOrder(comm, "joint history", local_names, local_orders, local, cache, names, values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex

namespace msflex {

PetscErrorCode ProbeHistory(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, const std::vector<ElementResults> &element_results,
                            std::vector<std::string> *names, std::vector<double> *values)
{
  static const char *const reaction_names[6] = {"force_x", "force_y", "force_z", "moment_x", "moment_y", "moment_z"};
  static const char *const section_names[6]  = {"N1", "N2", "N3", "M1", "M2", "M3"};
  PetscFunctionBeginUser;
  if (names) names->clear();
  values->clear();
  const size_t count = model.probes.size();
  // Every rank has the same probes, so every rank takes part or none does.
  const bool any = std::any_of(model.probes.begin(), model.probes.end(),
                               [](const Probe &probe) { return probe.kind == Probe::Kind::Element || probe.kind == Probe::Kind::Reaction; });
  if (!any) PetscFunctionReturn(PETSC_SUCCESS);
  // Kept from row to row (a history row of a small model costs about a microsecond; two
  // allocations per row were a fifth of it).
  thread_local std::vector<double> local, global;
  local.assign(6 * count, 0.0);
  global.assign(6 * count, 0.0);
  for (size_t p = 0; p < count; ++p) {
    const Probe &probe = model.probes[p];
    if (probe.kind != Probe::Kind::Element || probe.element < 0) continue; // element < 0: held by another rank
    const int k = map.element_to_local[probe.element];
    if (k < 0 || k >= (int)element_results.size()) continue;
    for (int i = 0; i < 3; ++i) local[6 * p + i] = element_results[k].force(i), local[6 * p + 3 + i] = element_results[k].moment(i);
  }
  PetscCall(MPIU_Allreduce(local.data(), global.data(), (PetscMPIInt)global.size(), MPI_DOUBLE, MPI_SUM, comm));
  for (size_t p = 0; p < count; ++p) {
    const Probe &probe = model.probes[p];
    if (probe.kind == Probe::Kind::Element)
      for (int i = 0; i < 6; ++i) {
        if (names) names->push_back(probe.name + "." + section_names[i]);
        values->push_back(global[6 * p + i]);
      }
    else if (probe.kind == Probe::Kind::Reaction)
      for (int i = 0; i < 6; ++i) {
        if (names) names->push_back(probe.name + "." + reaction_names[i]);
        values->push_back(p < state.probe_reactions.size() ? state.probe_reactions[p](i) : 0.0);
      }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode GatherHistory(MPI_Comm comm, const std::vector<HistoryValue> &local, HistoryGather *cache, std::vector<std::string> *names,
                             std::vector<double> *values)
{
  std::string          local_names; // '\0'-terminated, only for the first gather
  std::vector<double>  local_orders;
  std::vector<double> &local_values = cache->local_values;
  PetscFunctionBeginUser;
  local_values.clear();
  for (const HistoryValue &v : local) {
    if (!cache->gathered) local_names += v.name + '\0', local_orders.push_back((double)v.order);
    local_values.push_back(v.value);
  }
  PetscCall(GatherSeriesInOrder(comm, "history", local_names, local_orders, local_values, cache, names, values));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
