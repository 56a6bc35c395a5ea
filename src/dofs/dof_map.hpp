// The map from nodes and joints to global unknowns (docs/theory.md): 6 per independent node
// (displacement increment, incremental rotation vector) minus the DOFs that supports fix or
// prescribe, plus the released coordinates of every joint that are not driven. A slave node has
// no unknowns of its own: its configuration follows from its master and its joint (chains
// compose). Owned unknowns of a rank are contiguous in the global numbering (PETSc's layout); a
// joint belongs to the rank of its slave node. Ghost nodes are the non-owned nodes of the rank's
// elements, the second nodes of the force elements whose first node the rank owns and,
// recursively, the masters of local slave nodes.
//
// Set-up sees the whole model; DofMapRestrictToLocal then makes the distributed model: a new model
// and map of what the rank holds (its local nodes, elements and joints, renumbered), so that no
// array of the size of the whole model remains during the time loop. Code indexing through the map works
// unchanged in both states: a model index goes through node_to_local / element_to_local /
// joint_to_local, a local index through local_nodes / local_elements / local_joints, and
// global_nodes / global_elements give the rows of the output file.
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
  int           function = -1;    // -1: ramp f(t) = t
  int           support  = -1;    // the support entry that set it (for messages)
  bool          by_rate  = false; // the DOF's rate is value * f(t) (prescribe_rate)
};

struct DofMap {
  PetscInt num_global  = 0; // unknowns in the whole model
  PetscInt num_owned   = 0; // unknowns owned by this rank
  PetscInt first_owned = 0; // global index of the first owned unknown

  std::vector<int>                          node_rank;   // every node's owner
  std::vector<std::array<PetscInt, 6>>      node_dofs;   // every node: global unknown index, -1 when constrained
  std::vector<std::array<DofConstraint, 6>> constraints; // every node

  std::vector<int> local_nodes; // owned nodes first (in global numbering order), then ghosts
  PetscInt         num_owned_nodes = 0;
  std::vector<int> node_to_local;    // every node: index into local_nodes, or -1
  std::vector<int> local_elements;   // elements assembled here: those whose first node is owned
  std::vector<int> element_to_local; // every element: index into local_elements, or -1

  std::vector<int>                     node_joint; // every node: the joint whose slave it is, or -1
  std::vector<int>                     joint_rank; // every joint: owning rank (that of its slave node)
  std::vector<std::array<PetscInt, 6>> joint_dofs; // every joint: global index of each released coordinate, -1 when driven
  // Every node: the global unknowns its configuration depends on — its own free DOFs, or for a
  // slave those of its master followed by its joint's free coordinates.
  std::vector<std::vector<PetscInt>> node_unknowns;
  // Relay nodes (AnalysisSettings::condensation_depth): a slave every `depth` joints down a chain
  // that is itself a master keeps its own 6 DOFs (spin increments, in node_dofs) and 6 more
  // unknowns for the force it passes to its master (relay_forces, -1 elsewhere); its node_unknowns
  // are its own DOFs, so the slaves below it expand onto them, and relay_unknowns (empty elsewhere)
  // are what its joint maps it from: its master's node_unknowns followed by its joint's free
  // coordinates. The linear solve carries the joint as  du_s = C du_anchor  and  R^T lambda_s, whose
  // elimination is the condensation, so a chain costs O(depth^2) per joint instead of O(N^2).
  std::vector<std::array<PetscInt, 6>> relay_forces;
  std::vector<std::vector<PetscInt>>   relay_unknowns;
  PetscInt                             num_relays = 0; // in the whole model
  std::vector<int>                     local_joints;   // joints whose slave node is local, each after the joint of its master
  std::vector<int>                     joint_to_local; // every joint: index into local_joints, or -1

  // Output numbering. Per model node / element: its number in the whole model (the identity
  // before restriction). Per model joint: its slot in joint data distributed by owner (joints
  // numbered rank by rank, owned joints contiguous from first_owned_joint_slot).
  std::vector<int> global_nodes, global_elements, joint_slot;
  // Per model joint / rigid body: its number in the whole model (checkpoints).
  std::vector<int> global_joints, global_rigid_bodies;
  // Per model element: the first of its `order` visualisation segments in the output (the
  // segments are numbered element after element).
  std::vector<int> element_first_segment;
  int              first_owned_joint_slot = 0, num_owned_joints = 0;

  // Sizes of the whole model, kept after restriction.
  struct GlobalCount {
    PetscInt nodes = 0, elements = 0, joints = 0, rigid_bodies = 0;
  } global_count;
  bool restricted = false; // DofMapRestrictToLocal has run

  bool IsRelay(int node) const { return !relay_forces.empty() && relay_forces[node][0] >= 0; }
  // Unknowns of the state in the whole model: a relay's 12 rows (its own DOFs and its force) are none.
  PetscInt NumStateUnknowns() const { return num_global - 12 * num_relays; }
  // The unknowns a joint maps its slave from: a relay's relay_unknowns, else its node_unknowns.
  const std::vector<PetscInt> &JointMapUnknowns(int slave) const { return IsRelay(slave) ? relay_unknowns[slave] : node_unknowns[slave]; }
  // The global rows of the owned relays' own DOFs and forces (restricted map): no unknowns of the
  // state, held apart from every norm, weight and update.
  std::vector<PetscInt> OwnedRelayRows() const
  {
    std::vector<PetscInt> rows;
    for (PetscInt l = 0; l < num_owned_nodes && num_relays > 0; ++l)
      if (IsRelay((int)l))
        rows.insert(rows.end(), node_dofs[l].begin(), node_dofs[l].end()), rows.insert(rows.end(), relay_forces[l].begin(), relay_forces[l].end());
    return rows;
  }
};

// Builds the map; a DOF constrained twice by different supports is an input error naming both.
// Relay nodes in dynamic analyses and in statics without the stability account (its negative
// pivots need the condensed symmetric tangent, as eigenanalyses need the condensed pencil).
PetscErrorCode DofMapCreate(MPI_Comm comm, const Model &model, const std::vector<int> &node_rank, DofMap *map);

// Exact nonzeros per owned row of the assembled matrix, split into the diagonal (owned columns)
// and off-diagonal blocks: every element and every force element between two nodes couples the
// unknowns of all its nodes, every node those it depends on (nodal inertia, loads and the joints' geometric stiffness).
// With row_start and columns (may be null): the pattern itself, in CSR form for the owned rows
// (global column indices, ascending per row), as MatMPIAIJSetPreallocationCSR takes it.
PetscErrorCode DofMapPreallocation(const DofMap &map, const Model &model, std::vector<PetscInt> *diagonal_nonzeros,
                                   std::vector<PetscInt> *off_diagonal_nonzeros, std::vector<PetscInt> *row_start = nullptr,
                                   std::vector<PetscInt> *columns = nullptr);

// The distributed model: a new model and map of the part this rank holds, the local nodes (owned
// first, then ghosts), the local elements and joints (masters' joints first), each in the map's
// local order, so that every local_* list of the new map is the identity; node lists of supports,
// loads, initial conditions and rigid bodies keep their local nodes, distributed loads their local
// elements, probes point at their local node or -1; beams keep only their names and places (for
// messages), node sets and the copy of the input text are dropped (the output file already has
// them). Assembly over the distributed model is identical. Not collective.
PetscErrorCode DofMapRestrictToLocal(const Model &model, const DofMap &map, Model *local_model, DofMap *local_map);

} // namespace msflex
