// P = L U with row interchanges: msflex's own elimination up to kSmallLUMaxSize unknowns
// (core/small_lu.hpp: LAPACK's blocked machinery costs more than the arithmetic there), LAPACK
// getrf above; x = U^{-1} L^{-1} P^T b (SolveSmallLU or getrs). A pivot that is exactly zero
// (U(k,k) = 0, getrf's info = k > 0) makes P singular: reported, not raised.
#include "core/dense_lu.hpp"
#include "core/shell_pc.hpp"
#include "core/small_lu.hpp"

#include <petscblaslapack.h>

#include <cstring>
#include <vector>

namespace msflex {

namespace {

constexpr const char *kDenseLUName = "dense LU";

struct DenseLU {
  PetscBLASInt              n = 0;
  std::vector<PetscScalar>  factors;        // n x n, column-major: L below the diagonal, U on and above
  std::vector<PetscBLASInt> pivots;         // LAPACK's (1-based), above kSmallLUMaxSize
  std::vector<int>          small_pivots;   // FactorSmallLU's (0-based), up to kSmallLUMaxSize
  PetscBLASInt              zero_pivot = 0; // the first column with a zero pivot, 1-based (0: none)
  bool                      Small() const { return n <= kSmallLUMaxSize; }
};

PetscErrorCode DenseLUSetUp(PC pc)
{
  DenseLU           *lu;
  Mat                P;
  const PetscScalar *values;
  PetscInt           rows, columns, lda;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &lu));
  PetscCall(PCSetFailedReason(pc, PC_NOERROR));
  PetscCall(PCGetOperators(pc, nullptr, &P));
  PetscCall(MatGetSize(P, &rows, &columns));
  PetscCheck(rows == columns, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_SIZ, "dense LU of a %" PetscInt_FMT " x %" PetscInt_FMT " matrix", rows, columns);
  PetscCall(PetscBLASIntCast(rows, &lu->n));
  PetscCall(MatDenseGetLDA(P, &lda));
  lu->factors.resize((size_t)rows * (size_t)rows);
  PetscCall(MatDenseGetArrayRead(P, &values));
  for (PetscInt j = 0; j < rows; ++j) std::memcpy(&lu->factors[(size_t)j * rows], values + (size_t)j * lda, sizeof(PetscScalar) * (size_t)rows);
  PetscCall(MatDenseRestoreArrayRead(P, &values));
  PetscBLASInt info = 0;
  if (lu->Small()) {
    lu->small_pivots.resize((size_t)rows);
    info = FactorSmallLU(lu->n, lu->factors.data(), lu->small_pivots.data());
  } else {
    lu->pivots.resize((size_t)rows);
    PetscCall(PetscFPTrapPush(PETSC_FP_TRAP_OFF));
    PetscCallBLAS("LAPACKgetrf", LAPACKgetrf_(&lu->n, &lu->n, lu->factors.data(), &lu->n, lu->pivots.data(), &info));
    PetscCall(PetscFPTrapPop());
  }
  PetscCheck(info >= 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "LAPACK getrf: argument %d is wrong", (int)-info);
  lu->zero_pivot = info;
  if (info > 0) PetscCall(PCSetFailedReason(pc, PC_FACTOR_NUMERIC_ZEROPIVOT));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DenseLUApply(PC pc, Vec b, Vec x)
{
  DenseLU     *lu;
  PetscScalar *values;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &lu));
  if (lu->zero_pivot > 0) {
    // No solution: the caller sees the failed set-up (KSP_DIVERGED_PC_FAILED) and infinities.
    PetscCall(VecSetInf(x));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecCopy(b, x));
  if (lu->n == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscBLASInt one = 1, info = 0;
  PetscCall(VecGetArray(x, &values));
  if (lu->Small()) SolveSmallLU(lu->n, lu->factors.data(), lu->small_pivots.data(), values);
  else {
    PetscCall(PetscFPTrapPush(PETSC_FP_TRAP_OFF));
    PetscCallBLAS("LAPACKgetrs", LAPACKgetrs_("N", &lu->n, &one, lu->factors.data(), &lu->n, lu->pivots.data(), values, &lu->n, &info));
    PetscCall(PetscFPTrapPop());
  }
  PetscCall(VecRestoreArray(x, &values));
  PetscCheck(info == 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "LAPACK getrs: argument %d is wrong", (int)-info);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DenseLUDestroy(PC pc)
{
  DenseLU *lu;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &lu));
  delete lu;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode PCSetDenseLU(PC pc)
{
  PetscFunctionBeginUser;
  PetscCall(PCSetType(pc, PCSHELL));
  PetscCall(PCShellSetContext(pc, new DenseLU));
  PetscCall(PCShellSetSetUp(pc, DenseLUSetUp));
  PetscCall(PCShellSetApply(pc, DenseLUApply));
  PetscCall(PCShellSetDestroy(pc, DenseLUDestroy));
  PetscCall(PCShellSetName(pc, kDenseLUName));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DenseLUDescribeFailure(PC pc, bool *is_dense_lu, std::string *detail)
{
  void *found;
  PetscFunctionBeginUser;
  detail->clear();
  PetscCall(ShellContextIfNamed(pc, kDenseLUName, &found));
  *is_dense_lu = found != nullptr;
  if (!found) PetscFunctionReturn(PETSC_SUCCESS);
  const DenseLU *lu = static_cast<const DenseLU *>(found);
  if (lu->zero_pivot > 0) *detail = "zero pivot in column " + std::to_string(lu->zero_pivot) + " of the dense LU";
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SetDirectSolver(PC pc, Mat matrix)
{
  PetscBool dense;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)matrix, MATSEQDENSE, &dense));
  if (dense) PetscCall(PCSetDenseLU(pc));
  else {
    PetscCall(PCSetType(pc, PCLU));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The factorisation package of a PC of type LU (nullptr for any other PC, or none chosen yet).
static PetscErrorCode LUPackage(PC pc, MatSolverType *package)
{
  PCType type;
  PetscFunctionBeginUser;
  *package = nullptr;
  PetscCall(PCGetType(pc, &type));
  if (type && !strcmp(type, PCLU)) PetscCall(PCFactorGetMatSolverType(pc, package));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Whether the PC factors a sparse matrix by PETSc's own LU, which does not pivot (a dense matrix's
// LU is LAPACK's, which does).
static PetscErrorCode UsesNonPivotingLU(PC pc, Mat matrix, PetscBool *answer)
{
  MatSolverType package;
  PetscBool     dense;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompareAny((PetscObject)matrix, &dense, MATSEQDENSE, MATMPIDENSE, ""));
  PetscCall(LUPackage(pc, &package));
  *answer = !dense && package && !strcmp(package, MATSOLVERPETSC) ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WidenMumpsWorkspace(PC pc, Mat matrix, PetscInt percent)
{
  MatSolverType package;
  Mat           factor;
  PetscFunctionBeginUser;
  PetscCall(LUPackage(pc, &package));
  if (!package || strcmp(package, MATSOLVERMUMPS)) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCSetOperators(pc, matrix, matrix));
  PetscCall(PCFactorSetUpMatSolverType(pc));
  PetscCall(PCFactorGetMatrix(pc, &factor));
  // The default of ICNTL(14); -mat_mumps_icntl_14, read at the symbolic factorisation, still wins.
  PetscCall(MatMumpsSetIcntl(factor, 14, percent));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PrepareRelayDirectSolver(PC pc, Mat matrix, const char *package_option, int condensation_depth)
{
  PetscBool petsc_lu;
  PetscFunctionBeginUser;
  PetscCall(UsesNonPivotingLU(pc, matrix, &petsc_lu));
  PetscCheck(!petsc_lu, PetscObjectComm((PetscObject)pc), PETSC_ERR_USER_INPUT,
             "bad option: %s petsc with relay nodes (chains deeper than -analysis_condensation_depth %d): PETSc's LU does not pivot, and their force "
             "rows have zero diagonals; use mumps, or -analysis_condensation_depth 0",
             package_option, condensation_depth);
  PetscCall(WidenMumpsWorkspace(pc, matrix, kRelayMumpsWorkspace));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
