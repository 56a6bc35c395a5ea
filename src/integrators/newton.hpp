// Newton's method (PETSc SNES) on the step increments, shared by every analysis.
//
// Defaults, all changeable with -snes_*, -ksp_*, -pc_* options:
//  - newtonls with the msflex line search ("shell"): the full Newton step unless the new
//    configuration cannot be evaluated (an element's relative rotation reaches pi, or a NaN),
//    then the step is halved up to 8 times. The residual norm is a poor merit function for
//    rotation-dominated beams (it rises by orders of magnitude in the first, correct iteration
//    of a large-rotation step), so norm-decrease line searches (bt, l2) stall; they remain
//    available through -snes_linesearch_type.
//  - convergence when |R| <= rtol * max(|R_0|, |f|), with |f| the magnitude of the internal and
//    external forces (the norm of all element and load contributions before they cancel): the
//    relative test of PETSc measured against the force level as well, so a small load increment
//    on a heavily loaded structure does not ask for a residual below round-off; and when |R| is
//    below the round-off floor of the internal forces, eps sqrt(sum_e (100 |C|)^2 + (|C_N| R/h_e)^2)
//    (Assembler::RoundoffForceLevel: the stiffness, and the rounding of nodal coordinates of
//    magnitude R (the reference's or, when larger, the step's start's) over element lengths h_e,
//    which grows like N^1.5), so iterations per step do not
//    grow with the element count; in dynamics also 100 eps times the momenta over dt at the
//    start of the step (an inertial residual is their difference, and the predictor can leave
//    a step's first residual at their round-off). PETSc's step-size test (stol) stops Newton only while |R| is
//    within 1e4 of that threshold (far above it the updates are round-off of a singular tangent).
//  - The LU chosen by structure (analysis.direct_solver auto, the default): on one rank, a banded
//    LU in RCM order when the tangent is banded under RCM (mean squared row envelope <= 60^2:
//    chains, slender frames): msflex's block LU when the Assembler stores the tangent in 6x6 node
//    blocks (every unknown belongs to a node; core/block_envelope_pc.hpp), else PETSc's LU;
//    else MUMPS; a banded LU does not pivot between nodes, so a failed Newton solve is tried
//    again with MUMPS (NewtonUsePivotingLU): converged, MUMPS factors the rest of the run; failed
//    as well, the failure was no pivoting problem and the banded LU comes back
//    (NewtonUseBandedLUAgain) for the halved step.
//    direct_solver mumps: MUMPS always. A dense -jacobian_mat_type uses msflex's dense LU. The
//    symbolic factorisation is reused while the matrix pattern is unchanged.
//  - The tangent is exact in every scheme (assembly/assembler.hpp). In em it has a rank-one term
//    (beta of eq. 20 couples every element): the operator is a shell applying the assembled
//    tangent plus that term, and GMRES on the LU of the assembled tangent solves each Newton step
//    exactly in at most two iterations. -snes_mf_operator -ksp_type gmres gives the old
//    matrix-free operator (directional differences of the residual) for experiments.
#pragma once

#include "assembly/assembler.hpp"
#include "model/model.hpp"

#include <petscsnes.h>

#include <string>

namespace msflex {

struct NewtonContext {
  Assembler    *assembler      = nullptr;
  MPI_Comm      comm           = MPI_COMM_NULL;
  PetscLogStage assembly_stage = -1;    // pushed around residual and tangent assembly when registered
  bool          multigrid      = false; // analysis.linear_solver multigrid (failure messages)
  // Left by the msflex line search when not even the shortest step it tries could be evaluated
  // (for NewtonDescribeFailure): what went wrong there and that step's length.
  enum class StepTrouble { None, Unevaluable, NonFinite };
  StepTrouble line_search_trouble     = StepTrouble::None;
  double      line_search_last_lambda = 0.0;
  // em: K^{-1} a for the Sherman-Morrison solve of (K + a b^T) x = r, made once per tangent
  // (rank_one_solution_current is cleared whenever the tangent is assembled).
  Vec  rank_one_solution         = nullptr;
  bool rank_one_solution_current = false;
  // Modified Newton (AnalysisSettings::jacobian_reuse, theta): the factored tangent is kept for an
  // iteration when the last one reduced the residual by theta or more; at the first iteration of a
  // solve, when the previous solve's last iteration did and its tangent was of a step of the same
  // kind and length (tangent_step). 0: a new tangent every iteration.
  double    jacobian_reuse   = 0.0;
  bool      tangent_factored = false;                // the preconditioner holds the factorisation of tangent_step's tangent
  bool      last_contracted  = false;                // the last solve's last iteration contracted by theta
  double    tangent_step[4]  = {0.0, 0.0, 0.0, 0.0}; // problem, inertia coefficient, step length, load scale
  long long tangent_assembly = -1;                   // Assembler::MatrixAssemblies() after that tangent (no matrix assembled since)
  long long tangents_formed = 0, tangents_reused = 0;
  // The tangent assembled with the residual (Assembler::AssembleResidualWithJacobian): possible when
  // SNES is Newton with msflex's line search, a tangent at every iteration and the assembled matrix
  // as operator (NewtonSolverCreate decides, once, alike on every rank); tangent_ahead: the last
  // residual evaluation left the tangent of its iterate in the matrix, on every rank.
  bool tangent_with_residual = false;
  bool tangent_ahead         = false;
  // From FormJacobian until msflex's line search: residuals SNES evaluates in between (finite-
  // difference checks of the tangent) are assembled alone, so that the matrix stays the tangent.
  bool tangent_awaits_solve = false;
  // The factorisation is a banded LU (msflex's block LU or PETSc's) because the structure chose
  // it (not an option): it does not
  // pivot, so NewtonUsePivotingLU may replace it by MUMPS; pivoting_lu_forced once it has.
  bool banded_lu_by_structure = false;
  bool pivoting_lu_forced     = false;
};

// The Newton step's operator: the assembled tangent, or (em) the assembled tangent plus its
// rank-one term a b^T, solved exactly by Sherman-Morrison on the tangent's factorisation.
enum class NewtonOperator { Assembled, AssembledWithRankOne };

// Also keeps the residual norms of every solve (SNESGetConvergenceHistory).
PetscErrorCode NewtonSolverCreate(MPI_Comm comm, const AnalysisSettings &analysis, NewtonOperator newton_operator, NewtonContext *context, SNES *snes);

// After SNESSolve did not converge: why, in words, naming the step's trouble spot where it can be
// found (the element, node or joint where a NaN or Inf appears or whose geometry fails, the
// unknown of a singular tangent, the largest residual of a diverging solve), ending with the
// SNES reason. Collective. Call it before Assembler::DiscardStep: it leaves the assembler at the
// increments SNESSolve ended with.
PetscErrorCode NewtonDescribeFailure(SNES snes, NewtonContext *context, std::string *why);

// After a failed solve: the preconditioner starts afresh (a new symbolic factorisation) at the
// next solve. MUMPS skips the numeric factorisation of every later matrix once one has failed
// (INFOG(1) < 0) and then fails in the solve phase, so a retried step needs a new analysis.
// Modified Newton then forms a new tangent.
PetscErrorCode NewtonForgetFactorization(SNES snes, NewtonContext *context);

// When the structure chose a non-pivoting banded LU (NewtonContext::banded_lu_by_structure): MUMPS
// factors from now on, which pivots and accounts for a singular tangent (INFOG), until
// NewtonUseBandedLUAgain; *switched tells whether that happened now (false: MUMPS or a user's
// choice already). Collective.
PetscErrorCode NewtonUsePivotingLU(SNES snes, NewtonContext *context, bool *switched);

// Back from MUMPS to the banded LU the structure chose, after MUMPS failed the same step: the
// failure was not the banded LU's. Collective.
PetscErrorCode NewtonUseBandedLUAgain(SNES snes, NewtonContext *context);

} // namespace msflex
