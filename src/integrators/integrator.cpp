#include "integrators/integrator.hpp"

#include <petscblaslapack.h>

#include <limits>

#include "core/errors.hpp"
#include "core/format.hpp"
#include "integrators/linearization.hpp"

namespace msflex {

// A rotation increment of a step beyond this (16 turns) is no motion but a singular tangent's answer.
constexpr double kAbsurdRotationIncrement = 100.0;

Integrator::~Integrator()
{
  VecDestroy(&increments_);
  VecDestroy(&accelerations_);
  KSPDestroy(&null_pivot_ksp_);
  MatDestroy(&null_pivot_matrix_);
  VecDestroy(&mass_forces_);
  VecDestroy(&mass_check_);
  SNESDestroy(&snes_);
  VecDestroy(&newton_context_.rank_one_solution);
}

PetscErrorCode Integrator::Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, NodalMass nodal_mass,
                                 PetscLogStage assembly_stage)
{
  PetscFunctionBeginUser;
  comm_  = comm;
  model_ = &model;
  map_   = &map;
  PetscCall(ModelLength(comm, model, map, &model_size_)); // the error estimate's floor (a restart too)
  dynamic_ = model.analysis.type == AnalysisType::Dynamic;
  // -log_view stages: LinearSolve (each Newton solve but its assembly: factorisation, triangular
  // or Krylov solves), Assembly (pushed by the Newton callbacks).
  PetscCall(PetscLogStageRegister("LinearSolve", &solve_stage_));
  PetscCall(PetscLogEventRegister("ConsistentReact", SNES_CLASSID, &consistent_reactions_event_));
  PetscCall(system_.Setup(comm, model, map, std::move(pattern), std::move(nodal_mass)));
  newton_context_.assembler      = &system_.GetAssembler();
  newton_context_.assembly_stage = assembly_stage;
  const bool em                  = dynamic_ && model.analysis.integrator == TimeSchemeKind::EnergyMomentum;
  PetscCall(NewtonSolverCreate(comm, model.analysis, em ? NewtonOperator::AssembledWithRankOne : NewtonOperator::Assembled, &newton_context_, &snes_));
  PetscCall(VecDuplicate(system_.GetAssembler().SolutionTemplate(), &increments_));
  for (const Probe &probe : model.probes) reaction_probes_ = reaction_probes_ || probe.kind == Probe::Kind::Reaction;
  int local = reaction_probes_ ? 1 : 0, any; // every rank takes part in the reactions' reduction
  PetscCallMPI(MPI_Allreduce(&local, &any, 1, MPI_INT, MPI_MAX, comm));
  reaction_probes_ = any != 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::InitialiseConfiguration()
{
  PetscFunctionBeginUser;
  StateSetInitialConfiguration(*model_, *map_, &system_.GetState());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::InitialiseStatics()
{
  PetscFunctionBeginUser;
  system_.StartMotion();
  if (reaction_probes_) {
    PetscCall(system_.GetAssembler().BeginStep(StaticStep(0.0, 0.0)));
    PetscCall(system_.GetAssembler().EvaluateSupportReactions());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// With initial_velocities: given, a slave given a velocity its joint forbids moves at the nearest
// it allows: the largest such change over the ranks, said in one line (beyond round-off).
PetscErrorCode Integrator::ReportSlaveVelocityChange(const SlaveVelocityChange &change)
{
  struct {
    double value;
    int    rank;
  } mine, largest;
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm_, &rank));
  const bool beyond_roundoff = change.largest > 1e-12 * change.given;
  mine.value                 = beyond_roundoff ? change.largest : 0.0;
  mine.rank                  = rank;
  PetscCallMPI(MPIU_Allreduce(&mine, &largest, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_));
  if (!(largest.value > 0.0) || quiet_) PetscFunctionReturn(PETSC_SUCCESS);
  char joint[256] = {};
  if (rank == largest.rank) std::snprintf(joint, sizeof joint, "%s", model_->joints[change.joint].name.c_str());
  PetscCallMPI(MPI_Bcast(joint, sizeof joint, MPI_CHAR, largest.rank, comm_));
  PetscCall(PetscPrintf(comm_,
                        "msflex: initial velocities as given, except where a joint forbids them: a slave moves at the nearest velocity its joint "
                        "allows, changed by up to %.6g (joint '%s'); -analysis_initial_velocities projected completes them for every joint and support\n",
                        largest.value, joint));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The relative mismatch |M a - f| / |f| of the initial accelerations above which the part of the
// model without mass is said to be out of equilibrium: far above the solve's round-off.
constexpr double kMasslessEquilibriumTolerance = 1e-8;

PetscErrorCode Integrator::SolveAccelerations(Vec accelerations, bool hand_over, bool *solved, double *singular_mismatch)
{
  SNESConvergedReason reason = SNES_DIVERGED_LINEAR_SOLVE;
  PetscFunctionBeginUser;
  *solved            = false;
  *singular_mismatch = 0.0;
  // A mass matrix found singular stays so: straight to its solver (no failed factorisation a step).
  if (!singular_mass_) {
    PetscCall(VecZeroEntries(accelerations));
    PetscCall(SNESSolve(snes_, nullptr, accelerations));
    PetscCall(SNESGetConvergedReason(snes_, &reason));
    if (reason > 0) {
      *solved = true;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    // A failed factorisation leaves Newton's PC unusable (MUMPS skips every numeric factorisation
    // after a failed one, and the next step's Newton failed with INFOG(1) = -3): dropped.
    PetscCall(NewtonForgetFactorization(snes_, &newton_context_));
  }
  // Singular without an empty row (a node without mass between joints), or an LU without
  // pivoting between nodes that met a zero pivot: solved as it is, before any hand-over of the
  // run's LU to MUMPS (the mass matrix's singularity is no pivoting problem).
  PetscInt null_pivots = 0;
  double   mismatch    = 0.0;
  PetscCall(SolveSingularMassProblem(accelerations, solved, &mismatch, &null_pivots));
  if (*solved) {
    singular_mass_     = null_pivots > 0;
    *singular_mismatch = mismatch;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (!hand_over) PetscFunctionReturn(PETSC_SUCCESS);
  // As for a step (TryEquations): MUMPS keeps the run only if it solves what the banded LU could not.
  bool switched = false;
  PetscCall(NewtonUsePivotingLU(snes_, &newton_context_, &switched));
  if (!switched) PetscFunctionReturn(PETSC_SUCCESS);
  const SNESConvergedReason banded_reason = reason;
  PetscCall(VecZeroEntries(accelerations));
  PetscCall(SNESSolve(snes_, nullptr, accelerations));
  PetscCall(SNESGetConvergedReason(snes_, &reason));
  *solved = reason > 0;
  PetscCall(SettleRetryWithMumps(*solved, "the initial accelerations", SNESConvergedReasons[banded_reason]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::SettleRetryWithMumps(bool converged, const std::string &what, const std::string &why)
{
  PetscFunctionBeginUser;
  if (!converged) {
    PetscCall(NewtonUseBandedLUAgain(snes_, &newton_context_));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (!quiet_)
    PetscCall(PetscPrintf(
        comm_, "msflex: Newton failed on %s with the banded LU, which does not pivot between nodes (%s), and MUMPS converged: MUMPS factors from here on\n",
        what.c_str(), why.c_str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::SolveSingularMassProblem(Vec accelerations, bool *solved, double *mismatch, PetscInt *null_pivots)
{
  Mat jacobian, preconditioner;
  PetscFunctionBeginUser;
  *solved      = false;
  *mismatch    = NAN;
  *null_pivots = 0;
  // The problem is linear in the accelerations: M a = f with f = -r(0), M its tangent. (The
  // vectors are kept: the consistent reactions solve it at every step.)
  if (!mass_forces_) PetscCall(VecDuplicate(accelerations, &mass_forces_));
  if (!mass_check_) PetscCall(VecDuplicate(accelerations, &mass_check_));
  PetscCall(VecZeroEntries(accelerations));
  PetscCall(SNESComputeFunction(snes_, accelerations, mass_forces_));
  PetscCall(VecScale(mass_forces_, -1.0));
  PetscCall(SNESGetJacobian(snes_, &jacobian, &preconditioner, nullptr, nullptr));
  PetscCall(SNESComputeJacobian(snes_, accelerations, jacobian, preconditioner));
  // |M a - f| / |f| of the solution found (by either solver below).
  const auto measure = [&](Mat M) -> PetscErrorCode {
    PetscReal force_norm, check_norm;
    PetscFunctionBeginUser;
    PetscCall(MatMult(M, accelerations, mass_check_));
    PetscCall(VecAXPY(mass_check_, -1.0, mass_forces_));
    PetscCall(VecNorm(mass_check_, NORM_2, &check_norm));
    PetscCall(VecNorm(mass_forces_, NORM_2, &force_norm));
    *solved   = std::isfinite(check_norm);
    *mismatch = force_norm > 0 ? check_norm / force_norm : 0.0;
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  PetscBool dense;
  PetscCall(PetscObjectTypeCompare((PetscObject)jacobian, MATSEQDENSE, &dense));
  if (dense) {
    // A dense tangent (a small model on one rank): LAPACK's least-squares solution of least norm,
    // M^+ f, by the singular values (gelss): no acceleration along the motions without mass. A
    // MUMPS factorisation of such a matrix cost 130 us a step.
    PetscInt           n, lda;
    const PetscScalar *values;
    PetscCall(MatGetSize(jacobian, &n, nullptr));
    PetscCall(MatDenseGetLDA(jacobian, &lda));
    PetscCall(MatDenseGetArrayRead(jacobian, &values));
    dense_work_.assign(values, values + (size_t)lda * (size_t)n); // column-major, as LAPACK takes it
    PetscCall(MatDenseRestoreArrayRead(jacobian, &values));
    PetscBLASInt m_blas, lda_blas, one = 1, rank = 0, info = 0, lwork;
    PetscCall(PetscBLASIntCast(n, &m_blas));
    PetscCall(PetscBLASIntCast(lda, &lda_blas));
    lwork = 5 * m_blas + 64;
    dense_singular_values_.resize((size_t)n);
    dense_lapack_work_.resize((size_t)lwork);
    // Singular values below this fraction of the largest count as zero: round-off, 10 n eps (1e-12
    // zeroed a genuine light body, 1e-7 kg beside 1e6 kg).
    const PetscReal rcond = 10.0 * (PetscReal)n * std::numeric_limits<PetscReal>::epsilon();
    PetscScalar    *solution;
    PetscCall(VecCopy(mass_forces_, accelerations));
    PetscCall(VecGetArray(accelerations, &solution));
    PetscCallBLAS("LAPACKgelss", LAPACKgelss_(&m_blas, &m_blas, &one, dense_work_.data(), &lda_blas, solution, &m_blas, dense_singular_values_.data(), &rcond,
                                              &rank, dense_lapack_work_.data(), &lwork, &info));
    PetscCall(VecRestoreArray(accelerations, &solution));
    if (info == 0) {
      *null_pivots = n - rank;
      PetscCall(measure(jacobian));
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // MUMPS takes AIJ (the tangent may be dense or blocked); the solver and its analysis are kept for
  // the next solve.
  PC  pc;
  Mat factor;
  if (!null_pivot_ksp_) {
    PetscCall(MatConvert(jacobian, MATAIJ, MAT_INITIAL_MATRIX, &null_pivot_matrix_));
    PetscCall(KSPCreate(comm_, &null_pivot_ksp_));
    PetscCall(KSPSetType(null_pivot_ksp_, KSPPREONLY));
    PetscCall(KSPSetOperators(null_pivot_ksp_, null_pivot_matrix_, null_pivot_matrix_));
    PetscCall(KSPGetPC(null_pivot_ksp_, &pc));
    PetscCall(PCSetType(pc, PCLU));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
    PetscCall(PCFactorSetUpMatSolverType(pc));
    PetscCall(PCFactorGetMatrix(pc, &factor));
    // Null pivots detected and fixed (ICNTL 24): the unknown of each is held at zero and its
    // equation dropped, which for consistent equations leaves a solution of them all.
    PetscCall(MatMumpsSetIcntl(factor, 24, 1));
  } else PetscCall(MatConvert(jacobian, MATAIJ, MAT_REUSE_MATRIX, &null_pivot_matrix_));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  const PetscErrorCode code = KSPSolve(null_pivot_ksp_, mass_forces_, accelerations);
  PetscCall(PetscPopErrorHandler());
  int mine = code != PETSC_SUCCESS, any = 0;
  PetscCallMPI(MPIU_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, comm_));
  if (any) {
    // A failed factorisation is not tried again with the same solver (MUMPS would skip it).
    PetscCall(KSPDestroy(&null_pivot_ksp_));
    PetscCall(MatDestroy(&null_pivot_matrix_));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  KSPConvergedReason reason;
  PetscInt           null = 0;
  PetscCall(KSPGetConvergedReason(null_pivot_ksp_, &reason));
  PetscCall(measure(null_pivot_matrix_));
  *solved = *solved && reason > 0;
  PetscCall(KSPGetPC(null_pivot_ksp_, &pc));
  PetscCall(PCFactorGetMatrix(pc, &factor));
  PetscCall(MatMumpsGetInfog(factor, 28, &null)); // the null pivots detected
  *null_pivots = null;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// One line when the part of the model without mass starts out of equilibrium: the forces on the
// massless unknowns relative to the forces of the residual, or the mismatch of a singular mass
// matrix's equations (SolveSingularMassProblem).
PetscErrorCode Integrator::WarnIfMasslessOutOfEquilibrium(double t, double singular_mismatch)
{
  Assembler &assembler = system_.GetAssembler();
  double     imbalance = 0.0;
  PetscFunctionBeginUser;
  PetscCall(assembler.MasslessImbalance(&imbalance));
  const double mismatch = std::max(singular_mismatch, imbalance);
  if (mismatch > kMasslessEquilibriumTolerance && !quiet_)
    PetscCall(PetscPrintf(comm_,
                          "msflex: warning: the part of the model without mass is not in equilibrium at t = %.9g (the forces on it are %.3g of the "
                          "forces acting): newmark and genalpha bring it there in the first step, mc and em swing about it for the whole run; start "
                          "it in equilibrium (docs/force_elements.md)\n",
                          t, mismatch));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::InitialiseMotion(double t)
{
  PetscFunctionBeginUser;
  Assembler &assembler = system_.GetAssembler();
  motion_start_time_   = t;
  previous_step_       = 0.0; // (a static stage's load step is no time step)
  StateSetInitialVelocities(*model_, *map_, t, &system_.GetState());
  if (model_->analysis.project_initial_velocities) {
    InitialVelocityReport report;
    PetscCall(assembler.ProjectInitialVelocities(t, &report));
    if (!quiet_)
      PetscCall(PetscPrintf(comm_,
                            "msflex: initial velocities: %" PetscInt_FMT " unknown(s) held at given velocities, %" PetscInt_FMT
                            " chosen for the least strain rate (V^T K V %.3e -> %.3e%s), %" PetscInt_FMT
                            " at rest; largest change of a given velocity %.3g (slaves: the nearest their joints allow)\n",
                            report.held, report.chosen, report.strain_rate_before, report.strain_rate_after, report.solved ? "" : ": nothing strains, no solve",
                            report.at_rest, report.slave_change));
  } else {
    SlaveVelocityChange change;
    StateSetCoordinateRates(*model_, *map_, t, &system_.GetState(), &change);
    PetscCall(ReportSlaveVelocityChange(change));
  }
  system_.StartMotion();
  const bool midpoint = IsMidpointScheme(model_->analysis.integrator);
  // The mid-point schemes need no initial accelerations, but the first history row's joint
  // reactions do (they were 0): the problem is solved for them alone when there are joints, or
  // reaction probes whose reactions are the consistent ones.
  if (midpoint && map_->global_count.joints == 0 && !ConsistentReactionsWanted()) {
    PetscCall(assembler.BeginStep(InitialAccelerationProblem(t)));
    if (reaction_probes_) PetscCall(assembler.EvaluateSupportReactions());
    // The forces on the unknowns without mass, of which the mid-point schemes solve no equation at
    // t: a part without mass that starts out of equilibrium swings about it for the whole run.
    PetscCall(WarnIfMasslessOutOfEquilibrium(t, 0.0));
    // That problem's "increments" of prescribed DOFs are their accelerations value f''(t): drop
    // them, or the first frame shows a prescribed rotation turned by value f''(0) (a cosine ramp
    // of 0.4 rad: 1.97 rad at t = 0).
    assembler.DiscardStep();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(assembler.BeginStep(InitialAccelerationProblem(t)));
  if (midpoint) {
    // For the reactions alone: one attempt, no hand-over of the LU (the run's solver stays as it
    // is), and a failure leaves the first row's joint reactions at 0 rather than stop a run that
    // needs no accelerations. Nothing of the solve is kept: the mid-point schemes' steps start
    // from positions and velocities alone, the State as it was before it.
    bool   solved;
    double singular_mismatch;
    PetscCall(SolveAccelerations(increments_, false, &solved, &singular_mismatch));
    PetscCall(WarnIfMasslessOutOfEquilibrium(t, singular_mismatch));
    if (solved) {
      PetscCall(assembler.SetIncrements(increments_));
      PetscCall(assembler.EvaluateJointReactions(0.0));
    } else PetscCall(assembler.BeginStep(InitialAccelerationProblem(t))); // the supports' reactions without accelerations, as before
    if (reaction_probes_) PetscCall(assembler.EvaluateSupportReactions());
    assembler.DiscardStep();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  bool   solved;
  double singular_mismatch;
  PetscCall(SolveAccelerations(increments_, true, &solved, &singular_mismatch));
  PetscCheck(solved, comm_, PETSC_ERR_NOT_CONVERGED, "the initial accelerations could not be computed: is every node with a DOF free given mass or stiffness?");
  if (singular_mass_ && !quiet_)
    PetscCall(PetscPrintf(comm_, "msflex: initial accelerations: the mass matrix is singular (a node without mass between joints); each motion without mass "
                                 "starts with zero acceleration\n"));
  PetscCall(WarnIfMasslessOutOfEquilibrium(t, singular_mismatch)); // (it evaluates the forces at zero accelerations)
  PetscCall(assembler.SetIncrements(increments_));
  // The joints' reactions at t, for the first history row (the rates stay as given).
  if (map_->global_count.joints > 0) PetscCall(assembler.EvaluateJointReactions(0.0));
  // The reactions at t (the trapezoidal work of the first step starts from them).
  PetscCall(assembler.StoreReactions());
  if (reaction_probes_) PetscCall(assembler.EvaluateSupportReactions());
  if (assembler.NumMasslessUnknowns() > 0 && !quiet_)
    PetscCall(PetscPrintf(comm_, "msflex: initial accelerations: %" PetscInt_FMT " unknown(s) without mass start with zero acceleration\n",
                          assembler.NumMasslessUnknowns()));
  StateCommitInitialAcceleration(&system_.GetState());
  system_.StartMotion();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::CommitConvergedStep(double dt)
{
  Assembler &assembler = system_.GetAssembler();
  PetscFunctionBeginUser;
  const double t_end      = system_.GetState().equations.t_end;
  step_energy_correction_ = assembler.EnergyCorrectionFactor();
  previous_step_          = dt;
  if (map_->global_count.joints > 0) PetscCall(assembler.EvaluateJointReactions(dt));
  if (reaction_probes_) PetscCall(assembler.EvaluateSupportReactions());
  system_.CommitStep();
  StateCommitStep(*model_, &system_.GetState());
  if (ConsistentReactionsWanted()) PetscCall(ConsistentReactions(t_end));
  PetscFunctionReturn(PETSC_SUCCESS);
}

bool Integrator::ConsistentReactionsWanted() const
{
  if (!dynamic_ || model_->analysis.reactions != ReactionPoint::Consistent) return false;
  // The Newmark family's equations hold at t_end with the scheme's accelerations: without joints
  // its reactions are the consistent ones already.
  return map_->global_count.joints > 0 || (reaction_probes_ && IsMidpointScheme(model_->analysis.integrator));
}

PetscErrorCode Integrator::ConsistentReactions(double t)
{
  Assembler &assembler = system_.GetAssembler();
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(consistent_reactions_event_, 0, 0, 0, 0));
  const double started = MPI_Wtime();
  if (!accelerations_) PetscCall(VecDuplicate(increments_, &accelerations_));
  PetscCall(assembler.BeginStep(InitialAccelerationProblem(t)));
  bool   solved;
  double mismatch;
  PetscCall(SolveAccelerations(accelerations_, false, &solved, &mismatch));
  ++consistent_reaction_solves_;
  if (solved) {
    PetscCall(assembler.SetIncrements(accelerations_));
    // The joints' mean rates over the step stay what the history reports.
    if (map_->global_count.joints > 0) PetscCall(assembler.EvaluateJointReactions(0.0, true));
    if (reaction_probes_) PetscCall(assembler.EvaluateSupportReactions());
  } else {
    // The scheme's reactions stay; said once (a run that keeps failing here says it at the end).
    if (consistent_reaction_failures_++ == 0 && !quiet_)
      PetscCall(PetscPrintf(comm_,
                            "msflex: warning: the consistent reactions at t = %.9g could not be solved (DIVERGED_LINEAR_SOLVE); the scheme's are "
                            "reported there and wherever this recurs (analysis.reactions, docs/joints.md)\n",
                            t));
  }
  assembler.DiscardStep();
  ForgetKeptTangent();
  consistent_reaction_seconds_ += MPI_Wtime() - started;
  PetscCall(PetscLogEventEnd(consistent_reactions_event_, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// LocalErrorRatio's floor of motion per step: this fraction of the model's size and of a radian.
constexpr double kErrorMotionFloor = 1e-3;

PetscErrorCode Integrator::LocalErrorRatio(double dt, double *ratio)
{
  double local[4] = {0.0, 0.0, 0.0, 0.0}, global[4];
  PetscFunctionBeginUser;
  // The mid-point schemes' accelerations are the steps' means: their difference spans the two
  // steps' mid-points, (h_prev + h)/2 apart, not h (a step after a longer one kept an error floor
  // that did not fall with dt, and the controller piled up rejections; a user trial).
  const bool   midpoint = GetState().equations.Midpoint();
  const double span     = midpoint && previous_step_ > 0.0 ? 2.0 * dt / (previous_step_ + dt) : 1.0;
  StateLocalErrorSums(GetState(), dt, local);
  PetscCall(MPIU_Allreduce(local, global, 4, MPI_DOUBLE, MPI_SUM, comm_));
  const double tolerance = model_->analysis.step_tolerance;
  // The motion an error is measured against, with a floor of a thousandth of the model's size
  // (and of a radian) per node: starting from rest under a ramped load the error and the motion
  // both go as dt^3, so a purely relative measure never fell with the step (flying spaghetti
  // under newmark stopped at t = 0), nor where the motion nearly came to rest. No error where no
  // acceleration changed (rest, uniform motion).
  const double nodes = std::sqrt((double)std::max<PetscInt>(map_->global_count.nodes, 1));
  auto         part  = [tolerance](double error_squared, double motion_squared, double floor) {
    if (error_squared == 0.0) return 0.0;
    const double scale = std::sqrt(motion_squared) + floor;
    return scale > 0.0 ? std::sqrt(error_squared) / (tolerance * scale) : INFINITY;
  };
  *ratio = span * std::max(part(global[0], global[1], kErrorMotionFloor * model_size_ * nodes), part(global[2], global[3], kErrorMotionFloor * nodes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::TryStep(double t, double dt, StepOutcome *outcome)
{
  const AnalysisSettings &analysis = model_->analysis;
  PetscFunctionBeginUser;
  TimeScheme scheme             = MakeTimeScheme(analysis.integrator, analysis.spectral_radius, dt);
  scheme.energy_correction      = analysis.em_correction;
  const StepEquations equations = dynamic_ ? DynamicStep(scheme, t) : StaticStep(t, t + dt);
  PetscCall(TryEquations(equations, dt, outcome));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::TryStaticStageStep(double t, double load_factor, double step, StepOutcome *outcome)
{
  PetscFunctionBeginUser;
  PetscCall(TryEquations(StaticStageStep(t, load_factor + step), step, outcome));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::TryEquations(const StepEquations &equations, double dt, StepOutcome *outcome)
{
  const AnalysisSettings &analysis = model_->analysis;
  SNESConvergedReason     reason;
  PetscInt                iterations;
  PetscReal               residual_norm;
  double                  max_rotation = 0.0;
  Assembler              &assembler    = system_.GetAssembler();
  PetscFunctionBeginUser;
  *outcome = StepOutcome{};
  PetscCall(PetscLogStagePush(solve_stage_));
  PetscCall(assembler.BeginStep(equations));
  PetscCall(assembler.PredictIncrements(increments_));
  // An error raised inside the solver (a -snes_type whose inner SVD fails, a PETSc routine that
  // refuses this system) is a failed attempt like a divergence: the step is halved, and a run
  // that still fails stops with its results and the reason, not with a trace and MPI_Abort. An
  // error of msflex's own (a one-line error) goes on as it is.
  solver_error_.clear();
  PetscCall(PetscPushErrorHandler(CaptureFirstErrorMessage, &solver_error_));
  const PetscErrorCode solve_code = SNESSolve(snes_, nullptr, increments_);
  PetscCall(PetscPopErrorHandler());
  int mine = solve_code != PETSC_SUCCESS ? 1 : 0, any = 0;
  PetscCallMPI(MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, comm_));
  if (solve_code != PETSC_SUCCESS && IsOneLineError(solve_code)) {
    PetscCall(PetscLogStagePop());
    SETERRQ(PETSC_COMM_SELF, solve_code, "%s", solver_error_.c_str());
  }
  if (any) {
    PetscCall(PetscLogStagePop());
    *outcome        = StepOutcome{};
    outcome->reason = "solver error";
    outcome->why    = "the nonlinear solver raised an error: " + (solver_error_.empty() ? std::string("on another rank") : solver_error_);
    PetscCall(NewtonForgetFactorization(snes_, &newton_context_));
    assembler.DiscardStep();
    ForgetKeptTangent();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(assembler.SetIncrements(increments_));
  PetscCall(PetscLogStagePop());
  PetscCall(SNESGetConvergedReason(snes_, &reason));
  PetscCall(SNESGetIterationNumber(snes_, &iterations));
  PetscCall(SNESGetFunctionNorm(snes_, &residual_norm));
  PetscInt linear_iterations;
  PetscCall(SNESGetLinearSolveIterations(snes_, &linear_iterations));
  outcome->newton_iterations = (int)iterations;
  outcome->residual_norm     = residual_norm;
  outcome->linear_iterations = (int)linear_iterations;
  if (reason > 0) PetscCall(assembler.MaxRotationIncrement(&max_rotation));
  const bool rotation_too_large = max_rotation > analysis.max_rotation_increment;
  // The mid-point schemes' first step has no start acceleration to compare with (they solve none at
  // t_0, and the state holds zero): it goes unestimated, and the controller keeps its step.
  const bool start_acceleration_known = !equations.Midpoint() || equations.t_start > motion_start_time_;
  if (reason > 0 && !rotation_too_large && equations.Dynamic() && analysis.step_tolerance > 0.0 && start_acceleration_known)
    PetscCall(LocalErrorRatio(dt, &outcome->error_ratio));
  // A step at min_step is accepted whatever its estimate, as TSAdapt's basic adaptor does, and said
  // once: near rest, or from rest under a ramped load, the estimate relative to the motion need not
  // fall with the step.
  // (StepController::Propose stretches a step by up to 1 % to land on a target: from min_step that
  // is still min_step, or the rejection and the same stretched retry would loop for ever.)
  const bool at_min_step     = dt <= analysis.min_step * 1.01 * (1.0 + 1e-12);
  const bool error_too_large = outcome->error_ratio > 1.0 && !at_min_step;
  if (outcome->error_ratio > 1.0 && at_min_step && !error_over_tolerance_said_) {
    error_over_tolerance_said_ = true; // (a warning: -quiet too)
    PetscCall(PetscFPrintf(comm_, PETSC_STDERR,
                           "msflex: warning: the step to t = %.9g at min_step = %.3g has a local error estimate %.4g times step_tolerance; steps at "
                           "min_step are accepted whatever their estimate (said once)\n",
                           equations.t_end, analysis.min_step, outcome->error_ratio));
  }
  if (reason > 0 && !rotation_too_large && !error_too_large) {
    if (equations.Dynamic()) {
      double work, dissipation;
      PetscCall(assembler.StepExternalWork(&work));
      external_work_ += work;
      PetscCall(assembler.StepDissipation(&dissipation));
      dissipated_energy_ += dissipation;
    }
    PetscCall(CommitConvergedStep(dt));
    outcome->converged = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // Why, in words and naming where (element, node, joint), before the increments are dropped.
  outcome->reason = rotation_too_large ? "max_rotation_increment" : error_too_large ? "step_tolerance" : SNESConvergedReasons[reason];
  if (rotation_too_large) {
    // mc and em carry a joint angle's step as 2 tan(dphi/2), which outgrows dphi (a user read 14.8
    // rad for a step of about 4 rad): the message says which measure it is.
    outcome->why = Format("a rotation increment (of a node, or a joint's released angle%s) of %.4g rad exceeds max_rotation_increment = %.4g rad",
                          equations.Midpoint() ? ", as 2 tan(dphi/2) in mc and em" : "", max_rotation, analysis.max_rotation_increment);
    // Dozens of turns in one step come from a tangent singular but for round-off, which a pivoting
    // LU (MUMPS, on more ranks) factors without a word, where the banded LU stops at the pivot and
    // says what is free: the same hint.
    if (!equations.Dynamic() && max_rotation > kAbsurdRotationIncrement) // (in dynamics: real spin, and a step too long)
      outcome->why += "; an increment this large comes from a nearly singular tangent: is part of the model a mechanism, free to move without "
                      "resistance?";
  } else if (error_too_large) { // (estimated only where the rotation passed)
    outcome->why = Format("the local error estimate is %.4g times step_tolerance = %.3g", outcome->error_ratio, analysis.step_tolerance);
  } else {
    PetscCall(NewtonDescribeFailure(snes_, &newton_context_, &outcome->why));
    PetscCall(NewtonForgetFactorization(snes_, &newton_context_));
  }
  assembler.DiscardStep();
  ForgetKeptTangent(); // the retried step starts on a new tangent, whatever its length
  if (rotation_too_large || error_too_large) PetscFunctionReturn(PETSC_SUCCESS);
  // A banded LU does not pivot between nodes: the step is tried again with MUMPS, once. Converged,
  // MUMPS factors the rest of the run; failed as well, the failure is no pivoting problem (a step
  // too long for the motion), and the banded LU comes back for the halved step: MUMPS costs
  // 100 us a factorisation of the 49 unknowns of the turning arm, PETSc's LU 12 us.
  bool switched = false;
  PetscCall(NewtonUsePivotingLU(snes_, &newton_context_, &switched));
  if (!switched) PetscFunctionReturn(PETSC_SUCCESS);
  const std::string why_banded = outcome->why;
  const int         newton = outcome->newton_iterations, linear = outcome->linear_iterations;
  PetscCall(TryEquations(equations, dt, outcome));
  outcome->retried_newton_iterations += newton, outcome->retried_linear_iterations += linear;
  // (Newton converged with MUMPS where the step's error estimate alone rejects it: MUMPS keeps it.)
  PetscCall(SettleRetryWithMumps(outcome->converged || outcome->reason == "step_tolerance",
                                 Format("the step from t = %.9g to %.9g", equations.t_start, equations.t_end), why_banded));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::UsePivotingLU()
{
  bool switched;
  PetscFunctionBeginUser;
  PetscCall(NewtonUsePivotingLU(snes_, &newton_context_, &switched));
  // Recorded whether Newton's own LU changed or not (it may not be banded, under -pc_type): the
  // path follower's corrector, which asked, follows the flag after a restart (PathFollower::Correct).
  newton_context_.pivoting_lu_forced = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::ElementResults(std::vector<msflex::ElementResults> *results, double *strain_energy)
{
  PetscFunctionBeginUser;
  PetscCall(system_.ElementResults(results, strain_energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::StrainEnergy(double *strain_energy)
{
  PetscFunctionBeginUser;
  PetscCall(system_.StrainEnergy(strain_energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::MomentaOfState(Momenta *momenta)
{
  PetscFunctionBeginUser;
  PetscCall(system_.Momenta(momenta));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
