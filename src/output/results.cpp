#include "output/results.hpp"

#include "joints/joint_model.hpp"

#include <H5pubconf.h>

#ifndef H5_HAVE_PARALLEL
#error "msflex needs the MPI build of HDF5 (Debian: libhdf5-openmpi-dev)"
#endif

namespace msflex {

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

// A distributed frame: each rank holds the rows of the nodes and elements it owns, which the
// output file writes collectively (parallel HDF5). No communication here.
PetscErrorCode GatherFrame(MPI_Comm, const Model &model, const Assembler &assembler, const std::vector<ElementResults> &element_results, int step, double time,
                           bool with_velocities, OutputFrame *frame)
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
