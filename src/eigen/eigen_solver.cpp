#include "eigen/eigen_solver.hpp"
#include "core/errors.hpp"
#include "core/stop_signal.hpp"

#include <slepceps.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>

namespace msflex {

namespace {

// Relative residual tolerance of the eigenpairs: the eigenvalues of a symmetric pencil are then
// accurate to about its square.
constexpr double kTolerance = 1e-12;
// A mode is rigid when |lambda| is below this many times its round-off estimate eps max_i K_ii
// |phi|^2 (EigenPairs::zero_levels). Measured |lambda| / estimate of the rigid modes of a free
// frame, a free beam, a free chain of joints and a hinged beam: 3e-8 to 0.32; of their elastic
// modes 5.5e4 and more, 700 for a portal frame preloaded to 99 % of its buckling load (EA/EI =
// 1e8), which 1e3 took for rigid, and between 3 and 30 for the first bending mode of a hinged beam
// of 8000 and 16,000 quadratic elements (assembly rounding moves its eigenvalue by 20 and 58 of
// 7727), which 30 took for rigid.
constexpr double kRigidRoundoffFactor = 3.0;
// A K singular to the last bit (a motion of no stiffness at all) is factored at the shift
// -kRoundoffShift eps ||K|| / ||M|| instead of 0: far enough below zero that the factorisation of
// K + |shift| M sees a pivot of the motion's mass, near enough that no eigenvalue which double
// precision resolves from zero moves (SolveModes).
constexpr double kRoundoffShift = 1e3;

// A factorisation of the ST's operator by MUMPS Cholesky (K - sigma M, or K), direct.
PetscErrorCode UseCholesky(EPS eps)
{
  ST  st;
  KSP ksp;
  PC  pc;
  PetscFunctionBeginUser;
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STGetKSP(st, &ksp));
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCCHOLESKY));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The factorisation package of the spectral transformation must exist (-st_pc_factor_mat_solver_type).
PetscErrorCode CheckFactorSolverAvailable(EPS eps, Mat matrix)
{
  ST  st;
  KSP ksp;
  PetscFunctionBeginUser;
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STGetKSP(st, &ksp));
  PetscCall(msflex::CheckFactorSolverAvailable(ksp, matrix));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The converged pairs (at most `count`), their backward errors and vectors, with value(theta).
template <class Value>
PetscErrorCode CollectPairs(EPS eps, Mat A, int count, Value value, bool keep_positive_only, EigenPairs *pairs, double positive_above = 0.0)
{
  PetscInt converged;
  PetscFunctionBeginUser;
  PetscCall(EPSGetConverged(eps, &converged));
  std::vector<double> values, errors;
  std::vector<Vec>    vectors;
  for (PetscInt i = 0; i < converged && (int)values.size() < count; ++i) {
    PetscScalar eigenvalue;
    PetscReal   error;
    Vec         x;
    PetscCall(EPSGetEigenvalue(eps, i, &eigenvalue, nullptr));
    if (keep_positive_only && !(PetscRealPart(eigenvalue) > positive_above)) continue;
    PetscCall(MatCreateVecs(A, &x, nullptr));
    PetscCall(EPSGetEigenvector(eps, i, x, nullptr));
    PetscCall(EPSComputeError(eps, i, EPS_ERROR_BACKWARD, &error));
    values.push_back(value(PetscRealPart(eigenvalue)));
    errors.push_back(error);
    vectors.push_back(x);
  }
  std::vector<size_t> order(values.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return values[a] < values[b]; });
  for (size_t k : order) {
    pairs->values.push_back(values[k]);
    pairs->backward_errors.push_back(errors[k]);
    pairs->vectors.push_back(vectors[k]);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// SLEPc's own test, and a stop on a stop signal (SIGTERM, ... on any rank): the solve then ends
// with the pairs converged so far (EPS_CONVERGED_USER), which the analysis writes before it stops
// (a modal analysis of a large model ran on to the end through a scheduler's warning signal).
PetscErrorCode StopOnSignal(EPS eps, PetscInt its, PetscInt max_it, PetscInt nconv, PetscInt nev, EPSConvergedReason *reason, void *context)
{
  PetscFunctionBeginUser;
  PetscCall(EPSStoppingBasic(eps, its, max_it, nconv, nev, reason, context));
  if (*reason != EPS_CONVERGED_ITERATING) PetscFunctionReturn(PETSC_SUCCESS);
  const int mine = StopSignalReceived();
  int       any;
  PetscCallMPI(MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, PetscObjectComm((PetscObject)eps)));
  if (any) *reason = EPS_CONVERGED_USER;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Whether the solve ended on StopOnSignal, into pairs->stopped_by_signal.
void NoteStop(EPS eps, EigenPairs *pairs)
{
  EPSConvergedReason reason;
  if (EPSGetConvergedReason(eps, &reason) == PETSC_SUCCESS && reason == EPS_CONVERGED_USER) pairs->stopped_by_signal = true;
}

// EPSDestroy after a failed solve: SLEPc may refuse, its work space still taken (-st_type cayley
// did); nothing of the solver is used any more, so that refusal is no error.
PetscErrorCode DestroyAfterFailure(EPS *eps)
{
  PetscFunctionBeginUser;
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  (void)EPSDestroy(eps);
  PetscCall(PetscPopErrorHandler());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// SLEPc's backward error ||K x - lambda M x|| / ((||K|| + |lambda| ||M||) ||x||) measures a mode
// below the shift's magnitude against nothing but K: of a rigid mode of a model with little or no
// stiffness (a mechanism of rigid bodies) it is O(1), or 0/0. There |lambda| is replaced by the
// shift's, the scale at which the solve resolves eigenvalues: the same as SLEPc's for every mode
// with |lambda| >= |shift|, as the elastic modes are.
PetscErrorCode RigidModeErrors(Mat K, Mat M, EigenPairs *pairs)
{
  const double scale = std::abs(pairs->shift);
  PetscReal    norm_K, norm_M;
  Vec          residual = nullptr, mass_times = nullptr;
  PetscFunctionBeginUser;
  for (size_t k = 0; k < pairs->values.size(); ++k) {
    const double lambda = pairs->values[k];
    if (std::abs(lambda) >= scale && std::isfinite(pairs->backward_errors[k])) continue;
    if (!residual) {
      PetscCall(MatNorm(K, NORM_INFINITY, &norm_K));
      PetscCall(MatNorm(M, NORM_INFINITY, &norm_M));
      PetscCall(MatCreateVecs(K, &residual, &mass_times));
    }
    PetscReal residual_norm, length;
    PetscCall(MatMult(K, pairs->vectors[k], residual));
    PetscCall(MatMult(M, pairs->vectors[k], mass_times));
    PetscCall(VecAXPY(residual, -lambda, mass_times));
    PetscCall(VecNorm(residual, NORM_2, &residual_norm));
    PetscCall(VecNorm(pairs->vectors[k], NORM_2, &length));
    const double denominator  = (norm_K + std::max(std::abs(lambda), scale) * norm_M) * length;
    pairs->backward_errors[k] = denominator > 0 ? residual_norm / denominator : 0.0;
  }
  PetscCall(VecDestroy(&residual));
  PetscCall(VecDestroy(&mass_times));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// One shift-and-invert solve of K phi = lambda M phi about sigma. *failed (when not null): the
// solve raised an error (a singular K - sigma M), which is then no error of the caller.
PetscErrorCode SolveModesAt(Mat K, Mat M, int count, double sigma, EigenPairs *pairs, bool *failed)
{
  EPS eps;
  ST  st;
  PetscFunctionBeginUser;
  PetscCall(EigenPairsDestroy(pairs));
  PetscCall(EPSCreate(PetscObjectComm((PetscObject)K), &eps));
  PetscCall(EPSSetOperators(eps, K, M));
  PetscCall(EPSSetProblemType(eps, EPS_GHEP));
  PetscCall(EPSSetDimensions(eps, count, PETSC_DEFAULT, PETSC_DEFAULT));
  PetscCall(EPSSetTolerances(eps, kTolerance, PETSC_DEFAULT));
  PetscCall(EPSSetTarget(eps, sigma));
  PetscCall(EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE));
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STSetType(st, STSINVERT));
  PetscCall(UseCholesky(eps));
  MSFLEX_CALL_READING_OPTIONS(PetscObjectComm((PetscObject)eps), EPSSetFromOptions(eps));
  PetscCall(EPSSetStoppingTestFunction(eps, StopOnSignal, nullptr, nullptr));
  PetscCall(CheckFactorSolverAvailable(eps, K));
  PetscErrorCode code = PETSC_SUCCESS;
  if (failed) {
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
    code = EPSSolve(eps);
    PetscCall(PetscPopErrorHandler());
    int mine = code != PETSC_SUCCESS, any;
    PetscCallMPI(MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, PetscObjectComm((PetscObject)K)));
    *failed = any != 0;
  } else {
    // A factorisation that fails here (K - sigma M singular, or M itself with -st_type shift on a
    // model with massless motions) is the user's choice of shift, not an internal error: one line.
    std::string captured_error; // what the one-line report of a failed solve quotes
    PetscCall(PetscPushErrorHandler(CaptureFirstErrorMessage, &captured_error));
    const PetscErrorCode code = EPSSolve(eps);
    PetscCall(PetscPopErrorHandler());
    int mine = code != PETSC_SUCCESS, any;
    PetscCallMPI(MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, PetscObjectComm((PetscObject)K)));
    if (any) {
      STType type;
      PetscCall(STGetType(st, &type));
      const std::string st_type = type ? type : "?"; // the name lives in the ST, destroyed next
      const std::string why     = captured_error.empty() ? "on another rank" : captured_error;
      PetscCall(DestroyAfterFailure(&eps));
      // A factorisation that failed: the matrix is singular there. Anything else SLEPc refused
      // (a solver that does not support the problem or the transformation): its own words.
      const bool singular = why.find("ivot") != std::string::npos || why.find("ingular") != std::string::npos || why.find("MUMPS") != std::string::npos ||
                            why.find("INFOG") != std::string::npos || why.find("factor") != std::string::npos;
      if (singular)
        SETERRQ(PetscObjectComm((PetscObject)K), PETSC_ERR_NOT_CONVERGED,
                "the eigensolver failed at shift %.6g (spectral transformation %s): the matrix it factors is singular: K - shift M, as it is where "
                "the model can move freely (rigid-body modes) or at an eigenvalue, and at every shift where a motion has neither stiffness nor mass "
                "(a beam free to turn about its axis without rhoJ: give it rhoJ or restrain it), or M itself under -st_type shift, wherever a motion "
                "has no mass (rotations without rhoJ); keep msflex's shift-and-invert (no -st_type) or give an -eps_target (-analysis_shift) away from "
                "the eigenvalues, e.g. below zero",
                sigma, st_type.c_str());
      SETERRQ(PetscObjectComm((PetscObject)K), PETSC_ERR_NOT_CONVERGED,
              "the eigensolver failed at shift %.6g (spectral transformation %s): SLEPc: %s; msflex's default (no -st_type, -eps_type) is Krylov-Schur "
              "with shift-and-invert",
              sigma, st_type.c_str(), why.c_str());
    }
  }
  STType type;
  PetscCall(STGetType(st, &type));
  pairs->transformation = type ? type : "?";
  if (!failed || !*failed) {
    PetscScalar target;
    PetscCall(EPSGetTarget(eps, &target));
    pairs->shift = PetscRealPart(target);
    PetscCall(CollectPairs(
        eps, K, count, [](double theta) { return theta; }, false, pairs));
    PetscCall(RigidModeErrors(K, M, pairs));
    NoteStop(eps, pairs);
  }
  ++pairs->solves;
  if (failed && *failed) {
    PetscCall(DestroyAfterFailure(&eps));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // The last solve must deliver what was asked for: a transformation or solver chosen by option
  // that does not converge (-st_type shift finds the eigenvalues nearest the target slowly, if at
  // all) ends the run with one line, not with fewer modes or none.
  if (!failed && (int)pairs->values.size() < count && !pairs->stopped_by_signal) {
    EPSConvergedReason reason;
    PetscInt           iterations;
    PetscCall(EPSGetConvergedReason(eps, &reason));
    PetscCall(EPSGetIterationNumber(eps, &iterations));
    // A Krylov space that ends (breakdown) after some modes has found every finite eigenvalue:
    // M reaches no more motions (massless rotations), the others are infinite. The caller says so.
    pairs->ran_out = reason == EPS_DIVERGED_BREAKDOWN && !pairs->values.empty();
    if (pairs->ran_out) {
      PetscCall(EPSDestroy(&eps));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    const std::string transformation = pairs->transformation;
    const int         found          = (int)pairs->values.size();
    PetscCall(EPSDestroy(&eps));
    SETERRQ(PetscObjectComm((PetscObject)K), PETSC_ERR_NOT_CONVERGED,
            "the eigensolver found %d of the %d modes asked for (%s after %" PetscInt_FMT " iterations, spectral transformation %s at %.6g); msflex's "
            "default (no -st_type, -eps_type) is shift-and-invert, which finds the modes nearest the shift in a few iterations",
            found, count, EPSConvergedReasons[reason], iterations, transformation.c_str(), pairs->shift);
  }
  PetscCall(EPSDestroy(&eps));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// min over the DOFs with mass of K_ii / M_ii: the Rayleigh quotient of a unit vector, an upper
// bound of the lowest eigenvalue. Collective.
PetscErrorCode DiagonalRatio(Mat K, Mat M, double *ratio)
{
  Vec                k, m;
  const PetscScalar *kv, *mv;
  PetscInt           n;
  double             local = INFINITY;
  PetscFunctionBeginUser;
  PetscCall(MatCreateVecs(K, &k, &m));
  PetscCall(MatGetDiagonal(K, k));
  PetscCall(MatGetDiagonal(M, m));
  PetscCall(VecGetLocalSize(k, &n));
  PetscCall(VecGetArrayRead(k, &kv));
  PetscCall(VecGetArrayRead(m, &mv));
  for (PetscInt i = 0; i < n; ++i)
    if (PetscRealPart(mv[i]) > 0 && PetscRealPart(kv[i]) > 0) {
      const double r = PetscRealPart(kv[i]) / PetscRealPart(mv[i]);
      local          = std::min(local, r);
    }
  PetscCall(VecRestoreArrayRead(k, &kv));
  PetscCall(VecRestoreArrayRead(m, &mv));
  PetscCall(VecDestroy(&k));
  PetscCall(VecDestroy(&m));
  PetscCall(MPIU_Allreduce(&local, ratio, 1, MPI_DOUBLE, MPI_MIN, PetscObjectComm((PetscObject)K)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SolveModes(Mat K, Mat M, int count, double shift, EigenPairs *pairs);

// Per pair, its eigenvalue's own round-off, kRigidRoundoffFactor eps max_i |K_ii| |phi|^2: a
// backward-stable solve perturbs K by about eps ||K||, which moves lambda = phi^T K phi by
// eps ||K|| |phi|^2 (EigenPairs::zero_levels). Collective.
PetscErrorCode RoundoffLevels(Mat K, const EigenPairs &pairs, std::vector<double> *levels)
{
  Vec       diagonal;
  PetscReal largest_diagonal;
  PetscFunctionBeginUser;
  PetscCall(MatCreateVecs(K, &diagonal, nullptr));
  PetscCall(MatGetDiagonal(K, diagonal));
  PetscCall(VecNorm(diagonal, NORM_INFINITY, &largest_diagonal));
  PetscCall(VecDestroy(&diagonal));
  levels->clear();
  for (Vec phi : pairs.vectors) {
    PetscReal length;
    PetscCall(VecNorm(phi, NORM_2, &length));
    levels->push_back(kRigidRoundoffFactor * std::numeric_limits<double>::epsilon() * largest_diagonal * length * length);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode EigenInitialize()
{
  PetscBool initialized;
  PetscFunctionBeginUser;
  PetscCall(SlepcInitialized(&initialized));
  if (!initialized) PetscCall(SlepcInitializeNoArguments());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode EigenFinalize()
{
  PetscBool initialized;
  PetscFunctionBeginUser;
  PetscCall(SlepcInitialized(&initialized));
  if (initialized) PetscCall(SlepcFinalize());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckEigenOptions(MPI_Comm comm)
{
  static const char *const prefixes[] = {"-eps_", "-st_", "-bv_", "-ds_", "-rg_", "-fn_"};
  PetscInt                 count;
  char                   **names, **values;
  bool                     any = false;
  PetscFunctionBeginUser;
  // Only the options nothing has read yet can be eigensolver options (the same on every rank).
  PetscCall(PetscOptionsLeftGet(nullptr, &count, &names, &values));
  for (PetscInt i = 0; i < count && !any; ++i)
    for (const char *prefix : prefixes)
      if (std::strncmp(names[i], prefix + 1, std::strlen(prefix) - 1) == 0) any = true;
  PetscCall(PetscOptionsLeftRestore(nullptr, &count, &names, &values));
  if (!any) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(EigenInitialize());
  EPS eps;
  ST  st;
  PetscCall(EPSCreate(comm, &eps));
  PetscCall(EPSSetProblemType(eps, EPS_GHEP));
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STSetType(st, STSINVERT));
  PetscCall(UseCholesky(eps));
  MSFLEX_CALL_READING_OPTIONS(comm, EPSSetFromOptions(eps));
  // The factorisation package too, for the AIJ matrices the eigenanalyses factor (ConvertForCholesky).
  PetscMPIInt rank;
  Mat         probe;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(MatCreateAIJ(comm, rank == 0 ? 1 : 0, rank == 0 ? 1 : 0, 1, 1, 1, nullptr, 0, nullptr, &probe));
  const PetscErrorCode available = CheckFactorSolverAvailable(eps, probe);
  PetscCall(MatDestroy(&probe));
  PetscCall(EPSDestroy(&eps));
  PetscCall(available);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode EigenPairsDestroy(EigenPairs *pairs)
{
  PetscFunctionBeginUser;
  for (Vec &v : pairs->vectors) PetscCall(VecDestroy(&v));
  pairs->vectors.clear();
  pairs->values.clear();
  pairs->backward_errors.clear();
  pairs->stopped_by_signal = false;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode SolveVibrationModes(Mat K, Mat M, int count, double shift, EigenPairs *pairs)
{
  PetscFunctionBeginUser;
  PetscCall(SolveModes(K, M, count, shift, pairs));
  PetscCall(RoundoffLevels(K, *pairs, &pairs->zero_levels));
  for (double &level : pairs->zero_levels) level = std::max(1e-6 * std::abs(pairs->shift), level);
  PetscFunctionReturn(PETSC_SUCCESS);
}

namespace {

PetscErrorCode SolveModes(Mat K, Mat M, int count, double shift, EigenPairs *pairs)
{
  PetscBool target_option;
  PetscFunctionBeginUser;
  pairs->solves = 0;
  PetscCall(PetscOptionsHasName(nullptr, nullptr, "-eps_target", &target_option));
  if (std::isfinite(shift) || target_option) {
    PetscCall(SolveModesAt(K, M, count, std::isfinite(shift) ? shift : 0.0, pairs, nullptr));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // First at sigma = 0, which is the best shift unless K is singular.
  bool failed = false;
  PetscCall(SolveModesAt(K, M, count, 0.0, pairs, &failed));
  if (pairs->stopped_by_signal) PetscFunctionReturn(PETSC_SUCCESS);
  // A K singular to the last bit fails there: a motion with no stiffness at all (a free rigid body,
  // a wheel on a joint without a spring), which no round-off couples to anything stiff. A shift just
  // below zero at K's round-off level relative to M (kRoundoffShift eps ||K|| / ||M||) regularises
  // it without moving any eigenvalue that double precision resolves; with no stiffness at all
  // (||K|| = 0: every mode rigid) a unit shift does, every eigenvalue being 0.
  double roundoff_shift = 0.0;
  if (failed) {
    PetscReal norm_K, norm_M;
    PetscCall(MatNorm(K, NORM_INFINITY, &norm_K));
    PetscCall(MatNorm(M, NORM_INFINITY, &norm_M));
    PetscCheck(norm_M > 0, PetscObjectComm((PetscObject)K), PETSC_ERR_USER_INPUT,
               "no eigenvalue of the model could be estimated: does anything in it have mass?");
    roundoff_shift = norm_K > 0 ? -kRoundoffShift * std::numeric_limits<double>::epsilon() * norm_K / norm_M : -1.0;
    PetscCall(SolveModesAt(K, M, count, roundoff_shift, pairs, &failed));
    if (pairs->stopped_by_signal) PetscFunctionReturn(PETSC_SUCCESS);
  }
  double worst_error = 0.0;
  for (size_t k = 0; k < pairs->values.size(); ++k) worst_error = std::max(worst_error, pairs->backward_errors[k]);
  // Rigid: an eigenvalue at its own round-off, kRigidRoundoffFactor eps max_i |K_ii| |phi|^2 (as
  // SolveVibrationModes classifies them), or below the round-off shift. (1e-6 of the largest found
  // took a slow elastic mode for rigid: a spring-mass of omega^2 = 1e-4 beside one of 1e6, and the
  // second solve's shift, -1e-2 of the latter, then made it rigid for good.)
  std::vector<double> levels;
  PetscCall(RoundoffLevels(K, *pairs, &levels));
  double first_elastic = NAN;
  bool   rigid         = false;
  for (size_t k = 0; k < pairs->values.size(); ++k) {
    const double value = pairs->values[k];
    if (std::abs(value) <= std::max(levels[k], std::abs(roundoff_shift))) rigid = true;
    else if (std::isnan(first_elastic) && value > 0) first_elastic = value;
  }
  const bool complete = !failed && (int)pairs->values.size() == count && worst_error <= 1e-8;
  if (complete && !rigid) PetscFunctionReturn(PETSC_SUCCESS);
  // Every mode asked for rigid (a mechanism of rigid bodies with nothing to stiffen it): these are
  // the modes, found accurately at the shift just below zero.
  if (complete && std::isnan(first_elastic) && roundoff_shift != 0.0) PetscFunctionReturn(PETSC_SUCCESS);
  // Rigid modes, or a first solve that failed or is inaccurate: shift below zero by a hundredth of
  // the first elastic eigenvalue (or, without an estimate, of the lowest diagonal ratio).
  if (std::isnan(first_elastic)) PetscCall(DiagonalRatio(K, M, &first_elastic));
  PetscCheck(std::isfinite(first_elastic) && first_elastic > 0, PetscObjectComm((PetscObject)K), PETSC_ERR_USER_INPUT,
             "no eigenvalue of the model could be estimated: does anything in it have mass?");
  PetscCall(SolveModesAt(K, M, count, -1e-2 * first_elastic, pairs, nullptr));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode SolveBucklingModes(Mat K, Mat K_sigma, int count, EigenPairs *pairs)
{
  EPS eps;
  Mat minus_K_sigma;
  PetscFunctionBeginUser;
  PetscCall(EigenPairsDestroy(pairs));
  PetscCall(MatDuplicate(K_sigma, MAT_COPY_VALUES, &minus_K_sigma));
  PetscCall(MatScale(minus_K_sigma, -1.0));
  PetscCall(EPSCreate(PetscObjectComm((PetscObject)K), &eps));
  PetscCall(EPSSetOperators(eps, minus_K_sigma, K));
  PetscCall(EPSSetProblemType(eps, EPS_GHEP));
  PetscCall(EPSSetDimensions(eps, count, PETSC_DEFAULT, PETSC_DEFAULT));
  PetscCall(EPSSetTolerances(eps, kTolerance, PETSC_DEFAULT));
  PetscCall(EPSSetWhichEigenpairs(eps, EPS_LARGEST_REAL));
  PetscCall(UseCholesky(eps));
  MSFLEX_CALL_READING_OPTIONS(PetscObjectComm((PetscObject)eps), EPSSetFromOptions(eps));
  PetscCall(EPSSetStoppingTestFunction(eps, StopOnSignal, nullptr, nullptr));
  PetscCall(CheckFactorSolverAvailable(eps, K));
  PetscCall(EPSSolve(eps));
  NoteStop(eps, pairs);
  pairs->solves = 1;
  // nu at round-off is no buckling load: a K_sigma singular in some direction gives nu = 0 there,
  // computed as about eps ||K_sigma|| / ||K|| (a clamped column of two linear elements reported
  // "buckling loads" of 1.8e24); such nu are dropped with the negative ones.
  PetscReal norm_K, norm_K_sigma;
  PetscCall(MatNorm(K, NORM_INFINITY, &norm_K));
  PetscCall(MatNorm(K_sigma, NORM_INFINITY, &norm_K_sigma));
  const double roundoff = 1e3 * std::numeric_limits<double>::epsilon() * norm_K_sigma / norm_K;
  PetscCall(CollectPairs(
      eps, K, count, [](double nu) { return 1.0 / nu; }, true, pairs, roundoff));
  PetscCall(EPSDestroy(&eps));
  PetscCall(MatDestroy(&minus_K_sigma));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
