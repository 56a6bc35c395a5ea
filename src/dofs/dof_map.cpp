#include "dofs/dof_map.hpp"

#include "core/errors.hpp"
#include "joints/joint_model.hpp"

#include <functional>

#include <algorithm>

namespace msflex {

static const char *const kDofNames[6] = {"ux", "uy", "uz", "rx", "ry", "rz"};

static PetscErrorCode CollectConstraints(const Model &model, DofMap *map)
{
  PetscFunctionBeginUser;
  map->constraints.assign(model.nodes.size(), {});
  for (size_t s = 0; s < model.supports.size(); ++s) {
    const Support &support = model.supports[s];
    for (int node : support.nodes) {
      for (int d = 0; d < 6; ++d) {
        if (support.kind[d] == Support::Kind::Free) continue;
        DofConstraint &slot = map->constraints[node][d];
        if (slot.kind != Support::Kind::Free) {
          const Support &first = model.supports[slot.support];
          MSFLEX_INPUT_CHECK(false, support.mark, "DOF '%s' of node '%s' is already constrained by the support at line %d", kDofNames[d],
                             model.nodes[node].name.c_str(), first.mark.line);
        }
        slot = {support.kind[d], support.values[d], support.function, (int)s};
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Joints in an order where the joint of a master comes before the joints of its slaves.
static std::vector<int> JointChainOrder(const Model &model, const std::vector<int> &node_joint)
{
  std::vector<int> depth(model.joints.size(), -1), order(model.joints.size());
  std::function<int(int)> depth_of = [&](int j) {
    if (depth[j] >= 0) return depth[j];
    const int master = model.joints[j].master;
    depth[j]         = (master >= 0 && node_joint[master] >= 0) ? 1 + depth_of(node_joint[master]) : 0;
    return depth[j];
  };
  for (size_t j = 0; j < order.size(); ++j) {
    order[j] = (int)j;
    depth_of((int)j);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return depth[a] < depth[b]; });
  return order;
}

PetscErrorCode DofMapCreate(MPI_Comm comm, const Model &model, const std::vector<int> &node_rank, DofMap *map)
{
  PetscMPIInt rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(CollectConstraints(model, map));
  const size_t num_nodes  = model.nodes.size();
  const size_t num_joints = model.joints.size();
  map->node_rank          = node_rank;
  map->node_joint.assign(num_nodes, -1);
  for (size_t j = 0; j < num_joints; ++j) map->node_joint[model.joints[j].slave] = (int)j;
  map->joint_rank.assign(num_joints, 0);
  for (size_t j = 0; j < num_joints; ++j) map->joint_rank[j] = node_rank[model.joints[j].slave];

  // Number rank by rank: the free DOFs of its independent nodes, then its joints' free coordinates.
  map->node_dofs.assign(num_nodes, {{-1, -1, -1, -1, -1, -1}});
  map->joint_dofs.assign(num_joints, {{-1, -1, -1, -1, -1, -1}});
  PetscInt next = 0;
  for (int r = 0; r < size; ++r) {
    if (r == rank) map->first_owned = next;
    for (size_t i = 0; i < num_nodes; ++i) {
      if (node_rank[i] != r || map->node_joint[i] >= 0) continue;
      for (int d = 0; d < 6; ++d)
        if (map->constraints[i][d].kind == Support::Kind::Free) map->node_dofs[i][d] = next++;
    }
    for (size_t j = 0; j < num_joints; ++j) {
      if (map->joint_rank[j] != r) continue;
      const Joint &joint = model.joints[j];
      const int    k     = JointNumCoordinates(JointGeometryOf(joint));
      for (int c = 0; c < k; ++c)
        if (c != joint.driven_coordinate) map->joint_dofs[j][c] = next++;
    }
    if (r == rank) map->num_owned = next - map->first_owned;
  }
  map->num_global = next;

  // The unknowns each node depends on, masters first along every chain.
  const std::vector<int> chain_order = JointChainOrder(model, map->node_joint);
  map->node_unknowns.assign(num_nodes, {});
  for (size_t i = 0; i < num_nodes; ++i)
    for (PetscInt dof : map->node_dofs[i])
      if (dof >= 0) map->node_unknowns[i].push_back(dof);
  for (int j : chain_order) {
    const Joint           &joint    = model.joints[j];
    std::vector<PetscInt> &unknowns = map->node_unknowns[joint.slave];
    if (joint.master >= 0) unknowns = map->node_unknowns[joint.master];
    for (PetscInt dof : map->joint_dofs[j])
      if (dof >= 0) unknowns.push_back(dof);
  }

  // Local nodes: owned ones, then the ghosts reached by the elements this rank assembles, then
  // the masters of local slaves (recursively).
  map->node_to_local.assign(num_nodes, -1);
  map->local_nodes.clear();
  auto add_local = [map](int node) {
    if (map->node_to_local[node] >= 0) return;
    map->node_to_local[node] = (int)map->local_nodes.size();
    map->local_nodes.push_back(node);
  };
  for (size_t i = 0; i < num_nodes; ++i)
    if (node_rank[i] == rank) add_local((int)i);
  map->num_owned_nodes = (PetscInt)map->local_nodes.size();
  map->local_elements.clear();
  map->element_to_local.assign(model.elements.size(), -1);
  for (size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement &element = model.elements[e];
    if (node_rank[element.nodes[0]] != rank) continue;
    map->element_to_local[e] = (int)map->local_elements.size();
    map->local_elements.push_back((int)e);
    for (int a = 0; a < element.order + 1; ++a) add_local(element.nodes[a]);
  }
  for (size_t scanned = 0; scanned < map->local_nodes.size(); ++scanned) {
    const int j = map->node_joint[map->local_nodes[scanned]];
    if (j >= 0 && model.joints[j].master >= 0) add_local(model.joints[j].master);
  }
  map->local_joints.clear();
  map->joint_to_local.assign(num_joints, -1);
  for (int j : chain_order)
    if (map->node_to_local[model.joints[j].slave] >= 0) {
      map->joint_to_local[j] = (int)map->local_joints.size();
      map->local_joints.push_back(j);
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DofMapPreallocation(const DofMap &map, const Model &model, std::vector<PetscInt> *diagonal_nonzeros, std::vector<PetscInt> *off_diagonal_nonzeros)
{
  PetscFunctionBeginUser;
  const PetscInt                     first = map.first_owned, last = map.first_owned + map.num_owned;
  std::vector<std::vector<PetscInt>> columns(map.num_owned);
  // Every owned row among `coupled` couples with all of `coupled`.
  auto couple = [&](const std::vector<PetscInt> &coupled) {
    for (PetscInt row : coupled)
      if (row >= first && row < last) columns[row - first].insert(columns[row - first].end(), coupled.begin(), coupled.end());
  };
  std::vector<PetscInt> coupled;
  for (const BeamElement &element : model.elements) {
    coupled.clear();
    for (int a = 0; a <= element.order; ++a) coupled.insert(coupled.end(), map.node_unknowns[element.nodes[a]].begin(), map.node_unknowns[element.nodes[a]].end());
    couple(coupled);
  }
  for (const std::vector<PetscInt> &unknowns : map.node_unknowns) couple(unknowns);
  diagonal_nonzeros->assign(map.num_owned, 0);
  off_diagonal_nonzeros->assign(map.num_owned, 0);
  for (PetscInt r = 0; r < map.num_owned; ++r) {
    std::vector<PetscInt> &c = columns[r];
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
    for (PetscInt column : c) ++(column >= first && column < last ? (*diagonal_nonzeros)[r] : (*off_diagonal_nonzeros)[r]);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
