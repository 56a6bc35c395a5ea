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
#include "contributors/beam_contributor.hpp"
#include "core/format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>

namespace msflex {

namespace {

const char *const kDofNames[6] = {"ux", "uy", "uz", "rx", "ry", "rz"};

bool AllFinite(const double *values, int count)
{
  for (int i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) return false;
  return true;
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
PetscErrorCode LowestFinding(MPI_Comm comm, const TroubleFindings &finding, std::string *chosen)
{
  PetscInt64  key = finding.key, lowest;
  PetscMPIInt rank, size, candidate, root;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(MPIU_Allreduce(&key, &lowest, 1, MPIU_INT64, MPI_MIN, comm));
  chosen->clear();
  if (lowest == TroubleFindings::kNone) PetscFunctionReturn(PETSC_SUCCESS);
  candidate = key == lowest ? rank : size;
  PetscCall(MPIU_Allreduce(&candidate, &root, 1, MPI_INT, MPI_MIN, comm));
  int length = rank == root ? (int)finding.text.size() : 0;
  PetscCallMPI(MPI_Bcast(&length, 1, MPI_INT, root, comm));
  chosen->assign(rank == root ? finding.text : std::string((size_t)length, ' '));
  PetscCallMPI(MPI_Bcast(chosen->data(), length, MPI_CHAR, root, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode Assembler::DescribeNonFinite(std::string *where)
{
  const Model    &model = *model_;
  const DofMap   &map   = *map_;
  const State    &state = *state_;
  PetscMPIInt     rank;
  TroubleFindings finding;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  std::vector<char> node_finite(state.nodes.size());
  for (size_t l = 0; l < state.nodes.size(); ++l) node_finite[l] = NodeStateFinite(state.nodes[l]);

  // A node's own unknowns (or prescribed values) and the configuration derived from them; slaves
  // are placed by their joints and looked at there.
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (node_finite[l] || IsSlave((int)l)) continue;
    const int        node = map.local_nodes[l];
    const NodeState &s    = state.nodes[l];
    std::string      what = "in the configuration derived from its increments";
    for (int d = 5; d >= 0; --d) // the first non-finite component wins
      if (!std::isfinite(d < 3 ? s.displacement_increment(d) : s.rotation_increment(d - 3)))
        what = Format("in its %s %s", map.constraints[node][d].kind == Support::Kind::Prescribed ? "prescribed" : "increment", kDofNames[d]);
    finding.Offer(TroubleSource::NodeIncrement, map.global_nodes[node], NodeLabel(model, node) + ", " + what);
  }
  // Joints place their slaves from a finite master (a non-finite master is named upstream).
  for (const JointState &J : state.joints) {
    if (map.joint_rank[J.joint] != rank || (J.local_master >= 0 && !node_finite[J.local_master])) continue;
    const Joint &joint = model.joints[J.joint];
    std::string  what;
    for (int c = JointNumCoordinates(J.geometry) - 1; c >= 0; --c)
      if (!std::isfinite(J.increment[c])) what = Format("in its coordinate %s", JointCoordinateName(joint, c));
    if (what.empty() && !(node_finite[J.local_slave] && J.rows_map.allFinite() &&
                          AllFinite(expansion_rows_[J.local_slave].data(), (int)expansion_rows_[J.local_slave].size()) &&
                          AllFinite(expansion_columns_[J.local_slave].data(), (int)expansion_columns_[J.local_slave].size())))
      what = Format("in the configuration of its slave node '%s'", model.nodes[joint.slave].name.c_str());
    if (!what.empty()) finding.Offer(TroubleSource::Joint, map.joint_slot[J.joint], Format("joint '%s', ", joint.name.c_str()) + what);
  }
  // The contributors' data (loads, inertia), then the forces of every element, node and rigid
  // body whose nodes are finite: residual (with em's correction), then tangent.
  for (const ForceContributor *c : contributors_) c->FindNonFiniteData(state, &finding);
  ElementContribution element;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const int          e        = map.local_elements[k];
    const BeamElement &nodes_of = model.elements[e];
    bool               nodes_ok = true;
    for (int a = 0; a <= nodes_of.order; ++a) nodes_ok = nodes_ok && node_finite[map.node_to_local[nodes_of.nodes[a]]];
    if (!nodes_ok) continue;
    EvaluateElement(k, false, &element);
    if (!element.evaluable) continue; // cannot be evaluated: DescribeUnevaluable's business
    const int   nd = 6 * element.num_nodes;
    std::string what;
    bool        trouble = !AllFinite(element.residual, nd) || !AllFinite(element.correction, nd);
    if (!trouble && !state.equations.InitialAcceleration()) {
      double r[kBeamMaxDofs], K[kBeamMaxDofs * kBeamMaxDofs];
      if (beams_->EndPointTangent(state, k, r, K) && !AllFinite(K, nd * nd)) trouble = true, what = ", in its tangent";
    }
    if (trouble) finding.Offer(TroubleSource::Element, map.global_elements[e], ElementLabel(model, map, e) + what);
  }
  NodeContribution node;
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    if (!node_finite[l]) continue;
    EvaluateNode((int)l, true, &node);
    if (AllFinite(node.residual, 6) && node.tangent.allFinite()) continue;
    const int global_node = map.local_nodes[l];
    finding.Offer(TroubleSource::NodeForces, map.global_nodes[global_node], NodeLabel(model, global_node) + ", in its nodal forces");
  }
  for (const ForceContributor *c : contributors_) c->FindNonFiniteBlocks(state, node_finite, &finding);
  PetscCall(LowestFinding(comm_, finding, where));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DescribeUnevaluable(std::string *where)
{
  const Model        &model = *model_;
  const DofMap       &map   = *map_;
  TroubleFindings     finding;
  ElementContribution element;
  PetscFunctionBeginUser;
  for (size_t k = 0; k < map.local_elements.size(); ++k) {
    const int          e        = map.local_elements[k];
    const BeamElement &nodes_of = model.elements[e];
    bool               nodes_ok = true;
    for (int a = 0; a <= nodes_of.order; ++a) nodes_ok = nodes_ok && NodeStateFinite(state_->nodes[map.node_to_local[nodes_of.nodes[a]]]);
    if (!nodes_ok) continue; // a NaN configuration is DescribeNonFinite's business
    EvaluateElement(k, false, &element);
    if (!element.evaluable) finding.Offer(TroubleSource::Element, map.global_elements[e], ElementLabel(model, map, e));
  }
  PetscCall(LowestFinding(comm_, finding, where));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Assembler::DescribeUnknown(PetscInt row, std::string *what)
{
  const Model    &model = *model_;
  const DofMap   &map   = *map_;
  PetscMPIInt     rank;
  TroubleFindings finding;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  // Only the owner of the row holds the node or joint it belongs to.
  if (row >= map.first_owned && row < map.first_owned + map.num_owned) {
    for (PetscInt l = 0; l < map.num_owned_nodes && finding.text.empty(); ++l) {
      const int   node  = map.local_nodes[l];
      const char *relay = map.IsRelay((int)l) ? " (relay node)" : "";
      for (int d = 0; d < 6; ++d) {
        if (map.node_dofs[node][d] == row) finding.Offer(TroubleSource::NodeIncrement, row, NodeLabel(model, node) + " " + kDofNames[d] + relay);
        if (*relay && map.relay_forces[node][d] == row)
          finding.Offer(TroubleSource::NodeIncrement, row, NodeLabel(model, node) + " relay force " + kDofNames[d]);
      }
    }
    for (size_t i = 0; i < map.local_joints.size() && finding.text.empty(); ++i) {
      const int j = map.local_joints[i];
      if (map.joint_rank[j] != rank) continue;
      for (int c = 0; c < kJointMaxReleased; ++c)
        if (map.joint_dofs[j][c] == row)
          finding.Offer(TroubleSource::NodeIncrement, row, Format("joint '%s' %s", model.joints[j].name.c_str(), JointCoordinateName(model.joints[j], c)));
    }
  }
  PetscCall(LowestFinding(comm_, finding, what));
  if (what->empty()) *what = Format("unknown %" PetscInt_FMT, row);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
