#pragma once
// What the tangent's sparsity pattern says before any value is assembled: whether its unknowns
// come in whole node blocks of 6 (BAIJ storage), and how banded it is under reverse
// Cuthill-McKee (which direct solver fits, docs/solvers.md).
#include <petscmat.h>

#include <vector>

namespace msflex {

// The exact nonzero pattern of the owned rows (DofMapPreallocation), computed on the whole model
// before it is restricted to the rank's part: CSR with global columns, and the nonzeros of each
// row inside and outside the diagonal part (MatXAIJSetPreallocation).
struct MatrixPattern {
  std::vector<PetscInt> diagonal_nonzeros, off_diagonal_nonzeros, row_start, columns;
};

// Whether the pattern is made of whole aligned blocks of `bs`: the rows come in groups of bs from
// a multiple of bs, the rows of a group have the same columns, and those form whole groups of bs.
// Then the block rows' nonzero blocks, inside and outside the diagonal part, are *diagonal and
// *off_diagonal (for MatXAIJSetPreallocation with block size bs).
bool BlockPattern(const MatrixPattern &pattern, PetscInt first_row, PetscInt bs, std::vector<PetscInt> *diagonal, std::vector<PetscInt> *off_diagonal);

// Mean squared row envelope (the distance from the diagonal to the row's first nonzero) of the
// whole pattern of a one-rank tangent under reverse Cuthill-McKee: about the work per unknown of a
// banded LU in that ordering. A chain of beams gives a few tens, a 3D network thousands.
PetscErrorCode MeanSquaredRcmEnvelope(const MatrixPattern &pattern, double *mean_square);

// A tangent whose mean squared RCM envelope is at most this squared is "banded": PETSc's own LU in
// RCM order factors it fastest (8-10x MUMPS on a 1000-element chain, docs/performance.md).
constexpr double kBandedEnvelope = 60.0;

} // namespace msflex
