#include "dofs/dof_map.hpp"

#include "core/errors.hpp"

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

PetscErrorCode DofMapCreate(MPI_Comm comm, const Model &model, const std::vector<int> &node_rank, DofMap *map)
{
  PetscMPIInt rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(CollectConstraints(model, map));
  const size_t num_nodes = model.nodes.size();
  map->node_rank         = node_rank;

  // Number the free DOFs rank by rank, nodes in index order within a rank: contiguous ownership.
  map->node_dofs.assign(num_nodes, {{-1, -1, -1, -1, -1, -1}});
  PetscInt next = 0;
  for (int r = 0; r < size; ++r) {
    if (r == rank) map->first_owned = next;
    for (size_t i = 0; i < num_nodes; ++i) {
      if (node_rank[i] != r) continue;
      for (int d = 0; d < 6; ++d)
        if (map->constraints[i][d].kind == Support::Kind::Free) map->node_dofs[i][d] = next++;
    }
    if (r == rank) map->num_owned = next - map->first_owned;
  }
  map->num_global = next;

  // Local nodes: owned ones, then the ghosts reached by the elements this rank assembles.
  map->node_to_local.assign(num_nodes, -1);
  map->local_nodes.clear();
  for (size_t i = 0; i < num_nodes; ++i)
    if (node_rank[i] == rank) {
      map->node_to_local[i] = (int)map->local_nodes.size();
      map->local_nodes.push_back((int)i);
    }
  map->num_owned_nodes = (PetscInt)map->local_nodes.size();
  map->local_elements.clear();
  for (size_t e = 0; e < model.elements.size(); ++e) {
    const BeamElement &element = model.elements[e];
    if (node_rank[element.nodes[0]] != rank) continue;
    map->local_elements.push_back((int)e);
    for (int a = 0; a < element.order + 1; ++a) {
      const int node = element.nodes[a];
      if (map->node_to_local[node] < 0) {
        map->node_to_local[node] = (int)map->local_nodes.size();
        map->local_nodes.push_back(node);
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DofMapPreallocation(const DofMap &map, const Model &model, std::vector<PetscInt> *diagonal_nonzeros, std::vector<PetscInt> *off_diagonal_nonzeros)
{
  PetscFunctionBeginUser;
  // Node adjacency (a node is adjacent to itself and to every node it shares an element with).
  const size_t                  num_nodes = model.nodes.size();
  std::vector<std::vector<int>> adjacent(num_nodes);
  for (size_t i = 0; i < num_nodes; ++i) adjacent[i].push_back((int)i);
  for (const BeamElement &e : model.elements)
    for (int a = 0; a < e.order + 1; ++a)
      for (int b = 0; b < e.order + 1; ++b)
        if (a != b) adjacent[e.nodes[a]].push_back(e.nodes[b]);
  diagonal_nonzeros->assign(map.num_owned, 0);
  off_diagonal_nonzeros->assign(map.num_owned, 0);
  const PetscInt last_owned = map.first_owned + map.num_owned;
  for (size_t i = 0; i < num_nodes; ++i) {
    const bool owned = map.node_to_local[i] >= 0 && map.node_to_local[i] < map.num_owned_nodes;
    if (!owned) continue;
    std::vector<int> &neighbours = adjacent[i];
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    PetscInt diagonal = 0, off_diagonal = 0;
    for (int j : neighbours)
      for (PetscInt column : map.node_dofs[j]) {
        if (column < 0) continue;
        if (column >= map.first_owned && column < last_owned) ++diagonal;
        else ++off_diagonal;
      }
    for (PetscInt row : map.node_dofs[i]) {
      if (row < map.first_owned || row >= last_owned) continue;
      (*diagonal_nonzeros)[row - map.first_owned]     = diagonal;
      (*off_diagonal_nonzeros)[row - map.first_owned] = off_diagonal;
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
