// Node partitioning: which rank owns each node (and so its unknowns and the elements whose first
// node it is). Every partitioner sits behind PartitionNodes; `-partitioner` selects one.
#pragma once

#include "model/model.hpp"

#include <petscsys.h>

#include <vector>

namespace msflex {

enum class PartitionerType { Simple };

// Reads -partitioner (default: simple). Collective.
PetscErrorCode PartitionerTypeFromOptions(MPI_Comm comm, PartitionerType *type);

// node_rank[i] = owning rank of node i. Collective; every rank gets the same answer.
// Simple: nodes in the order they first appear in the element connectivity, cut into
// contiguous blocks of nearly equal size.
PetscErrorCode PartitionNodes(MPI_Comm comm, const Model &model, PartitionerType type, std::vector<int> *node_rank);

} // namespace msflex
