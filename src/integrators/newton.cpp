#include "integrators/newton.hpp"

#include <cmath>

namespace msflex {

namespace {

// Residual on every rank; false on every rank when any element could not be evaluated.
PetscErrorCode EvaluateResidual(NewtonContext *context, Vec increments, Vec residual, PetscBool *all_ok)
{
  PetscBool geometry_ok;
  PetscFunctionBeginUser;
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePush(context->assembly_stage));
  PetscCall(context->assembler->SetIncrements(increments));
  PetscCall(context->assembler->AssembleResidual(residual, &geometry_ok));
  PetscCall(MPIU_Allreduce(&geometry_ok, all_ok, 1, MPIU_BOOL, MPI_LAND, context->comm));
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePop());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode FormResidual(SNES snes, Vec increments, Vec residual, void *ctx)
{
  PetscBool all_ok;
  PetscFunctionBeginUser;
  PetscCall(EvaluateResidual(static_cast<NewtonContext *>(ctx), increments, residual, &all_ok));
  if (!all_ok) PetscCall(SNESSetFunctionDomainError(snes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode FormJacobian(SNES snes, Vec increments, Mat jacobian, Mat preconditioner, void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  PetscBool      geometry_ok, all_ok;
  PetscFunctionBeginUser;
  if (context->assembly_stage >= 0) PetscCall(PetscLogStagePush(context->assembly_stage));
  PetscCall(context->assembler->SetIncrements(increments));
  PetscCall(context->assembler->AssembleJacobian(preconditioner, &geometry_ok));
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
  PetscBool      evaluable = PETSC_FALSE;
  PetscFunctionBeginUser;
  PetscCall(SNESLineSearchGetVecs(linesearch, &x, &f, &y, &w, &g));
  for (int attempt = 0; attempt < 9 && !evaluable; ++attempt, lambda *= 0.5) {
    PetscCall(VecWAXPY(w, -lambda, y, x));
    PetscCall(EvaluateResidual(context, w, g, &evaluable));
    if (evaluable) {
      PetscCall(VecNorm(g, NORM_2, &fnorm));
      evaluable = std::isfinite(fnorm) ? PETSC_TRUE : PETSC_FALSE;
    }
    if (evaluable) break;
  }
  if (!evaluable) {
    PetscCall(SNESLineSearchSetReason(linesearch, SNES_LINESEARCH_FAILED_DOMAIN));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecCopy(w, x));
  PetscCall(VecCopy(g, f));
  PetscCall(VecNorm(x, NORM_2, &xnorm));
  PetscCall(VecNorm(y, NORM_2, &ynorm));
  PetscCall(SNESLineSearchSetLambda(linesearch, lambda));
  PetscCall(SNESLineSearchSetNorms(linesearch, xnorm, fnorm, lambda * ynorm));
  PetscCall(SNESLineSearchSetReason(linesearch, SNES_LINESEARCH_SUCCEEDED));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode ForceScaledConvergenceTest(SNES snes, PetscInt iteration, PetscReal xnorm, PetscReal step_norm, PetscReal fnorm, SNESConvergedReason *reason,
                                          void *ctx)
{
  NewtonContext *context = static_cast<NewtonContext *>(ctx);
  PetscFunctionBeginUser;
  PetscCall(SNESConvergedDefault(snes, iteration, xnorm, step_norm, fnorm, reason, nullptr));
  if (*reason != SNES_CONVERGED_ITERATING || iteration == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscReal atol, rtol, stol;
  PetscInt  max_iterations, max_evaluations;
  double    force_scale;
  PetscCall(SNESGetTolerances(snes, &atol, &rtol, &stol, &max_iterations, &max_evaluations));
  PetscCall(context->assembler->ForceScale(&force_scale));
  if (fnorm <= rtol * force_scale || fnorm <= context->assembler->RoundoffForceLevel()) *reason = SNES_CONVERGED_FNORM_RELATIVE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode NewtonSolverCreate(MPI_Comm comm, const AnalysisSettings &analysis, bool matrix_free_operator, NewtonContext *context, SNES *snes)
{
  KSP            ksp;
  PC             pc;
  SNESLineSearch linesearch;
  Vec            residual;
  PetscFunctionBeginUser;
  context->comm = comm;
  PetscCall(SNESCreate(comm, snes));
  PetscCall(SNESSetType(*snes, SNESNEWTONLS));
  PetscCall(VecDuplicate(context->assembler->SolutionTemplate(), &residual));
  PetscCall(SNESSetFunction(*snes, residual, FormResidual, context));
  PetscCall(VecDestroy(&residual));
  PetscCall(SNESSetJacobian(*snes, context->assembler->Jacobian(), context->assembler->Jacobian(), FormJacobian, context));
  // stol: a relative update below 1e-12 means the iterate is at round-off.
  PetscCall(SNESSetTolerances(*snes, analysis.newton_atol, analysis.newton_rtol, 1e-12, analysis.max_newton_iterations, PETSC_DEFAULT));
  // No divergence test on |R|: in a large-rotation beam step the first, correct iteration can
  // raise |R| by orders of magnitude; failure is detected by the iteration limit instead.
  PetscCall(SNESSetDivergenceTolerance(*snes, -1.0));
  PetscCall(SNESSetConvergenceTest(*snes, ForceScaledConvergenceTest, context, nullptr));
  PetscCall(SNESGetLineSearch(*snes, &linesearch));
  PetscCall(SNESLineSearchSetType(linesearch, SNESLINESEARCHSHELL));
  PetscCall(SNESLineSearchShellSetUserFunc(linesearch, SafeguardedNewtonStep, context));
  PetscCall(SNESGetKSP(*snes, &ksp));
  if (matrix_free_operator) {
    PetscCall(SNESSetUseMatrixFree(*snes, PETSC_TRUE, PETSC_FALSE));
    PetscCall(KSPSetType(ksp, KSPGMRES));
    PetscCall(KSPSetTolerances(ksp, 1e-10, PETSC_DEFAULT, PETSC_DEFAULT, 200));
    PetscCall(KSPGMRESSetRestart(ksp, 100));
  } else {
    PetscCall(KSPSetType(ksp, KSPPREONLY));
  }
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCLU));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscCall(SNESSetFromOptions(*snes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
