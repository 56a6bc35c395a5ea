#include "integrators/newton.hpp"
#include "core/block_envelope_pc.hpp"
#include "core/dense_lu.hpp"
#include "core/errors.hpp"

#include "core/format.hpp"

#include <petscmat.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>

namespace msflex {

namespace {

// Whether a residual evaluation should assemble the tangent with it: SNES asks for the tangent at
// every iterate whose residual does not pass the convergence test, and one pass for both costs
// little more than the tangent's alone (the residual pass it saves is a third of an iteration of a
// beam model).
bool TangentWithResidual(const NewtonContext &context) { return context.tangent_with_residual && context.assembler->CanAssembleResidualWithJacobian(); }

// Residual on every rank; false on every rank when any element could not be evaluated.
// The residual at `increments`; with `with_tangent` also the tangent there, in the same pass
// (Assembler::AssembleResidualWithJacobian), for the FormJacobian that follows.
PetscErrorCode EvaluateResidual(NewtonContext *context, Vec increments, Vec residual, PetscBool *all_ok, bool with_tangent = false)
{
  PetscBool geometry_ok;
  PetscFunctionBeginUser;
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePush(context->assembly_stage));
  PetscCall(context->assembler->SetIncrements(increments));
  // A residual alone while tangents come with residuals: no tangent follows at these unknowns
  // (Newton expects to have converged, or a finite-difference check evaluates), so em's elements
  // need not keep their iterates.
  if (with_tangent) PetscCall(context->assembler->AssembleResidualWithJacobian(residual, &geometry_ok));
  else PetscCall(context->assembler->AssembleResidual(residual, &geometry_ok, !TangentWithResidual(*context)));
  PetscCall(MPIU_Allreduce(&geometry_ok, all_ok, 1, MPIU_BOOL, MPI_LAND, context->comm));
  context->tangent_ahead = with_tangent && *all_ok;
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePop());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The residual norm that converges (ForceScaledConvergenceTest, besides SNES's own atol): rtol
// times the force level of the last residual, or the residual's round-off floor where that is
// higher. Collective (ForceScale).
PetscErrorCode ConvergedResidualNorm(SNES snes, NewtonContext *context, double *needed)
{
  PetscReal atol, rtol, stol;
  PetscInt  max_iterations, max_evaluations;
  double    force_scale;
  PetscFunctionBeginUser;
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations));
  PetscCall(context->assembler->ForceScale(&force_scale));
  *needed = std::max((double)rtol * force_scale, context->assembler->RoundoffForceLevel());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Whether the Newton step about to be taken (from iterate k, residual norm f_k) most likely ends
// the solve: with quadratic convergence f_{k+1} = C f_k^2, and C from the last iteration,
// f_{k+1} = f_k^3 / f_{k-1}^2. Then its residual is assembled alone, as no tangent will follow.
// A wrong guess costs a pass, never the answer. Collective (ForceScale), alike on every rank.
PetscErrorCode StepLikelyConverges(SNES snes, NewtonContext *context, bool *converges)
{
  PetscInt   iteration = 0, count = 0, max_iterations, max_evaluations;
  PetscReal *norms = nullptr, atol, rtol, stol;
  double     needed;
  PetscFunctionBeginUser;
  *converges = false;
  PetscCall(SNESGetIterationNumber(snes, &iteration));
  PetscCall(SNESGetConvergenceHistory(snes, &norms, nullptr, &count));
  if (iteration < 1 || count <= iteration) PetscFunctionReturn(PETSC_SUCCESS);
  const double previous = norms[iteration - 1], current = norms[iteration];
  if (!(current < previous) || previous <= 0.0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations));
  PetscCall(ConvergedResidualNorm(snes, context, &needed));
  const double predicted = current * (current / previous) * (current / previous);
  *converges             = predicted <= std::max((double)atol, needed);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode FormResidual(SNES snes, Vec increments, Vec residual, void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  PetscBool      all_ok;
  PetscFunctionBeginUser;
  // With msflex's line search SNES evaluates the residual itself at the start of a solve, and the
  // tangent there follows unless the start already converged. Between a tangent and its solve it
  // evaluates residuals only to check that tangent by finite differences (-snes_compare_explicit,
  // -snes_compare_coloring, -snes_test_jacobian_display_threshold, ...), at other unknowns: those
  // must leave the matrix alone.
  const bool with_tangent = TangentWithResidual(*context) && !context->tangent_awaits_solve;
  PetscCall(EvaluateResidual(context, increments, residual, &all_ok, with_tangent));
  if (!all_ok) PetscCall(SNESSetFunctionDomainError(snes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The step kind and length a tangent belongs to (NewtonContext::tangent_step): the problem, the
// inertia coefficient, the step (dt as set, not a difference of times; a static step's length in
// time) and the load scale (the static stage's steps share one time and differ in it).
void TangentStep(const StepEquations &equations, double key[4])
{
  key[0] = (double)equations.problem;
  key[1] = equations.InertiaCoefficient();
  key[2] = equations.Dynamic() ? equations.scheme.dt : equations.t_end - equations.t_start;
  key[3] = equations.load_scale;
}

// Modified Newton's rule (NewtonContext::jacobian_reuse): whether the factored tangent serves
// this iteration too. Every rank decides alike (the residual norms and the step are global).
bool ReuseTangent(SNES snes, const NewtonContext &context)
{
  if (context.jacobian_reuse <= 0.0 || !context.tangent_factored) return false;
  double key[4];
  TangentStep(context.assembler->Equations(), key);
  if (!std::equal(key, key + 4, context.tangent_step)) return false;
  if (context.assembler->MatrixAssemblies() != context.tangent_assembly) return false; // the matrix holds something else now
  PetscInt   iteration = 0, count = 0;
  PetscReal *norms = nullptr;
  if (SNESGetIterationNumber(snes, &iteration) != PETSC_SUCCESS || SNESGetConvergenceHistory(snes, &norms, nullptr, &count) != PETSC_SUCCESS) return false;
  if (iteration == 0) return context.last_contracted;
  return count > iteration && norms[iteration] <= context.jacobian_reuse * norms[iteration - 1];
}

PetscErrorCode FormJacobian(SNES snes, Vec increments, Mat jacobian, Mat preconditioner, void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  PetscBool      geometry_ok, all_ok;
  PetscFunctionBeginUser;
  // Modified Newton: the matrix is left as it is, so the preconditioner keeps its factorisation
  // (PCSetUp skips an unchanged operator) and em's rank-one vectors stay those of that tangent. A
  // matrix-free operator (-snes_mf_operator) still moves to the new iterate: its assembly sets the
  // point it differentiates at.
  context->tangent_awaits_solve = true; // until msflex's line search takes the step it gives
  if (ReuseTangent(snes, *context)) {
    ++context->tangents_reused;
    if (jacobian != preconditioner) {
      PetscCall(MatAssemblyBegin(jacobian, MAT_FINAL_ASSEMBLY));
      PetscCall(MatAssemblyEnd(jacobian, MAT_FINAL_ASSEMBLY));
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePush(context->assembly_stage));
  // SNES asks for the tangent at the iterate whose residual it has just evaluated: the State holds
  // it, and so may the matrix (the residual was assembled with it, on every rank alike).
  PetscCall(context->assembler->SetIncrements(increments, true));
  if (context->tangent_ahead && context->assembler->JacobianCurrent() && preconditioner == context->assembler->Jacobian()) geometry_ok = PETSC_TRUE;
  else PetscCall(context->assembler->AssembleJacobian(preconditioner, &geometry_ok));
  context->tangent_ahead             = false;
  context->rank_one_solution_current = false;
  context->tangent_factored          = context->jacobian_reuse > 0.0; // factored by the solve that follows
  TangentStep(context->assembler->Equations(), context->tangent_step);
  context->tangent_assembly = context->assembler->MatrixAssemblies();
  ++context->tangents_formed;
  PetscCall(MPIU_Allreduce(&geometry_ok, &all_ok, 1, MPIU_BOOL, MPI_LAND, context->comm));
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePop());
  if (!all_ok) PetscCall(SNESSetJacobianDomainError(snes));
  if (jacobian != preconditioner) {
    PetscCall(MatAssemblyBegin(jacobian, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(jacobian, MAT_FINAL_ASSEMBLY));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// x_new = x - lambda y with lambda = 1, halved while the new configuration cannot be evaluated.
PetscErrorCode SafeguardedNewtonStep(SNESLineSearch linesearch, void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  Vec            x, f, y, w, g;
  PetscReal      lambda = 1.0, fnorm = 0.0, xnorm, ynorm;
  PetscBool      geometry_ok = PETSC_FALSE, evaluable = PETSC_FALSE;
  PetscFunctionBeginUser;
  PetscCall(SNESLineSearchGetVecs(linesearch, &x, &f, &y, &w, &g));
  context->tangent_awaits_solve = false;
  // The relay nodes' entries of the step are the linear solve's, not increments of the state.
  PetscCall(context->assembler->ZeroRelayEntries(y));
  PetscCall(VecNorm(y, NORM_2, &ynorm));
  // A non-finite update leaves the tangent it came from in the matrix, for the diagnosis.
  bool with_tangent = TangentWithResidual(*context) && std::isfinite(ynorm);
  if (with_tangent) {
    SNES snes;
    bool converges;
    PetscCall(SNESLineSearchGetSNES(linesearch, &snes));
    PetscCall(StepLikelyConverges(snes, context, &converges));
    with_tangent = !converges;
  }
  for (int attempt = 0; attempt < 9; ++attempt) {
    if (attempt > 0) lambda *= 0.5;
    PetscCall(VecWAXPY(w, -lambda, y, x));
    PetscCall(EvaluateResidual(context, w, g, &geometry_ok, with_tangent));
    evaluable = geometry_ok;
    if (evaluable) {
      PetscCall(VecNorm(g, NORM_2, &fnorm));
      evaluable = std::isfinite(fnorm) ? PETSC_TRUE : PETSC_FALSE;
    }
    if (evaluable) break;
  }
  // w and g keep the shortest step's increments and residual: NewtonDescribeFailure looks there.
  context->line_search_trouble     = evaluable     ? NewtonContext::StepTrouble::None
                                     : geometry_ok ? NewtonContext::StepTrouble::NonFinite
                                                   : NewtonContext::StepTrouble::Unevaluable;
  context->line_search_last_lambda = lambda;
  if (!evaluable) {
    PetscCall(SNESLineSearchSetReason(linesearch, SNES_LINESEARCH_FAILED_DOMAIN));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecCopy(w, x));
  PetscCall(VecCopy(g, f));
  PetscCall(VecNorm(x, NORM_2, &xnorm));
  PetscCall(SNESLineSearchSetLambda(linesearch, lambda));
  PetscCall(SNESLineSearchSetNorms(linesearch, xnorm, fnorm, lambda * ynorm));
  PetscCall(SNESLineSearchSetReason(linesearch, SNES_LINESEARCH_SUCCEEDED));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// How far above the residual's convergence threshold the step-size test may still stop Newton.
constexpr double kStepTestResidualMargin = 1e4;

PetscErrorCode ForceScaledConvergenceTest(SNES snes, PetscInt iteration, PetscReal xnorm, PetscReal step_norm, PetscReal fnorm, SNESConvergedReason *reason,
                                          void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  PetscFunctionBeginUser;
  if (iteration == 0) context->line_search_trouble = NewtonContext::StepTrouble::None; // a new solve
  PetscCall(SNESConvergedDefault(snes, iteration, xnorm, step_norm, fnorm, reason, nullptr));
  if (iteration == 0) PetscFunctionReturn(PETSC_SUCCESS);
  // Modified Newton: whether the last iteration contracted by the factor, for the next tangent and,
  // after the last iteration, for the next solve's first (NewtonContext::last_contracted).
  if (context->jacobian_reuse > 0.0) {
    PetscInt   count = 0;
    PetscReal *norms = nullptr;
    PetscCall(SNESGetConvergenceHistory(snes, &norms, nullptr, &count));
    context->last_contracted = count > iteration && fnorm <= context->jacobian_reuse * norms[iteration - 1];
  }
  if (*reason != SNES_CONVERGED_ITERATING && *reason != SNES_CONVERGED_SNORM_RELATIVE) PetscFunctionReturn(PETSC_SUCCESS);
  double needed;
  PetscCall(ConvergedResidualNorm(snes, context, &needed));
  if (fnorm <= needed) *reason = SNES_CONVERGED_FNORM_RELATIVE;
  // The step-size test (a relative update below stol) means the iterate is at round-off only when
  // the residual is near its floor too: far above it (a singular tangent, whose updates are
  // round-off in the null space) it is no convergence.
  else if (*reason == SNES_CONVERGED_SNORM_RELATIVE && fnorm > kStepTestResidualMargin * needed) *reason = SNES_CONVERGED_ITERATING;
  // At the noise of the inertia terms' rounding (a body at rest or at a turning point with a small
  // step, where the momenta set no floor): a residual below the assembler's stagnation level that
  // the last iteration did not halve is as small as it gets. (The residual bounced between 1.5e-9
  // and 4.5e-9 against a needed 1e-9 for a flywheel at rest with dt = 1e-4 s, and halving the step
  // raises that noise like 1/dt^2.) A Newton that still converges is not stopped early.
  if (*reason == SNES_CONVERGED_ITERATING && iteration >= 2 && fnorm <= context->assembler->StagnationLevel()) {
    PetscInt   count = 0;
    PetscReal *norms = nullptr;
    PetscCall(SNESGetConvergenceHistory(snes, &norms, nullptr, &count));
    if (count > iteration && fnorm > 0.5 * norms[iteration - 1]) *reason = SNES_CONVERGED_FNORM_ABS;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// em's linear solves (Sherman-Morrison): the Newton operator is K + a b^T, K the assembled
// tangent and a b^T the rank-one term of beta (Assembler::RankOneTerm). The KSP solves K y = r
// with K's factorisation; this hook turns y into the solution of the whole operator,
//   x = y - c (b^T y) / (1 + b^T c),   c = K^{-1} a,
// with c solved once per tangent: two triangular solves per Newton iteration, against the three
// of GMRES on the preconditioned operator I + K^{-1} a b^T. When the KSP's operator is not K
// itself (-snes_mf_operator: the Krylov method already solved the whole operator) it does nothing.
PetscErrorCode ShermanMorrisonCorrection(KSP ksp, Vec rhs, Vec x, void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  Mat            operator_matrix, preconditioner_matrix;
  Vec            a, b;
  bool           active;
  PetscFunctionBeginUser;
  (void)rhs;
  context->assembler->RankOneTerm(&a, &b, &active);
  PetscCall(KSPGetOperators(ksp, &operator_matrix, &preconditioner_matrix));
  if (!active || operator_matrix != preconditioner_matrix) PetscFunctionReturn(PETSC_SUCCESS);
  if (!context->rank_one_solution) PetscCall(VecDuplicate(x, &context->rank_one_solution));
  if (!context->rank_one_solution_current) {
    PC pc;
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCApply(pc, a, context->rank_one_solution));
    context->rank_one_solution_current = true;
  }
  PetscScalar b_dot_y, b_dot_c;
  PetscCall(VecDot(b, x, &b_dot_y));
  PetscCall(VecDot(b, context->rank_one_solution, &b_dot_c));
  // 1 + b^T c = 0 would make K + a b^T singular: the step is then K's alone (inexact, and
  // Newton's own test judges it) rather than a division by zero.
  if (std::abs(1.0 + PetscRealPart(b_dot_c)) > 1e-14) PetscCall(VecAXPY(x, -b_dot_y / (1.0 + b_dot_c), context->rank_one_solution));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// analysis.linear_solver multigrid (docs/solvers.md, "Large networks in statics"): GMRES
// preconditioned by smoothed-aggregation algebraic multigrid, which builds its coarse spaces from
// the six rigid-body modes of every node that the Assembler attaches as the tangent's near-null
// space (the tangent has blocks of 6 when every unknown is in a node's block). Trilinos ML when
// PETSc has it (on lattice networks its coarse levels stay sparse, where GAMG's fill up to 7x the
// fine operator: 2.5 s against 17 s per static solve of 38,016 unknowns), else GAMG. A linear
// relative tolerance of 1e-6 costs no Newton iteration there (inexact Newton; the converged
// residual is tested as always) and saves 40 % of the Krylov iterations against 1e-10. The levels
// smooth by Chebyshev iteration on the inverted 6x6 node blocks (point-block Jacobi), 20 % faster
// per solve than ML's default SOR there and the same on any number of ranks. -ksp_*, -pc_* and
// -mg_levels_* options override all of it.
PetscErrorCode SetMultigridSolver(KSP ksp, PC pc)
{
  PetscErrorCode (*create_ml)(PC) = nullptr;
  PetscBool smoother_chosen, smoother_pc_chosen;
  PetscFunctionBeginUser;
  PetscCall(KSPSetType(ksp, KSPGMRES));
  PetscCall(KSPGMRESSetRestart(ksp, 50));                                     // default
  PetscCall(KSPSetTolerances(ksp, 1e-6, PETSC_DEFAULT, PETSC_DEFAULT, 1000)); // default rtol, iteration limit
  PetscCall(PetscFunctionListFind(PCList, PCML, &create_ml));
  PetscCall(PCSetType(pc, create_ml ? PCML : PCGAMG));
  // The level solvers exist only once the hierarchy is built, and read their options then.
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-mg_levels_ksp_type", &smoother_chosen));
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-mg_levels_pc_type", &smoother_pc_chosen));
  if (!smoother_chosen) PetscCall(PetscOptionsSetValue(nullptr, "-mg_levels_ksp_type", KSPCHEBYSHEV)); // default
  if (!smoother_pc_chosen) PetscCall(PetscOptionsSetValue(nullptr, "-mg_levels_pc_type", PCPBJACOBI)); // default
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Whether residual evaluations assemble the tangent with them (NewtonContext::tangent_with_residual):
// only when SNES is sure to ask for the tangent at each iterate whose residual msflex's line search
// (or SNES at the start) evaluates, and to solve with the assembled matrix. Not with modified Newton
// (the matrix keeps an older tangent), a lagged Jacobian, or a matrix-free or finite-difference
// Jacobian (-snes_mf, -snes_mf_operator, -snes_fd: other residual evaluations, another matrix). The
// finite-difference checks of a tangent (-snes_test_jacobian, -snes_compare_*) need no rule of
// their own: FormResidual assembles their residuals alone (NewtonContext::tangent_awaits_solve).
PetscErrorCode DecideTangentWithResidual(SNES snes, SNESLineSearch linesearch, NewtonContext *context)
{
  PetscBool          newton_ls, shell_line_search, matrix_free, matrix_free_operator;
  PetscInt           lag;
  SNESLineSearchType line_search_type;
  PetscErrorCode (*jacobian_function)(SNES, Vec, Mat, Mat, void *) = nullptr;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNEWTONLS, &newton_ls));
  PetscCall(SNESLineSearchGetType(linesearch, &line_search_type));
  shell_line_search = !strcmp(line_search_type, SNESLINESEARCHSHELL) ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(SNESGetLagJacobian(snes, &lag));
  PetscCall(SNESGetJacobian(snes, nullptr, nullptr, &jacobian_function, nullptr));
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-snes_mf", &matrix_free));
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-snes_mf_operator", &matrix_free_operator));
  context->tangent_with_residual = newton_ls && shell_line_search && lag == 1 && jacobian_function == FormJacobian && !matrix_free && !matrix_free_operator &&
                                   context->jacobian_reuse <= 0.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode NewtonSolverCreate(MPI_Comm comm, const AnalysisSettings &analysis, NewtonOperator newton_operator, NewtonContext *context, SNES *snes)
{
  KSP            ksp;
  PC             pc;
  SNESLineSearch linesearch;
  Vec            residual;
  PetscFunctionBeginUser;
  context->comm           = comm;
  context->jacobian_reuse = analysis.jacobian_reuse;
  PetscCall(SNESCreate(comm, snes));
  PetscCall(SNESSetType(*snes, SNESNEWTONLS));
  PetscCall(VecDuplicate(context->assembler->SolutionTemplate(), &residual));
  PetscCall(SNESSetFunction(*snes, residual, FormResidual, context));
  PetscCall(VecDestroy(&residual));
  Mat tangent = context->assembler->Jacobian();
  PetscCall(SNESSetJacobian(*snes, tangent, tangent, FormJacobian, context));
  // stol: a relative update below 1e-12 means the iterate is at round-off.
  PetscCall(SNESSetTolerances(*snes, analysis.newton_atol, analysis.newton_rtol, 1e-12, analysis.max_newton_iterations, PETSC_DEFAULT));
  // No divergence test on |R|: in a large-rotation beam step the first, correct iteration can
  // raise |R| by orders of magnitude; failure is detected by the iteration limit instead.
  PetscCall(SNESSetDivergenceTolerance(*snes, -1.0));
  PetscCall(SNESSetConvergenceTest(*snes, ForceScaledConvergenceTest, context, nullptr));
  // The residual norms of each solve (reset at every SNESSolve) for NewtonDescribeFailure.
  PetscCall(SNESSetConvergenceHistory(*snes, nullptr, nullptr, PETSC_DECIDE, PETSC_TRUE));
  PetscCall(SNESGetLineSearch(*snes, &linesearch));
  PetscCall(SNESLineSearchSetType(linesearch, SNESLINESEARCHSHELL));
  PetscCall(SNESLineSearchShellSetUserFunc(linesearch, SafeguardedNewtonStep, context));
  PetscCall(SNESGetKSP(*snes, &ksp));
  const bool multigrid = analysis.linear_solver == LinearSolverKind::Multigrid;
  context->multigrid   = multigrid;
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  if (newton_operator == NewtonOperator::AssembledWithRankOne) PetscCall(KSPSetPostSolve(ksp, ShermanMorrisonCorrection, context));
  PetscCall(KSPGetPC(ksp, &pc));
  // The direct solver by structure (analysis.direct_solver auto): PETSc's LU for banded tangents,
  // whose failure hands the run to MUMPS (NewtonUsePivotingLU), so that a singular tangent is
  // still accounted for by MUMPS (INFOG). A dense tangent always goes to LAPACK (MUMPS takes
  // sparse matrices only), through msflex's dense LU, which reports a singular tangent itself.
  const bool by_structure = analysis.direct_solver == DirectSolverChoice::Auto;
  // Relay nodes put zeros on the diagonal (their force rows): they need a pivoting LU (MUMPS, LAPACK).
  const bool relays = context->assembler->Map().num_relays > 0;
  PetscCheck(!multigrid || !relays, comm, PETSC_ERR_USER_INPUT,
             "-analysis_linear_solver multigrid with relay nodes (chains of joints deeper than -analysis_condensation_depth %d): their rows have zero "
             "diagonals, which multigrid's smoothers divide by; give -analysis_condensation_depth 0 (whole condensation; a long chain may still "
             "defeat multigrid, whose smoothers are made for the nodes' unknowns: then -analysis_linear_solver direct)",
             analysis.condensation_depth);
  if (multigrid) PetscCall(SetMultigridSolver(ksp, pc));
  else if (by_structure && !relays) PetscCall(ChooseDirectSolver(context->assembler->BandedUnderRcm(), tangent, pc));
  else PetscCall(SetDirectSolver(pc, tangent));
  MSFLEX_CALL_READING_OPTIONS(PetscObjectComm((PetscObject)*snes), SNESSetFromOptions(*snes));
  PetscCall(CheckFactorSolverAvailable(ksp, tangent));
  if (by_structure && !relays && !multigrid) PetscCall(BandedLUByStructure(pc, &context->banded_lu_by_structure));
  PetscCall(DecideTangentWithResidual(*snes, linesearch, context));
  if (relays) {
    PetscCall(PrepareRelayDirectSolver(pc, tangent, "-pc_factor_mat_solver_type", analysis.condensation_depth));
    PetscBool          matrix_free = PETSC_FALSE;
    SNESLineSearchType line_search_type;
    PetscCall(PetscOptionsHasName(nullptr, nullptr, "-snes_mf_operator", &matrix_free));
    PetscCall(SNESLineSearchGetType(linesearch, &line_search_type));
    // msflex's own line search drops the relays' entries of the step (they are no increments).
    PetscCheck(!strcmp(line_search_type, SNESLINESEARCHSHELL), comm, PETSC_ERR_USER_INPUT,
               "bad option: -snes_linesearch_type %s with relay nodes (chains deeper than -analysis_condensation_depth %d): msflex's own line search "
               "keeps the relays' rows out of the update; give -analysis_condensation_depth 0",
               line_search_type, analysis.condensation_depth);
    PetscCheck(!matrix_free, comm, PETSC_ERR_USER_INPUT,
               "bad option: -snes_mf_operator with relay nodes (chains deeper than -analysis_condensation_depth %d): the matrix-free operator does not see "
               "their rows; give -analysis_condensation_depth 0",
               analysis.condensation_depth);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

namespace {

// The lowest global row of v holding NaN or Inf (-1: none) and whether v holds a NaN. Collective.
PetscErrorCode FirstNonFiniteRow(Vec v, PetscInt *row, PetscBool *has_nan)
{
  const PetscScalar *values;
  PetscInt           first, last, local_row = PETSC_MAX_INT;
  PetscBool          local_nan = PETSC_FALSE;
  PetscFunctionBeginUser;
  PetscCall(VecGetOwnershipRange(v, &first, &last));
  PetscCall(VecGetArrayRead(v, &values));
  for (PetscInt i = last - first - 1; i >= 0; --i) {
    const PetscReal value = PetscRealPart(values[i]);
    if (std::isnan(value)) local_nan = PETSC_TRUE;
    if (!std::isfinite(value)) local_row = first + i;
  }
  PetscCall(VecRestoreArrayRead(v, &values));
  PetscCall(MPIU_Allreduce(&local_row, row, 1, MPIU_INT, MPI_MIN, PetscObjectComm((PetscObject)v)));
  PetscCall(MPIU_Allreduce(&local_nan, has_nan, 1, MPIU_BOOL, MPI_LOR, PetscObjectComm((PetscObject)v)));
  if (*row == PETSC_MAX_INT) *row = -1;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The row of v with the largest magnitude and that magnitude. Collective.
PetscErrorCode LargestEntry(Vec v, PetscInt *row, PetscReal *magnitude)
{
  Vec magnitudes;
  PetscFunctionBeginUser;
  PetscCall(VecDuplicate(v, &magnitudes));
  PetscCall(VecCopy(v, magnitudes));
  PetscCall(VecAbs(magnitudes));
  PetscCall(VecMax(magnitudes, row, magnitude));
  PetscCall(VecDestroy(&magnitudes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The lowest global row of the matrix that is entirely zero and the lowest holding NaN or Inf
// (-1: none). A zero row is an unknown that nothing resists: no stiffness, no mass. Collective.
PetscErrorCode FirstZeroAndNonFiniteRows(Mat matrix, PetscInt *zero_row, PetscInt *non_finite_row)
{
  PetscInt first, last, local[2] = {PETSC_MAX_INT, PETSC_MAX_INT}, global[2];
  PetscFunctionBeginUser;
  PetscCall(MatGetOwnershipRange(matrix, &first, &last));
  for (PetscInt row = first; row < last; ++row) {
    const PetscScalar *values;
    PetscInt           count;
    bool               zero = true, finite = true;
    PetscCall(MatGetRow(matrix, row, &count, nullptr, &values));
    for (PetscInt k = 0; k < count; ++k) {
      const PetscReal value = PetscRealPart(values[k]);
      if (!std::isfinite(value)) finite = false;
      else if (value != 0.0) zero = false;
    }
    PetscCall(MatRestoreRow(matrix, row, &count, nullptr, &values));
    if (!finite) local[1] = std::min(local[1], row);
    else if (zero) local[0] = std::min(local[0], row);
  }
  PetscCall(MPIU_Allreduce(local, global, 2, MPIU_INT, MPI_MIN, PetscObjectComm((PetscObject)matrix)));
  *zero_row       = global[0] == PETSC_MAX_INT ? -1 : global[0];
  *non_finite_row = global[1] == PETSC_MAX_INT ? -1 : global[1];
  PetscFunctionReturn(PETSC_SUCCESS);
}

const char *NonFiniteWord(PetscBool has_nan) { return has_nan ? "NaN" : "Inf"; }

// Where a non-finite residual `residual` at increments `x` comes from: the model's trouble spot,
// else the first equation holding it. *has_nan: NaN rather than Inf.
PetscErrorCode DescribeNonFiniteResidual(NewtonContext *context, Vec x, Vec residual, std::string *where, PetscBool *has_nan)
{
  PetscInt row;
  PetscFunctionBeginUser;
  PetscCall(context->assembler->SetIncrements(x));
  PetscCall(context->assembler->DescribeNonFinite(where));
  PetscCall(FirstNonFiniteRow(residual, &row, has_nan));
  if (where->empty() && row >= 0) {
    std::string unknown;
    PetscCall(context->assembler->DescribeUnknown(row, &unknown));
    *where = "the equation of " + unknown;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// "element 12 (nodes 'a', 'b') cannot be evaluated: ..." at increments x (empty if every element can).
PetscErrorCode DescribeUnevaluableAt(NewtonContext *context, Vec x, std::string *where)
{
  PetscFunctionBeginUser;
  PetscCall(context->assembler->SetIncrements(x));
  PetscCall(context->assembler->DescribeUnevaluable(where));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Where the tangent assembled at increments x (null: unknown) is not finite: the model's trouble
// spot, else the first row of `tangent` holding NaN or Inf (empty when both are finite).
PetscErrorCode DescribeNonFiniteTangent(NewtonContext *context, Vec x, Mat tangent, std::string *where)
{
  PetscInt zero_row, non_finite_row;
  PetscFunctionBeginUser;
  where->clear();
  if (x) {
    PetscCall(context->assembler->SetIncrements(x));
    PetscCall(context->assembler->DescribeNonFinite(where));
    if (!where->empty()) PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(FirstZeroAndNonFiniteRows(tangent, &zero_row, &non_finite_row));
  if (non_finite_row >= 0) {
    std::string unknown;
    PetscCall(context->assembler->DescribeUnknown(non_finite_row, &unknown));
    *where = "the row of " + unknown;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

const char *const kHalfTurn = "its nodes turn by nearly pi relative to each other";
// Growth of |R| in one Newton iteration beyond which the tangent must be nearly singular.
constexpr double  kAbsurdGrowth = 1e12;
const char *const kSingularHint = "is part of the model a mechanism free to move, or has a node neither stiffness nor mass in some direction?";

// The factorisation's own account of a failed preconditioner set-up (MUMPS INFOG, zero pivot).
PetscErrorCode DescribeFactorFailure(PC pc, std::string *detail, MatFactorError *error)
{
  PetscBool is_factor;
  PetscFunctionBeginUser;
  *error = MAT_FACTOR_NOERROR;
  detail->clear();
  bool dense_lu, block_lu;
  PetscCall(DenseLUDescribeFailure(pc, &dense_lu, detail));
  if (!dense_lu) PetscCall(BlockLUDescribeFailure(pc, &block_lu, detail));
  if (dense_lu || block_lu) {
    if (!detail->empty()) *error = MAT_FACTOR_NUMERIC_ZEROPIVOT;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &is_factor, PCLU, PCCHOLESKY, PCILU, PCICC, ""));
  if (!is_factor) PetscFunctionReturn(PETSC_SUCCESS);
  MatSolverType solver;
  Mat           factor;
  PCType        pc_type;
  PetscCall(PCGetType(pc, &pc_type));
  PetscCall(PCFactorGetMatSolverType(pc, &solver));
  PetscCall(PCFactorGetMatrix(pc, &factor));
  MatFactorError local_error;
  PetscCall(MatFactorGetError(factor, &local_error));
  int local = (int)local_error, global;
  PetscCall(MPIU_Allreduce(&local, &global, 1, MPI_INT, MPI_MAX, PetscObjectComm((PetscObject)pc)));
  *error             = (MatFactorError)global;
  PetscBool is_mumps = PETSC_FALSE;
  if (solver) PetscCall(PetscStrcmp(solver, MATSOLVERMUMPS, &is_mumps));
#if defined(PETSC_HAVE_MUMPS)
  if (is_mumps) {
    PetscInt infog1, infog2;
    PetscCall(MatMumpsGetInfog(factor, 1, &infog1));
    PetscCall(MatMumpsGetInfog(factor, 2, &infog2));
    *detail = Format("MUMPS INFOG(1) = %" PetscInt_FMT ", INFOG(2) = %" PetscInt_FMT, infog1, infog2);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
#endif
  // PETSc's own factorisations know the zero pivot; its row is in the factor's reordered
  // numbering, so it names no unknown.
  if (*error == MAT_FACTOR_NUMERIC_ZEROPIVOT || *error == MAT_FACTOR_STRUCT_ZEROPIVOT) {
    PetscReal pivot = 0.0;
    PetscInt  pivot_row;
    if (local_error != MAT_FACTOR_NOERROR) PetscCall(MatFactorGetErrorZeroPivot(factor, &pivot, &pivot_row));
    PetscReal largest;
    PetscCall(MPIU_Allreduce(&pivot, &largest, 1, MPIU_REAL, MPI_MAX, PetscObjectComm((PetscObject)pc)));
    *detail = Format("zero pivot %.3g in the %s factorisation by %s", (double)largest, pc_type, solver ? solver : "petsc");
  } else {
    *detail = Format("the %s factorisation by %s %s", pc_type, solver ? solver : "petsc", *error == MAT_FACTOR_OUTMEMORY ? "ran out of memory" : "failed");
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode DescribeLinearSolveFailure(SNES snes, NewtonContext *context, Vec x, std::string *why)
{
  KSP                ksp;
  PC                 pc;
  Mat                preconditioner;
  KSPConvergedReason ksp_reason;
  PCFailedReason     local_pc_reason;
  PetscInt           zero_row, non_finite_row, ksp_iterations;
  PetscFunctionBeginUser;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(KSPGetOperators(ksp, nullptr, &preconditioner));
  PetscCall(KSPGetConvergedReason(ksp, &ksp_reason));
  PetscCall(KSPGetIterationNumber(ksp, &ksp_iterations));
  PetscCall(PCGetFailedReasonRank(pc, &local_pc_reason));
  int local = (int)local_pc_reason, pc_reason;
  PetscCall(MPIU_Allreduce(&local, &pc_reason, 1, MPI_INT, MPI_MAX, context->comm));
  PetscCall(FirstZeroAndNonFiniteRows(preconditioner, &zero_row, &non_finite_row));
  if (non_finite_row >= 0 || ksp_reason == KSP_DIVERGED_NANORINF) {
    std::string where;
    PetscCall(DescribeNonFiniteTangent(context, x, preconditioner, &where));
    *why = where.empty() ? std::string("the linear solver met NaN or Inf though the residual and tangent are finite") : "the tangent is not finite at " + where;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  std::string    detail;
  MatFactorError factor_error = MAT_FACTOR_NOERROR;
  if (pc_reason != PC_NOERROR) PetscCall(DescribeFactorFailure(pc, &detail, &factor_error));
  const bool singular = pc_reason == PC_FACTOR_STRUCT_ZEROPIVOT || pc_reason == PC_FACTOR_NUMERIC_ZEROPIVOT || factor_error == MAT_FACTOR_STRUCT_ZEROPIVOT ||
                        factor_error == MAT_FACTOR_NUMERIC_ZEROPIVOT;
  if (detail.empty() && pc_reason != PC_NOERROR) detail = Format("%s", PCFailedReasons[pc_reason]);
  if (singular || zero_row >= 0) {
    *why = "the tangent is singular" + (detail.empty() ? std::string() : " (" + detail + ")");
    if (zero_row >= 0) {
      std::string unknown;
      PetscCall(context->assembler->DescribeUnknown(zero_row, &unknown));
      // In statics (a static stage, a preload) mass does not resist: the node may well carry a body.
      const bool statics = context->assembler->Equations().problem == StepProblem::Statics;
      *why += ": nothing resists " + unknown + (statics ? " (no stiffness: in statics its mass, if any, does not resist)" : " (neither stiffness nor mass)");
    } else {
      *why += std::string(": ") + kSingularHint;
    }
  } else if (pc_reason == PC_FACTOR_OUTMEMORY || factor_error == MAT_FACTOR_OUTMEMORY) {
    *why = "the factorisation of the tangent ran out of memory (" + detail + ")";
  } else if (pc_reason != PC_NOERROR) {
    *why = "the preconditioner failed (" + detail + ")";
  } else {
    *why = Format("the linear solver did not converge (%s after %" PetscInt_FMT " iterations)", KSPConvergedReasons[ksp_reason], ksp_iterations);
    // Multigrid's smoothers and coarse spaces are made for the nodes' unknowns; joint coordinates,
    // above all chains of them at one point, can defeat it (a user trial: 8 revolute joints at a
    // beam's root, DIVERGED_BREAKDOWN with and without relays). The direct solver has no such limit.
    if (context->multigrid && context->assembler->Map().global_count.joints > 0)
      *why += "; the model has joints, whose coordinates multigrid may not handle: try -analysis_linear_solver direct";
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// A Newton update holding NaN or Inf (first at `row`): the tangent made it (assembled at x; null:
// at an earlier iterate), or the linear solver did without saying so.
PetscErrorCode DescribeNonFiniteUpdate(SNES snes, NewtonContext *context, Vec x, PetscInt row, PetscBool has_nan, std::string *why)
{
  KSP         ksp;
  Mat         preconditioner;
  std::string where;
  PetscFunctionBeginUser;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetOperators(ksp, nullptr, &preconditioner));
  PetscCall(DescribeNonFiniteTangent(context, x, preconditioner, &where));
  if (!where.empty()) *why = Format("the Newton update is %s: the tangent is not finite at ", NonFiniteWord(has_nan)) + where;
  else {
    std::string unknown;
    PetscCall(context->assembler->DescribeUnknown(row, &unknown));
    *why = Format("the Newton update is %s at %s though the tangent is finite: the tangent is singular and the linear solver did not say so; ",
                  NonFiniteWord(has_nan), unknown.c_str()) +
           kSingularHint;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// No acceptable step along a Newton update from x whose residual is finite: the update is not
// finite, or a step along it cannot be evaluated or gives NaN or Inf.
PetscErrorCode DescribeFailedStep(SNES snes, NewtonContext *context, Vec x, Vec update, std::string *why)
{
  SNESLineSearch linesearch;
  PetscReal      update_norm;
  PetscInt       row;
  PetscBool      has_nan;
  std::string    where;
  PetscFunctionBeginUser;
  PetscCall(FirstNonFiniteRow(update, &row, &has_nan));
  if (row >= 0) {
    PetscCall(DescribeNonFiniteUpdate(snes, context, x, row, has_nan, why));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecNorm(update, NORM_2, &update_norm));
  if (context->line_search_trouble != NewtonContext::StepTrouble::None) {
    // The msflex line search: its w and g hold the shortest step it tried and that step's residual.
    Vec        unused_x, unused_f, unused_y, trial, trial_residual;
    const long shortening = std::lround(1.0 / context->line_search_last_lambda);
    PetscCall(SNESGetLineSearch(snes, &linesearch));
    PetscCall(SNESLineSearchGetVecs(linesearch, &unused_x, &unused_f, &unused_y, &trial, &trial_residual));
    if (context->line_search_trouble == NewtonContext::StepTrouble::Unevaluable) {
      PetscCall(DescribeUnevaluableAt(context, trial, &where));
      *why = Format("the Newton update (norm %.3e) cannot be applied even shortened to 1/%ld: ", (double)update_norm, shortening) +
             (where.empty() ? std::string("an element") : where) + ": " + kHalfTurn;
    } else {
      PetscCall(DescribeNonFiniteResidual(context, trial, trial_residual, &where, &has_nan));
      *why =
          Format("after the Newton update (norm %.3e), even shortened to 1/%ld, the residual is %s", (double)update_norm, shortening, NonFiniteWord(has_nan)) +
          (where.empty() ? std::string() : " at " + where);
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // Another line search (-snes_linesearch_type): look at the full step.
  Vec trial, trial_residual;
  PetscCall(VecDuplicate(x, &trial));
  PetscCall(VecDuplicate(x, &trial_residual));
  PetscCall(VecWAXPY(trial, -1.0, update, x));
  PetscCall(DescribeUnevaluableAt(context, trial, &where));
  if (!where.empty()) *why = Format("the Newton update (norm %.3e) cannot be applied: ", (double)update_norm) + where + ": " + kHalfTurn;
  else {
    PetscBool geometry_ok;
    PetscCall(context->assembler->AssembleResidual(trial_residual, &geometry_ok));
    PetscCall(FirstNonFiniteRow(trial_residual, &row, &has_nan));
    if (row >= 0) {
      PetscCall(DescribeNonFiniteResidual(context, trial, trial_residual, &where, &has_nan));
      *why = Format("after the full Newton update (norm %.3e) the residual is %s at ", (double)update_norm, NonFiniteWord(has_nan)) + where;
    } else {
      *why = Format("the line search found no acceptable step along the Newton update (norm %.3e)", (double)update_norm);
    }
  }
  PetscCall(VecDestroy(&trial_residual));
  PetscCall(VecDestroy(&trial));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The residual is NaN or Inf: at x itself, or (with other line searches, which reject the step but
// report its norm) beyond x along the update.
PetscErrorCode DescribeNonFiniteNorm(SNES snes, NewtonContext *context, Vec x, Vec update, Vec residual, std::string *why)
{
  PetscInt    row, update_row     = -1, linear_iterations;
  PetscBool   has_nan, update_nan = PETSC_FALSE;
  std::string where;
  PetscFunctionBeginUser;
  PetscCall(FirstNonFiniteRow(residual, &row, &has_nan));
  if (row < 0) {
    // Every entry finite, yet the norm is not: the entries are so large that their squares overflow.
    PetscReal norm, largest;
    PetscInt  largest_row;
    PetscCall(VecNorm(residual, NORM_2, &norm));
    if (!std::isfinite((double)norm)) {
      PetscCall(LargestEntry(residual, &largest_row, &largest));
      PetscCall(context->assembler->DescribeUnknown(largest_row, &where));
      *why = Format("the residual norm overflows: its entries reach %.3e, the largest at ", (double)largest) + where +
             " (loads or motions beyond the range of double precision)";
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(DescribeFailedStep(snes, context, x, update, why));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(DescribeNonFiniteResidual(context, x, residual, &where, &has_nan));
  *why = Format("the residual is %s", NonFiniteWord(has_nan)) + (where.empty() ? std::string() : " at " + where);
  // An update of this solve (a linear solve counted) that is not finite is where x got its NaN.
  PetscCall(SNESGetLinearSolveIterations(snes, &linear_iterations));
  if (linear_iterations > 0) PetscCall(FirstNonFiniteRow(update, &update_row, &update_nan));
  if (update_row >= 0) {
    std::string update_why;
    PetscCall(DescribeNonFiniteUpdate(snes, context, nullptr, update_row, update_nan, &update_why));
    *why += "; " + update_why;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Residual norms of the solve, what convergence needed and where the residual is largest.
PetscErrorCode DescribeDivergence(SNES snes, NewtonContext *context, SNESConvergedReason reason, std::string *why)
{
  PetscReal *norms, atol, rtol, stol, largest;
  PetscInt  *linear_iterations, num_norms, iterations, max_iterations, max_evaluations, row;
  Vec        residual;
  double     force_scale;
  PetscFunctionBeginUser;
  PetscCall(SNESGetConvergenceHistory(snes, &norms, &linear_iterations, &num_norms));
  PetscCall(SNESGetIterationNumber(snes, &iterations));
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations));
  PetscCall(SNESGetFunction(snes, &residual, nullptr, nullptr));
  PetscCall(context->assembler->ForceScale(&force_scale));
  PetscCall(LargestEntry(residual, &row, &largest));
  std::string unknown;
  PetscCall(context->assembler->DescribeUnknown(row, &unknown));
  const double first = num_norms > 0 ? norms[0] : NAN, last = num_norms > 0 ? norms[num_norms - 1] : NAN;
  // The test of ForceScaledConvergenceTest, as a threshold.
  const double needed = std::max({(double)atol, rtol * first, rtol * force_scale, context->assembler->RoundoffForceLevel()});
  switch (reason) {
  case SNES_DIVERGED_MAX_IT:
    *why = Format("Newton did not converge in %" PetscInt_FMT " iteration%s", iterations, iterations == 1 ? "" : "s");
    break;
  case SNES_DIVERGED_DTOL:
    *why = Format("the residual diverged in %" PetscInt_FMT " Newton iteration%s", iterations, iterations == 1 ? "" : "s");
    break;
  case SNES_DIVERGED_FUNCTION_COUNT:
    *why = Format("Newton reached the limit of %" PetscInt_FMT " residual evaluations in %" PetscInt_FMT " iterations", max_evaluations, iterations);
    break;
  default:
    *why = Format("Newton failed after %" PetscInt_FMT " iteration%s", iterations, iterations == 1 ? "" : "s");
  }
  *why += Format(": |R| = %.3e at the start of the step, %.3e after the last iteration (convergence needs %.3e); the largest residual, %.3e, is at %s", first,
                 last, needed, (double)largest, unknown.c_str());
  // A factorisation of a singular tangent may not fail: its round-off pivots make absurd updates,
  // which even large-rotation steps (a few orders of magnitude) do not approach.
  int    jump_iteration = 0;
  double jump           = 1.0;
  for (PetscInt i = 1; i < num_norms; ++i)
    if (norms[i - 1] > 0.0 && norms[i] / norms[i - 1] > jump) jump = norms[i] / norms[i - 1], jump_iteration = (int)i;
  if (jump > kAbsurdGrowth) *why += Format("; |R| grew %.1e-fold in iteration %d, so the tangent is nearly singular: ", jump, jump_iteration) + kSingularHint;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode NewtonDescribeFailure(SNES snes, NewtonContext *context, std::string *why)
{
  SNESConvergedReason reason;
  PetscInt            iterations;
  Vec                 x, update, residual;
  std::string         where;
  PetscFunctionBeginUser;
  PetscCall(SNESGetConvergedReason(snes, &reason));
  PetscCall(SNESGetIterationNumber(snes, &iterations));
  PetscCall(SNESGetSolution(snes, &x));
  PetscCall(SNESGetSolutionUpdate(snes, &update));
  PetscCall(SNESGetFunction(snes, &residual, nullptr, nullptr));
  switch (reason) {
  case SNES_CONVERGED_FNORM_ABS:
  case SNES_CONVERGED_FNORM_RELATIVE:
  case SNES_CONVERGED_SNORM_RELATIVE:
  case SNES_CONVERGED_ITS:
    *why = Format("Newton converged in %" PetscInt_FMT " iteration%s", iterations, iterations == 1 ? "" : "s");
    break;
  case SNES_DIVERGED_FNORM_NAN:
    PetscCall(DescribeNonFiniteNorm(snes, context, x, update, residual, why));
    break;
  case SNES_DIVERGED_FUNCTION_DOMAIN:
  case SNES_DIVERGED_JACOBIAN_DOMAIN:
    PetscCall(DescribeUnevaluableAt(context, x, &where));
    *why = (where.empty() ? std::string("an element") : where) + " cannot be evaluated: " + kHalfTurn +
           (iterations == 0 ? " at the start of the step (the predicted or prescribed increments)" : "");
    break;
  case SNES_DIVERGED_LINE_SEARCH:
  case SNES_DIVERGED_LOCAL_MIN:
    PetscCall(DescribeFailedStep(snes, context, x, update, why));
    break;
  case SNES_DIVERGED_LINEAR_SOLVE:
    PetscCall(DescribeLinearSolveFailure(snes, context, x, why));
    break;
  default:
    PetscCall(DescribeDivergence(snes, context, reason, why));
  }
  *why += Format(" (SNES: %s)", SNESConvergedReasons[reason]);
  // Back to where SNESSolve ended.
  PetscCall(context->assembler->SetIncrements(x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode NewtonUsePivotingLU(SNES snes, NewtonContext *context, bool *switched)
{
  KSP ksp;
  PC  pc;
  PetscFunctionBeginUser;
  *switched = context->banded_lu_by_structure;
  if (!*switched) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(NewtonForgetFactorization(snes, context));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCUseMumps(pc)); // Newton gives it the operators again at its next iteration
  context->banded_lu_by_structure = false;
  context->pivoting_lu_forced     = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode NewtonUseBandedLUAgain(SNES snes, NewtonContext *context)
{
  KSP ksp;
  PC  pc;
  PetscFunctionBeginUser;
  PetscCall(NewtonForgetFactorization(snes, context));
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  // As NewtonSolverCreate chose it (a banded structure, no option naming the PC or its package),
  // with the options of the factorisation read again.
  PetscCall(ChooseDirectSolver(true, context->assembler->Jacobian(), pc));
  PetscCall(PCSetFromOptions(pc));
  PetscCall(BandedLUByStructure(pc, &context->banded_lu_by_structure));
  context->pivoting_lu_forced = false;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode NewtonForgetFactorization(SNES snes, NewtonContext *context)
{
  KSP ksp;
  PC  pc;
  PetscFunctionBeginUser;
  context->tangent_factored = false;
  context->last_contracted  = false;
  PetscCall(SNESGetKSP(snes, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCReset(pc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
