#include "parallel/partition.hpp"

namespace msflex {

PetscErrorCode PartitionerTypeFromOptions(MPI_Comm comm, PartitionerType *type)
{
  const char *const names[] = {"simple", "PartitionerType", "PARTITIONER_", nullptr};
  PetscEnum         choice  = (PetscEnum)PartitionerType::Simple; // default
  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, nullptr, "Partitioning", "msflex");
  PetscCall(PetscOptionsEnum("-partitioner", "How nodes are distributed over ranks", "PartitionNodes", names, choice, &choice, nullptr));
  PetscOptionsEnd();
  *type = (PartitionerType)choice;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Nodes in order of first appearance along the element list, so that each block is a run of
// consecutive elements and few elements straddle ranks.
static std::vector<int> ConnectivityOrder(const Model &model)
{
  std::vector<int>  order;
  std::vector<char> seen(model.nodes.size(), 0);
  order.reserve(model.nodes.size());
  for (const BeamElement &e : model.elements)
    for (int a = 0; a < e.order + 1; ++a)
      if (!seen[e.nodes[a]]) {
        seen[e.nodes[a]] = 1;
        order.push_back(e.nodes[a]);
      }
  for (size_t i = 0; i < model.nodes.size(); ++i)
    if (!seen[i]) order.push_back((int)i);
  return order;
}

PetscErrorCode PartitionNodes(MPI_Comm comm, const Model &model, PartitionerType type, std::vector<int> *node_rank)
{
  PetscMPIInt size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const std::vector<int> order = ConnectivityOrder(model);
  const size_t           n     = order.size();
  node_rank->assign(n, 0);
  switch (type) {
  case PartitionerType::Simple:
    for (size_t k = 0; k < n; ++k) (*node_rank)[order[k]] = (int)((k * (size_t)size) / n);
    break;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
