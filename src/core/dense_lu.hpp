// A direct solver for a dense operator (MATSEQDENSE: a small model's tangent, -jacobian_dense_below)
// that fails softly: LU with partial pivoting (msflex's own elimination up to kSmallLUMaxSize
// unknowns, core/small_lu.hpp; LAPACK getrf and getrs above), its exactly singular factorisation
// reported as the preconditioner's failure
// (PC_FACTOR_NUMERIC_ZEROPIVOT), so that the linear solve fails, the step is halved and the
// message names what nothing resists. PETSc's own dense LU raises an error there instead
// (PETSC_ERR_MAT_LU_ZRPVT), which ends the run with a trace-back.
#pragma once

#include <petscksp.h>

#include <string>

namespace msflex {

// Makes `pc` the dense LU above (a PCSHELL named "dense LU"). `-pc_type lu` in the options
// replaces it by PETSc's LU again.
PetscErrorCode PCSetDenseLU(PC pc);

// Whether `pc` is that solver, and if its last factorisation met a zero pivot, where (`detail`).
PetscErrorCode DenseLUDescribeFailure(PC pc, bool *is_dense_lu, std::string *detail);

// msflex's direct solver for `matrix`: the dense LU above for a dense matrix (one rank only:
// -jacobian_mat_type dense is refused on more), else MUMPS LU.
PetscErrorCode SetDirectSolver(PC pc, Mat matrix);
// MUMPS' work-space margin (ICNTL(14), percent over its estimate) for a tangent whose pivots are
// found by numerical pivoting; nothing for other solvers. -mat_mumps_icntl_14 still wins.
PetscErrorCode WidenMumpsWorkspace(PC pc, Mat matrix, PetscInt percent);
// Relay nodes' zero diagonals (DofMap) are pivoted numerically: MUMPS' estimate of its work space
// is too low for them (a chain of 10^4 rigid bodies failed with INFOG(1) = -9 at the default 20 %).
constexpr PetscInt kRelayMumpsWorkspace = 100;
// A direct solver for a matrix with relay nodes: PETSc's sparse LU, which does not pivot, is
// refused with one line naming `package_option` (the option that chose it); MUMPS gets the margin
// above.
PetscErrorCode PrepareRelayDirectSolver(PC pc, Mat matrix, const char *package_option, int condensation_depth);

} // namespace msflex
