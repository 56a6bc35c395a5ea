// Node partitioning: which rank owns each node (and so its unknowns and the elements whose first
// node it is). Every partitioner sits behind PartitionNodes; `-partitioner` selects one.
#pragma once

#include "model/model.hpp"

#include <petscsys.h>

#include <vector>

namespace msflex {

enum class PartitionerType { Simple, Metis };

// Reads -partitioner simple|metis (default: metis on more than one rank). Collective.
PetscErrorCode PartitionerTypeFromOptions(MPI_Comm comm, PartitionerType *type);

// node_rank[i] = owning rank of node i. Collective; every rank gets the same answer.
// Simple: nodes in the order they first appear in the element connectivity, cut into
// contiguous blocks of nearly equal size.
// Metis: k-way partition (METIS_PartGraphKway, computed on rank 0 and broadcast) of the graph
// whose vertices are the nodes, with every joint chain contracted to one vertex so that no joint
// straddles ranks, and whose edges join the nodes of each element and of each force element between two nodes; vertex weights are the
// vertices' node counts. Joint chains stay whole with either partitioner.
PetscErrorCode PartitionNodes(MPI_Comm comm, const Model &model, PartitionerType type, std::vector<int> *node_rank);

} // namespace msflex
