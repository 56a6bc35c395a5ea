// Assembly of the global residual and tangent from the element and load kernels into PETSc
// objects (MPIAIJ with exact preallocation). The residual is in spin form (rows: virtual
// displacements and spins); the tangent is with respect to the Newton unknowns
// (u, omega): K_spin * blockdiag(I, H(omega)) per node (DESIGN.md §3).
#pragma once

#include "dofs/dof_map.hpp"
#include "elements/beam.hpp"
#include "model/model.hpp"
#include "state/state.hpp"

#include <petscmat.h>
#include <petscvec.h>

#include <vector>

namespace msflex {

// Per-element mean (over the Gauss points) of strains and stress resultants, section frame.
struct ElementResults {
  Vec3 strain, curvature, force, moment;
};

class Assembler {
public:
  Assembler() = default;
  Assembler(const Assembler &)            = delete;
  Assembler &operator=(const Assembler &) = delete;
  ~Assembler();

  // Element reference data, preallocated matrix, vectors and the ghost scatter. Collective.
  PetscErrorCode Setup(MPI_Comm comm, const Model &model, const DofMap &map);

  // Prepares the step t_start -> t_end: load factors at t_end and prescribed increments.
  PetscErrorCode BeginStep(double t_start, double t_end);
  // Sets the increments of every local node from the global unknown vector (scatter to ghosts).
  PetscErrorCode SetIncrements(Vec increments);
  // Residual = internal forces - external loads at the current increments. Returns
  // *geometry_ok = false when an element cannot be evaluated (relative rotation too large).
  PetscErrorCode AssembleResidual(Vec residual, PetscBool *geometry_ok);
  PetscErrorCode AssembleJacobian(Mat jacobian, PetscBool *geometry_ok);
  // Accepts the current increments as the new start of step.
  PetscErrorCode CommitStep();
  // Forgets the increments (a rejected step).
  PetscErrorCode DiscardStep();

  // Magnitude of the forces in the last residual: the norm of all element and load contributions
  // before assembly (the level against which round-off in the residual is measured). Collective.
  PetscErrorCode ForceScale(double *scale);
  // Largest |omega| over the nodes of the whole model (collective).
  PetscErrorCode MaxRotationIncrement(double *max_rotation);
  // Element results for the local elements (indexed like DofMap::local_elements) and the total
  // strain energy (collective).
  PetscErrorCode EvaluateResults(std::vector<ElementResults> *results, double *strain_energy);

  Mat                           Jacobian() const { return jacobian_; }
  Vec                           SolutionTemplate() const { return solution_template_; }
  const std::vector<NodeState> &LocalNodes() const { return nodes_; }
  const DofMap                 &Map() const { return *map_; }

private:
  PetscErrorCode ApplyPrescribedIncrements(double t_start, double t_end);
  PetscErrorCode CreateCsrDestinations();
  PetscErrorCode AddElementMatrix(size_t local_element, const PetscInt *indices, int num_dofs, const double *values, PetscScalar *diagonal_values,
                                  PetscScalar *off_diagonal_values);
  double         FunctionValue(int function, double t) const;
  // Current nodal positions and section triads of an element (and the nodes' H(omega) if asked).
  void ElementConfiguration(const BeamElement &element, Vec3 *positions, Mat3 *triads, const Mat3 **rotation_tangents) const;

  MPI_Comm                          comm_  = MPI_COMM_NULL;
  const Model                      *model_ = nullptr;
  const DofMap                     *map_   = nullptr;
  std::vector<BeamElementReference> element_references_; // per local element
  std::vector<BeamSectionStiffness> section_stiffness_;  // per section
  std::vector<NodeState>            nodes_;              // per local node
  // External loads at the end of the step: per local element the distributed load per length,
  // per owned node the dead and follower (body-frame) force and moment.
  std::vector<Vec3> element_line_load_;
  std::vector<Vec3> dead_force_, dead_moment_, follower_force_, follower_moment_;
  double            local_force_squares_ = 0.0; // sum of squared contributions in the last residual

  Mat        jacobian_          = nullptr;
  Vec        solution_template_ = nullptr;
  Vec        ghosted_increments_ = nullptr; // sequential: the free DOFs of the local nodes
  VecScatter to_ghosted_        = nullptr;
  std::vector<PetscInt> ghosted_slot_;      // per local node and DOF: index in ghosted_increments_, -1 if constrained

  // Direct assembly into the CSR value arrays of the owned rows (the pattern is fixed by exact
  // preallocation, so the position of every element-matrix entry is computed once). Per local
  // element, per entry (row-major): kCsrSkip (constrained row or column), kCsrOtherRank (row
  // owned by another rank: goes through MatSetValues), an index >= 0 into the diagonal block's
  // values, or kCsrOffDiagonal - index for the off-diagonal block. Empty when the matrix type
  // is not AIJ: then everything goes through MatSetValues.
  static constexpr PetscInt kCsrSkip = -1, kCsrOtherRank = -2, kCsrOffDiagonal = -3;
  std::vector<std::vector<PetscInt>> csr_destinations_;
  Mat                                diagonal_block_ = nullptr, off_diagonal_block_ = nullptr; // borrowed from jacobian_
};

} // namespace msflex
