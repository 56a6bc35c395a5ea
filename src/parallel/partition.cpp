#include "parallel/partition.hpp"

#include <metis.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

namespace msflex {

PetscErrorCode PartitionerTypeFromOptions(MPI_Comm comm, PartitionerType *type)
{
  const char *const names[] = {"simple", "metis", "PartitionerType", "PARTITIONER_", nullptr};
  PetscMPIInt       size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscEnum choice = (PetscEnum)(size > 1 ? PartitionerType::Metis : PartitionerType::Simple); // default
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

// Union-find root of a node in the joint-chain contraction.
static int Root(std::vector<int> &parent, int i)
{
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

// Vertex of every node: nodes joined by joints (master-slave, not the ground) share one.
static std::vector<int> ContractJointChains(const Model &model, int *num_vertices)
{
  const int        n = (int)model.nodes.size();
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (const Joint &joint : model.joints)
    if (joint.master >= 0) parent[Root(parent, joint.slave)] = Root(parent, joint.master);
  std::vector<int> vertex(n, -1), root_vertex(n, -1);
  *num_vertices = 0;
  for (int i = 0; i < n; ++i) {
    const int r = Root(parent, i);
    if (root_vertex[r] < 0) root_vertex[r] = (*num_vertices)++;
    vertex[i] = root_vertex[r];
  }
  return vertex;
}

// METIS k-way partition of the contracted node graph, on the calling rank.
static PetscErrorCode MetisPartition(const Model &model, int parts, std::vector<int> *node_rank)
{
  PetscFunctionBeginUser;
  int                             num_vertices;
  const std::vector<int>          vertex = ContractJointChains(model, &num_vertices);
  std::vector<std::vector<idx_t>> neighbours(num_vertices);
  for (const BeamElement &element : model.elements)
    for (int a = 0; a <= element.order; ++a)
      for (int b = 0; b <= element.order; ++b) {
        const int va = vertex[element.nodes[a]], vb = vertex[element.nodes[b]];
        if (va != vb) neighbours[va].push_back(vb);
      }
  for (const ForceElement &element : model.force_elements) // between two nodes, like a 2-node element
    if (element.kind != ForceElement::Kind::Coordinate) {
      const int va = vertex[element.nodes[0]], vb = vertex[element.nodes[1]];
      if (va != vb) neighbours[va].push_back(vb), neighbours[vb].push_back(va);
    }
  std::vector<idx_t> xadj(1, 0), adjncy, weight(num_vertices, 0), part(num_vertices, 0);
  for (int v = 0; v < num_vertices; ++v) {
    std::vector<idx_t> &list = neighbours[v];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    adjncy.insert(adjncy.end(), list.begin(), list.end());
    xadj.push_back((idx_t)adjncy.size());
  }
  for (size_t i = 0; i < model.nodes.size(); ++i) ++weight[vertex[i]];
  if (parts > 1 && num_vertices > parts) {
    idx_t nvtxs = num_vertices, ncon = 1, nparts = parts, edgecut = 0;
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 1; // reproducible partitions
    const int status = METIS_PartGraphKway(&nvtxs, &ncon, xadj.data(), adjncy.data(), weight.data(), nullptr, nullptr, &nparts, nullptr, nullptr, options,
                                           &edgecut, part.data());
    PetscCheck(status == METIS_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "METIS_PartGraphKway failed with status %d", status);
  } else {
    for (int v = 0; v < num_vertices; ++v) part[v] = (idx_t)(((size_t)v * (size_t)parts) / (size_t)std::max(1, num_vertices));
  }
  node_rank->assign(model.nodes.size(), 0);
  for (size_t i = 0; i < model.nodes.size(); ++i) (*node_rank)[i] = (int)part[vertex[i]];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PartitionNodes(MPI_Comm comm, const Model &model, PartitionerType type, std::vector<int> *node_rank)
{
  PetscMPIInt size, rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  const size_t n = model.nodes.size();
  node_rank->assign(n, 0);
  switch (type) {
  case PartitionerType::Simple: {
    // Contiguous blocks in connectivity order, then every joint chain moved to the rank of its root.
    const std::vector<int> order = ConnectivityOrder(model);
    for (size_t k = 0; k < n; ++k) (*node_rank)[order[k]] = (int)((k * (size_t)size) / n);
    int                    num_vertices;
    const std::vector<int> vertex = ContractJointChains(model, &num_vertices);
    std::vector<int>       vertex_rank(num_vertices, -1);
    for (size_t k = 0; k < n; ++k) {
      int &r = vertex_rank[vertex[order[k]]];
      if (r < 0) r = (*node_rank)[order[k]];
      (*node_rank)[order[k]] = r;
    }
    break;
  }
  case PartitionerType::Metis:
    // METIS runs on rank 0 only (the whole graph is needed there once); the answer is broadcast.
    if (rank == 0) PetscCall(MetisPartition(model, size, node_rank));
    PetscCallMPI(MPI_Bcast(node_rank->data(), (int)n, MPI_INT, 0, comm));
    break;
  }
  // A rank without nodes holds no part of the model (only a share of MUMPS' factorisation): said,
  // since the run then goes little faster than on fewer ranks (a hub joined to 18 arms by joints is
  // one group of 19 nodes that no partition splits: 55 nodes on 4 ranks were 18, 19, 18 and 0).
  std::vector<size_t> nodes_of(size, 0);
  for (int r : *node_rank) ++nodes_of[r];
  std::string idle;
  for (int r = 0; r < size; ++r)
    if (nodes_of[r] == 0) idle += (idle.empty() ? "" : ", ") + std::to_string(r);
  if (!idle.empty())
    PetscCall(PetscFPrintf(comm, PETSC_STDERR,
                           "msflex: warning: the partition leaves rank(s) %s without a node (%zu nodes on %d ranks; the nodes a chain of joints joins "
                           "stay on one rank): those ranks hold no part of the model\n",
                           idle.c_str(), n, (int)size));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
