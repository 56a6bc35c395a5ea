// Reverse Cuthill-McKee order of a sparsity pattern (one rank's CSR), from PETSc's ordering.
#pragma once

#include <petscmat.h>

#include <vector>

namespace msflex {

// order[i]: the row placed i-th. PETSc orders matrices, not patterns: the pattern is wrapped in a
// sequential AIJ matrix of zeros.
PetscErrorCode RcmOrder(PetscInt n, const PetscInt *row_start, const PetscInt *columns, std::vector<PetscInt> *order);

} // namespace msflex
