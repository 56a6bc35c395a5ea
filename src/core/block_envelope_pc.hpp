// The direct solver of a banded tangent stored by node blocks (SEQBAIJ with blocks of 6, one rank):
// msflex's block envelope LU (core/block_envelope_lu.hpp) in RCM order of the node blocks, as a
// PCSHELL named "block LU". It factors a 1000-element chain in about half the time of PETSc's own
// BAIJ LU (docs/performance.md), pivots inside the 6x6 diagonal blocks as PETSc's does, and
// reports an exactly singular diagonal block as the preconditioner's failure
// (PC_FACTOR_NUMERIC_ZEROPIVOT) instead of raising an error. The ordering and the envelope are
// kept while the matrix and its nonzero pattern stay.
#pragma once

#include <petscksp.h>

#include <string>

namespace msflex {

// Whether `matrix` is what the block LU factors: SEQBAIJ with blocks of 6.
PetscErrorCode BlockLUFits(Mat matrix, bool *fits);

// Makes `pc` the block LU above. `-pc_type` or `-pc_factor_mat_solver_type` in the options replace it.
PetscErrorCode PCSetBlockLU(PC pc);

// Whether `pc` is that solver, and if its last factorisation met a singular diagonal block, which
// (`detail`).
PetscErrorCode BlockLUDescribeFailure(PC pc, bool *is_block_lu, std::string *detail);

} // namespace msflex
