// Numerical trouble in words: where a NaN or Inf first appears, which element cannot be evaluated,
// which node or joint an unknown belongs to. Only used on the failure path, so it recomputes what
// it needs from the kernels instead of keeping anything during assembly.
//
// Every rank looks at what it alone holds (owned nodes, assembled elements, owned joints, rigid
// bodies of owned nodes) and offers its first finding with a key; the lowest key in the whole
// model wins and its text is broadcast from the rank that found it. The key orders findings by
// where trouble comes from before by number: a node's own unknowns feed the joints that place
// their slaves, both feed the loads and elements, so a NaN increment is named rather than the
// elements it spoils.
#include "assembly/assembler.hpp"
#include "core/format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>

namespace msflex {

namespace {

const char *const kDofNames[6] = {"ux", "uy", "uz", "rx", "ry", "rz"};

// Sources of non-finite values, upstream first (the high bits of a finding's key).
enum class Source : PetscInt64 { NodeIncrement = 0, Joint, NodeLoad, Element, NodeForces, RigidBody };

constexpr PetscInt64 kNoFinding = std::numeric_limits<PetscInt64>::max();

PetscInt64 FindingKey(Source source, PetscInt64 global_index) { return ((PetscInt64)source << 40) + global_index; }

bool AllFinite(const double *values, int count)
{
  for (int i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
}

template <class Matrix> bool AllFinite(const Matrix &m) { return m.allFinite(); }

bool NodeStateFinite(const NodeState &s)
{
  return AllFinite(s.displacement_increment) && AllFinite(s.rotation_increment) && AllFinite(s.position) && AllFinite(s.rotation) &&
         AllFinite(s.rotation_tangent) && AllFinite(s.tangent_scaled_increment) && AllFinite(s.tangent_scaled_derivative) &&
         AllFinite(s.translation_update.velocity) && AllFinite(s.translation_update.acceleration);
}

std::string NodeLabel(const Model &model, int node) { return Format("node '%s'", model.nodes[node].name.c_str()); }

// "element 12 (nodes 'arm.3', 'arm.4')": the element's number in the whole model (its row in the
// output file) and its nodes' names, which survive DofMapRestrictToLocal (its beam does not).
std::string ElementLabel(const Model &model, const DofMap &map, int element)
{
  const BeamElement &e     = model.elements[element];
  std::string        label = Format("element %d (nodes ", map.global_elements[element]);
  for (int a = 0; a <= e.order; ++a) label += Format("%s'%s'", a > 0 ? ", " : "", model.nodes[e.nodes[a]].name.c_str());
  return label + ")";
}

// Name of released coordinate c of a joint, as in the joint history (tx ty tz, rx ry rz in joint axes).
const char *JointCoordinateName(const Joint &joint, int c)
{
  static const char *const translation_names[3] = {"tx", "ty", "tz"}, *rotation_names[3] = {"rx", "ry", "rz"};
  if (c < joint.num_translations) return translation_names[joint.translation_axis[c]];
  const int r = c - joint.num_translations;
  if (joint.rotation == Joint::Rotation::Free) return rotation_names[r];
  return rotation_names[joint.rotation_axis[r]];
}

// The text of the lowest key over all ranks (empty when no rank has a finding). Collective.
PetscErrorCode LowestFinding(MPI_Comm comm, PetscInt64 key, const std::string &text, std::string *chosen)
{
  PetscInt64  lowest;
  PetscMPIInt rank, size, candidate, root;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(MPIU_Allreduce(&key, &lowest, 1, MPIU_INT64, MPI_MIN, comm));
  chosen->clear();
  if (lowest == kNoFinding) PetscFunctionReturn(PETSC_SUCCESS);
  candidate = key == lowest ? rank : size;
  PetscCall(MPIU_Allreduce(&candidate, &root, 1, MPI_INT, MPI_MIN, comm));
  int length = rank == root ? (int)text.size() : 0;
  PetscCallMPI(MPI_Bcast(&length, 1, MPI_INT, root, comm));
  chosen->assign(rank == root ? text : std::string((size_t)length, ' '));
  PetscCallMPI(MPI_Bcast(chosen->data(), length, MPI_CHAR, root, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Keeps the finding with the lowest key.
struct Finding {
  PetscInt64  key = kNoFinding;
  std::string text;
  void        Offer(Source source, PetscInt64 global_index, std::string description)
  {
    const PetscInt64 candidate = FindingKey(source, global_index);
    if (candidate < key) key = candidate, text = std::move(description);
  }
};

} // namespace

PetscErrorCode Assembler::DescribeNonFinite(std::string *where)
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  PetscMPIInt   rank;
  Finding       finding;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  std::vector<char> node_finite(nodes_.size());
  for (size_t l = 0; l < nodes_.size(); ++l) node_finite[l] = NodeStateFinite(nodes_[l]);

  // A node's own unknowns (or prescribed values) and the configuration derived from them; slaves
  // are placed by their joints and looked at there.
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (node_finite[l] || node_local_joint_[l] >= 0) continue;
    const int        node = map.local_nodes[l];
    const NodeState &s    = nodes_[l];
    std::string      what = "in the configuration derived from its increments";
    for (int d = 5; d >= 0; --d) // the first non-finite component wins
      if (!std::isfinite(d < 3 ? s.displacement_increment(d) : s.rotation_increment(d - 3)))
        what = Format("in its %s %s", map.constraints[node][d].kind == Support::Kind::Prescribed ? "prescribed" : "increment", kDofNames[d]);
    finding.Offer(Source::NodeIncrement, map.global_nodes[node], NodeLabel(model, node) + ", " + what);
  }
  // Joints place their slaves from a finite master (a non-finite master is named upstream).
  for (const LocalJoint &J : joints_) {
    const int j = map.local_joints[J.local_index];
    if (map.joint_rank[j] != rank || (J.local_master >= 0 && !node_finite[J.local_master])) continue;
    const Joint &joint = ModelJoint(J);
    std::string  what;
    for (int c = JointNumCoordinates(J.geometry) - 1; c >= 0; --c)
      if (!std::isfinite(J.increment[c])) what = Format("in its coordinate %s", JointCoordinateName(joint, c));
    if (what.empty() &&
        !(node_finite[J.local_slave] && AllFinite(J.rows_map) && AllFinite(expansion_rows_[J.local_slave].data(), (int)expansion_rows_[J.local_slave].size()) &&
          AllFinite(expansion_columns_[J.local_slave].data(), (int)expansion_columns_[J.local_slave].size())))
      what = Format("in the configuration of its slave node '%s'", model.nodes[joint.slave].name.c_str());
    if (!what.empty()) finding.Offer(Source::Joint, map.joint_slot[j], Format("joint '%s', ", joint.name.c_str()) + what);
  }
  // Nodal loads (their functions of time).
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (AllFinite(dead_force_[l]) && AllFinite(dead_moment_[l]) && AllFinite(follower_force_start_[l]) && AllFinite(follower_moment_start_[l]) &&
        AllFinite(follower_force_end_[l]) && AllFinite(follower_moment_end_[l]))
      continue;
    const int node = map.local_nodes[l];
    finding.Offer(Source::NodeLoad, map.global_nodes[node], NodeLabel(model, node) + ", in its load");
  }
  // Elements whose nodes are finite: distributed load, then residual (internal forces, inertia,
  // em's correction), then tangent.
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const int          e        = map.local_elements[k];
    const BeamElement &element  = model.elements[e];
    bool               nodes_ok = true;
    for (int a = 0; a <= element.order; ++a) nodes_ok = nodes_ok && node_finite[map.node_to_local[element.nodes[a]]];
    if (!nodes_ok) continue;
    bool        trouble = false;
    std::string what;
    if (!AllFinite(element_line_load_[k])) trouble = true, what = ", in its distributed load";
    else {
      double    force[kBeamMaxDofs], correction[kBeamMaxDofs], mismatch, correction_work, work_scale;
      PetscBool ok;
      const int nd = 6 * (element.order + 1);
      std::fill(correction, correction + nd, 0.0);
      PetscCall(ElementForces(k, force, correction, &mismatch, &correction_work, &work_scale, &ok));
      if (!ok) continue; // cannot be evaluated: DescribeUnevaluable's business
      if (!AllFinite(force, nd) || !AllFinite(correction, nd)) trouble = true;
      else if (mode_ != Mode::InitialAcceleration) {
        Vec3   positions[kBeamMaxNodes];
        Mat3   triads[kBeamMaxNodes];
        double r[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs];
        ElementConfiguration(element, positions, triads, nullptr);
        if (BeamInternalForces(element_references_[k], section_stiffness_[element.section], positions, triads, r, K, nullptr, nullptr) ==
                BeamKernelStatus::Ok &&
            !AllFinite(K, nd * nd))
          trouble = true, what = ", in its tangent";
      }
    }
    if (trouble) finding.Offer(Source::Element, map.global_elements[e], ElementLabel(model, map, e) + what);
  }
  // Nodal forces beyond the loads: rotary inertia and the follower loads' rotation.
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (!node_finite[l]) continue;
    double r[6];
    Mat6   block;
    NodalForces(l, r, &block);
    if (AllFinite(r, 6) && AllFinite(block)) continue;
    const int node = map.local_nodes[l];
    finding.Offer(Source::NodeForces, map.global_nodes[node],
                  NodeLabel(model, node) + (AllFinite(node_inertia_[l]) ? ", in its nodal forces" : ", in its rotary inertia"));
  }
  for (LocalRigidBody &body : rigid_bodies_) {
    if (!node_finite[body.local_node]) continue;
    Vec6 r;
    Mat6 block;
    PetscCall(RigidBodyForces(&body, &r, &block));
    if (AllFinite(r) && AllFinite(block) && AllFinite(body.gravity_force)) continue;
    const int node = map.local_nodes[body.local_node];
    finding.Offer(Source::RigidBody, map.global_nodes[node], "the rigid body on " + NodeLabel(model, node));
  }
  PetscCall(LowestFinding(comm_, finding.key, finding.text, where));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DescribeUnevaluable(std::string *where)
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  Finding       finding;
  PetscFunctionBeginUser;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const int          e        = map.local_elements[k];
    const BeamElement &element  = model.elements[e];
    bool               nodes_ok = true;
    for (int a = 0; a <= element.order; ++a) nodes_ok = nodes_ok && NodeStateFinite(nodes_[map.node_to_local[element.nodes[a]]]);
    if (!nodes_ok) continue; // a NaN configuration is DescribeNonFinite's business
    double    force[kBeamMaxDofs], correction[kBeamMaxDofs], mismatch, correction_work, work_scale;
    PetscBool ok;
    PetscCall(ElementForces(k, force, correction, &mismatch, &correction_work, &work_scale, &ok));
    if (!ok) finding.Offer(Source::Element, map.global_elements[e], ElementLabel(model, map, e));
  }
  PetscCall(LowestFinding(comm_, finding.key, finding.text, where));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DescribeUnknown(PetscInt row, std::string *what)
{
  const Model  &model = *model_;
  const DofMap &map   = *map_;
  PetscMPIInt   rank;
  Finding       finding;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  // Only the owner of the row holds the node or joint it belongs to.
  if (row >= map.first_owned && row < map.first_owned + map.num_owned) {
    for (PetscInt l = 0; l < map.num_owned_nodes && finding.text.empty(); ++l) {
      const int node = map.local_nodes[l];
      for (int d = 0; d < 6; ++d)
        if (map.node_dofs[node][d] == row) finding.Offer(Source::NodeIncrement, row, NodeLabel(model, node) + " " + kDofNames[d]);
    }
    for (size_t i = 0; i < map.local_joints.size() && finding.text.empty(); ++i) {
      const int j = map.local_joints[i];
      if (map.joint_rank[j] != rank) continue;
      for (int c = 0; c < kJointMaxReleased; ++c)
        if (map.joint_dofs[j][c] == row)
          finding.Offer(Source::NodeIncrement, row, Format("joint '%s' %s", model.joints[j].name.c_str(), JointCoordinateName(model.joints[j], c)));
    }
  }
  PetscCall(LowestFinding(comm_, finding.key, finding.text, what));
  if (what->empty()) *what = Format("unknown %" PetscInt_FMT, row);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
