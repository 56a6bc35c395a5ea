// The map from nodes and joints to global unknowns (DESIGN.md §3–4): 6 per independent node
// (displacement increment, incremental rotation vector) minus the DOFs that supports fix or
// prescribe, plus the released coordinates of every joint that are not driven. A slave node has
// no unknowns of its own: its configuration follows from its master and its joint (chains
// compose). Owned unknowns of a rank are contiguous in the global numbering (PETSc's layout); a
// joint belongs to the rank of its slave node. Ghost nodes are the non-owned nodes of the rank's
// elements and, recursively, the masters of local slave nodes.
#pragma once

#include "model/model.hpp"

#include <petscsys.h>

#include <array>
#include <vector>

namespace msflex {

// How one DOF of one node is held: free (an unknown), fixed, or prescribed value(t) = value * f(t).
struct DofConstraint {
  Support::Kind kind     = Support::Kind::Free;
  double        value    = 0.0;
  int           function = -1; // -1: ramp f(t) = t
  int           support  = -1; // the support entry that set it (for messages)
};

struct DofMap {
  PetscInt num_global  = 0; // unknowns in the whole model
  PetscInt num_owned   = 0; // unknowns owned by this rank
  PetscInt first_owned = 0; // global index of the first owned unknown

  std::vector<int>                          node_rank;   // every node's owner
  std::vector<std::array<PetscInt, 6>>      node_dofs;   // every node: global unknown index, -1 when constrained
  std::vector<std::array<DofConstraint, 6>> constraints; // every node

  std::vector<int> local_nodes;     // owned nodes first (in global numbering order), then ghosts
  PetscInt         num_owned_nodes = 0;
  std::vector<int> node_to_local;   // every node: index into local_nodes, or -1
  std::vector<int> local_elements;  // elements assembled here: those whose first node is owned
  std::vector<int> element_to_local; // every element: index into local_elements, or -1

  std::vector<int> node_joint;  // every node: the joint whose slave it is, or -1
  std::vector<int> joint_rank;  // every joint: owning rank (that of its slave node)
  std::vector<std::array<PetscInt, 6>> joint_dofs; // every joint: global index of each released coordinate, -1 when driven
  // Every node: the global unknowns its configuration depends on — its own free DOFs, or for a
  // slave those of its master followed by its joint's free coordinates.
  std::vector<std::vector<PetscInt>> node_unknowns;
  std::vector<int> local_joints;    // joints whose slave node is local, each after the joint of its master
  std::vector<int> joint_to_local;  // every joint: index into local_joints, or -1
};

// Builds the map; a DOF constrained twice by different supports is an input error naming both.
PetscErrorCode DofMapCreate(MPI_Comm comm, const Model &model, const std::vector<int> &node_rank, DofMap *map);

// Exact nonzeros per owned row of the assembled matrix, split into the diagonal (owned columns)
// and off-diagonal blocks: every element couples the unknowns of all its nodes, every node those
// it depends on (nodal inertia, loads and the joints' geometric stiffness).
PetscErrorCode DofMapPreallocation(const DofMap &map, const Model &model, std::vector<PetscInt> *diagonal_nonzeros, std::vector<PetscInt> *off_diagonal_nonzeros);

} // namespace msflex
