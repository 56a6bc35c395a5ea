// A = L U by node blocks in RCM order (BlockEnvelopeLU), x = U^{-1} L^{-1} b; the RCM order and the
// envelope follow the matrix's nonzero pattern (recomputed when PETSc's object id or nonzero state
// changes), the values are refactored at every set-up.
#include "core/block_envelope_pc.hpp"
#include "core/block_envelope_lu.hpp"
#include "core/dense_lu.hpp"
#include "core/rcm_order.hpp"
#include "core/shell_pc.hpp"

#include <cstring>
#include <string>
#include <vector>

namespace msflex {

namespace {

constexpr const char *kBlockLUName = "block LU";

// Accuracy of a solve, |b - P x| / |b|: the first solve with each factorisation is checked; above
// kRefineAbove the solves with it are refined (x += LU^{-1} (b - P x), while that helps, up to
// kMaxRefinements times), and a solve left above kFailAbove fails the PC, which hands the
// factorisation to MUMPS (Newton's banded LU by structure). The block LU pivots only inside the
// diagonal blocks: on a slender beam whose axial and shear stiffness dwarf EI/h^2 (EA h^2/EI =
// 1.6e6) its first solve left 1e-2 of the right-hand side where PETSc's scalar LU in the same order
// left 3e-8, and Newton, stopped by the round-off floor, accepted a tip deflection 2.4e-4 off.
constexpr double kRefineAbove = 1e-10, kFailAbove = 1e-6;
constexpr int    kMaxRefinements = 8;

struct BlockLU {
  BlockEnvelopeLU  lu;
  PetscInt64       matrix_id     = -1; // the pattern analysed: PETSc's object id and nonzero state
  PetscObjectState pattern_state = -1;
  int              zero_pivot    = 0; // the first singular diagonal block + 1 (0: none)
  PetscLogEvent    factor_event = 0, solve_event = 0;
  bool             checked = false, refine = false; // of the current factorisation
  Vec              residual = nullptr, correction = nullptr;
};

// The block pattern of P (block CSR) and its RCM order.
PetscErrorCode BlockPatternInRcmOrder(Mat P, std::vector<int> *row_start, std::vector<int> *columns, std::vector<int> *order)
{
  const PetscInt *ia, *ja;
  PetscInt        n;
  PetscBool       done;
  PetscFunctionBeginUser;
  PetscCall(MatGetRowIJ(P, 0, PETSC_FALSE, PETSC_TRUE, &n, &ia, &ja, &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "block LU: the matrix does not give its block pattern");
  std::vector<PetscInt> rcm;
  PetscCall(RcmOrder(n, ia, ja, &rcm));
  row_start->assign(ia, ia + n + 1);
  columns->assign(ja, ja + ia[n]);
  order->assign(rcm.begin(), rcm.end());
  PetscInt restored; // MatRestoreRowIJ zeroes the count it is given
  PetscCall(MatRestoreRowIJ(P, 0, PETSC_FALSE, PETSC_TRUE, &restored, &ia, &ja, &done));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Analyse(Mat P, BlockLU *context)
{
  std::vector<int> row_start, columns, order;
  PetscFunctionBeginUser;
  PetscCall(BlockPatternInRcmOrder(P, &row_start, &columns, &order));
  context->lu.Analyse((int)order.size(), row_start.data(), columns.data(), order);
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Whether an option of the database names a PC or a factorisation setting for `prefix`
// (-<prefix>pc_type, -<prefix>pc_factor_*): they are PETSc's PC's, which the block LU would ignore.
PetscErrorCode OptionsNamePetscFactor(const char *prefix, bool *named)
{
  char *all;
  PetscFunctionBeginUser;
  *named = false;
  PetscCall(PetscOptionsGetAll(nullptr, &all));
  const std::string options = std::string(" ") + all, head = std::string(" -") + (prefix ? prefix : "");
  PetscCall(PetscFree(all));
  *named = options.find(head + "pc_type") != std::string::npos || options.find(head + "pc_factor_") != std::string::npos;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUSetUp(PC pc)
{
  BlockLU         *context;
  Mat              P;
  PetscScalar     *values;
  PetscInt64       id;
  PetscObjectState pattern_state;
  bool             fits;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &context));
  PetscCall(PCSetFailedReason(pc, PC_NOERROR));
  PetscCall(PCGetOperators(pc, nullptr, &P));
  PetscCall(BlockLUFits(P, &fits));
  PetscCheck(fits, PetscObjectComm((PetscObject)pc), PETSC_ERR_SUP, "block LU: the matrix is not SEQBAIJ with blocks of %d", kEnvelopeBlock);
  PetscCall(PetscLogEventBegin(context->factor_event, pc, P, 0, 0));
  PetscCall(PetscObjectGetId((PetscObject)P, &id));
  PetscCall(MatGetNonzeroState(P, &pattern_state));
  if (id != context->matrix_id || pattern_state != context->pattern_state) {
    PetscCall(Analyse(P, context));
    context->matrix_id     = id;
    context->pattern_state = pattern_state;
  }
  PetscCall(MatSeqBAIJGetArray(P, &values));
  context->zero_pivot = context->lu.Factor(values);
  context->checked    = false;
  context->refine     = false;
  PetscCall(MatSeqBAIJRestoreArray(P, &values));
  PetscCall(PetscLogEventEnd(context->factor_event, pc, P, 0, 0));
  if (context->zero_pivot > 0) PetscCall(PCSetFailedReason(pc, PC_FACTOR_NUMERIC_ZEROPIVOT));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The accuracy check after a solve x = LU^{-1} b (kRefineAbove, kFailAbove above): r = b - P x,
// refinement where the factorisation's first check found it inaccurate, and the PC's failure
// where the solve stays above kFailAbove.
PetscErrorCode CheckAndRefine(PC pc, BlockLU *context, Vec b, Vec x)
{
  Mat       P;
  PetscReal b_norm, r_norm;
  PetscInt  size = -1, work_size = -1;
  PetscFunctionBeginUser;
  PetscCall(PCGetOperators(pc, nullptr, &P));
  PetscCall(VecGetSize(b, &size));
  if (context->residual) PetscCall(VecGetSize(context->residual, &work_size));
  if (work_size != size) { // first use, or a matrix of another size since
    PetscCall(VecDestroy(&context->residual));
    PetscCall(VecDestroy(&context->correction));
    PetscCall(VecDuplicate(b, &context->residual));
    PetscCall(VecDuplicate(b, &context->correction));
  }
  const auto residual_norm = [&](PetscReal *norm) -> PetscErrorCode {
    PetscFunctionBeginUser;
    PetscCall(MatMult(P, x, context->residual));
    PetscCall(VecAYPX(context->residual, -1.0, b));
    PetscCall(VecNorm(context->residual, NORM_2, norm));
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  PetscCall(VecNorm(b, NORM_2, &b_norm));
  PetscCall(residual_norm(&r_norm));
  if (!context->checked) context->refine = b_norm > 0 && r_norm > kRefineAbove * b_norm;
  context->checked = true;
  for (int k = 0; context->refine && k < kMaxRefinements && r_norm > kRefineAbove * b_norm; ++k) {
    const PetscScalar *r_values;
    PetscScalar       *d_values;
    PetscCall(VecGetArrayRead(context->residual, &r_values));
    PetscCall(VecGetArray(context->correction, &d_values));
    context->lu.Solve(r_values, d_values);
    PetscCall(VecRestoreArray(context->correction, &d_values));
    PetscCall(VecRestoreArrayRead(context->residual, &r_values));
    PetscCall(VecAXPY(x, 1.0, context->correction));
    const PetscReal before = r_norm;
    PetscCall(residual_norm(&r_norm));
    if (!(r_norm < 0.5 * before)) break; // no longer helps
  }
  if (!(r_norm <= kFailAbove * b_norm)) PetscCall(PCSetFailedReason(pc, PC_SUBPC_ERROR));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUApply(PC pc, Vec b, Vec x)
{
  BlockLU           *context;
  const PetscScalar *b_values;
  PetscScalar       *x_values;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &context));
  if (context->zero_pivot > 0) {
    // No solution: the caller sees the failed set-up (KSP_DIVERGED_PC_FAILED) and infinities.
    PetscCall(VecSetInf(x));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(PetscLogEventBegin(context->solve_event, pc, b, x, 0));
  PetscCall(VecGetArrayRead(b, &b_values));
  PetscCall(VecGetArray(x, &x_values));
  context->lu.Solve(b_values, x_values);
  PetscCall(VecRestoreArray(x, &x_values));
  PetscCall(VecRestoreArrayRead(b, &b_values));
  if (!context->checked || context->refine) PetscCall(CheckAndRefine(pc, context, b, x));
  PetscCall(PetscLogEventEnd(context->solve_event, pc, b, x, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// -ksp_view: what factors, in which order, and the envelope's size.
PetscErrorCode BlockLUView(PC pc, PetscViewer viewer)
{
  BlockLU  *context;
  PetscBool ascii;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &context));
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (!ascii) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscViewerASCIIPrintf(viewer, "msflex's block LU of %dx%d node blocks in RCM order (pivoting inside the diagonal blocks)\n", kEnvelopeBlock,
                                   kEnvelopeBlock));
  PetscCall(PetscViewerASCIIPrintf(viewer, "%d block rows, %zu blocks stored in the envelope\n", context->lu.NumBlockRows(), context->lu.NumStoredBlocks()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUDestroy(PC pc)
{
  BlockLU *context;
  PetscFunctionBeginUser;
  PetscCall(PCShellGetContext(pc, &context));
  PetscCall(VecDestroy(&context->residual));
  PetscCall(VecDestroy(&context->correction));
  delete context;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode BlockLUFits(Mat matrix, bool *fits)
{
  PetscBool seq_baij;
  PetscInt  block_size;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)matrix, MATSEQBAIJ, &seq_baij));
  PetscCall(MatGetBlockSize(matrix, &block_size));
  *fits = seq_baij && block_size == kEnvelopeBlock;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUEnvelopeOverFill(Mat matrix, double *ratio)
{
  std::vector<int> row_start, columns, order;
  PetscFunctionBeginUser;
  PetscCall(BlockPatternInRcmOrder(matrix, &row_start, &columns, &order));
  const BlockEnvelopeCount count = CountBlockEnvelope((int)order.size(), row_start.data(), columns.data(), order);
  *ratio                         = count.envelope == 0 ? 1.0 : (double)count.envelope / (double)count.fill;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUSuits(Mat matrix, const char *prefix, bool *suits)
{
  bool fits, named;
  PetscFunctionBeginUser;
  *suits = false;
  PetscCall(BlockLUFits(matrix, &fits));
  if (!fits) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(OptionsNamePetscFactor(prefix, &named));
  if (named) PetscFunctionReturn(PETSC_SUCCESS);
  double ratio;
  PetscCall(BlockLUEnvelopeOverFill(matrix, &ratio));
  *suits = ratio <= kBlockLUEnvelopeOverFill;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCSetBlockLU(PC pc)
{
  auto *context = new BlockLU;
  PetscFunctionBeginUser;
  // A PC that is a shell already keeps its type (and its context, which would leak): none first.
  PetscCall(PCSetType(pc, PCNONE));
  // -log_view: the factorisation and the solves, beside PETSc's MatLUFactorNumeric and MatSolve.
  PetscCall(PetscLogEventRegister("BlockLUFactor", PC_CLASSID, &context->factor_event));
  PetscCall(PetscLogEventRegister("BlockLUSolve", PC_CLASSID, &context->solve_event));
  PetscCall(PCSetType(pc, PCSHELL));
  PetscCall(PCShellSetContext(pc, context));
  PetscCall(PCShellSetSetUp(pc, BlockLUSetUp));
  PetscCall(PCShellSetApply(pc, BlockLUApply));
  PetscCall(PCShellSetDestroy(pc, BlockLUDestroy));
  PetscCall(PCShellSetView(pc, BlockLUView));
  PetscCall(PCShellSetName(pc, kBlockLUName));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCIsBlockLU(PC pc, bool *is_block_lu)
{
  void *found;
  PetscFunctionBeginUser;
  PetscCall(ShellContextIfNamed(pc, kBlockLUName, &found));
  *is_block_lu = found != nullptr;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BlockLUDescribeFailure(PC pc, bool *is_block_lu, std::string *detail)
{
  void *found;
  PetscFunctionBeginUser;
  detail->clear();
  PetscCall(ShellContextIfNamed(pc, kBlockLUName, &found));
  *is_block_lu = found != nullptr;
  if (!found) PetscFunctionReturn(PETSC_SUCCESS);
  const BlockLU *context = static_cast<const BlockLU *>(found);
  if (context->zero_pivot > 0)
    *detail = "zero pivot in the diagonal block of unknowns " + std::to_string(kEnvelopeBlock * (context->zero_pivot - 1)) + ".." +
              std::to_string(kEnvelopeBlock * context->zero_pivot - 1) + " of the block LU";
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode ChooseDirectSolver(bool banded, Mat tangent, PC pc)
{
  PetscFunctionBeginUser;
  // Stored by node blocks (SEQBAIJ, 6) with an envelope close to the LU's fill: msflex's block
  // LU, unless an option names PETSc's PC or its factorisation settings.
  bool block_lu = false;
  if (banded) {
    const char *prefix;
    PetscCall(PCGetOptionsPrefix(pc, &prefix));
    PetscCall(BlockLUSuits(tangent, prefix, &block_lu));
  }
  if (block_lu) PetscCall(PCSetBlockLU(pc));
  else if (banded) { // never a dense tangent (Assembler::Setup)
    PetscCall(PCSetType(pc, PCLU));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERPETSC));
    PetscCall(PCFactorSetMatOrderingType(pc, MATORDERINGRCM));
  } else {
    PetscCall(SetDirectSolver(pc, tangent)); // MUMPS, or the dense LU for a dense tangent
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode BandedLUByStructure(PC pc, bool *answer)
{
  PetscBool     lu, package_named, pc_named;
  MatSolverType package = nullptr;
  const char   *prefix;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCLU, &lu));
  if (lu) PetscCall(PCFactorGetMatSolverType(pc, &package));
  PetscCall(PCGetOptionsPrefix(pc, &prefix));
  PetscCall(PetscOptionsHasName(nullptr, prefix, "-pc_factor_mat_solver_type", &package_named));
  PetscCall(PetscOptionsHasName(nullptr, prefix, "-pc_type", &pc_named));
  bool block_lu;
  PetscCall(PCIsBlockLU(pc, &block_lu));
  *answer = block_lu || (lu && package && !strcmp(package, MATSOLVERPETSC) && !package_named && !pc_named);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PCUseMumps(PC pc)
{
  PetscFunctionBeginUser;
  // Without its factor (PCReset) the PC takes another package; its user gives it the operators
  // again before the next solve.
  PetscCall(PCReset(pc));
  PetscCall(PCSetType(pc, PCLU)); // from msflex's block LU, or already
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  // MUMPS orders for itself; ND is PCLU's own default, so -ksp_view shows no stale RCM.
  PetscCall(PCFactorSetMatOrderingType(pc, MATORDERINGND));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
