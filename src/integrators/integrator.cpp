#include "integrators/integrator.hpp"

#include "core/format.hpp"

namespace msflex {

Integrator::~Integrator()
{
  VecDestroy(&increments_);
  SNESDestroy(&snes_);
}

PetscErrorCode Integrator::Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, NodalMass nodal_mass,
                                 PetscLogStage assembly_stage)
{
  PetscFunctionBeginUser;
  comm_    = comm;
  model_   = &model;
  map_     = &map;
  dynamic_ = model.analysis.type == AnalysisType::Dynamic;
  // -log_view stages: LinearSolve (each Newton solve but its assembly: factorisation, triangular
  // or Krylov solves), Assembly (pushed by the Newton callbacks).
  PetscCall(PetscLogStageRegister("LinearSolve", &solve_stage_));
  PetscCall(system_.Setup(comm, model, map, std::move(pattern), std::move(nodal_mass)));
  newton_context_.assembler      = &system_.GetAssembler();
  newton_context_.assembly_stage = assembly_stage;
  const bool em                  = dynamic_ && model.analysis.integrator == TimeSchemeKind::EnergyMomentum;
  PetscCall(NewtonSolverCreate(comm, model.analysis, em ? NewtonOperator::AssembledWithRankOne : NewtonOperator::Assembled, &newton_context_, &snes_));
  PetscCall(VecDuplicate(system_.GetAssembler().SolutionTemplate(), &increments_));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::InitialiseMotion(double t)
{
  PetscFunctionBeginUser;
  Assembler &assembler = system_.GetAssembler();
  StateSetInitialVelocities(*model_, *map_, t, &system_.GetState());
  if (IsMidpointScheme(model_->analysis.integrator)) PetscFunctionReturn(PETSC_SUCCESS);
  SNESConvergedReason reason;
  PetscCall(assembler.BeginStep(InitialAccelerationProblem(t)));
  PetscCall(VecZeroEntries(increments_));
  PetscCall(SNESSolve(snes_, nullptr, increments_));
  PetscCall(SNESGetConvergedReason(snes_, &reason));
  PetscCheck(reason > 0, comm_, PETSC_ERR_NOT_CONVERGED,
             "the initial accelerations could not be computed (%s): is every node with a DOF free given mass or stiffness?", SNESConvergedReasons[reason]);
  PetscCall(assembler.SetIncrements(increments_));
  // The reactions at t (the trapezoidal work of the first step starts from them).
  PetscCall(assembler.StoreReactions());
  StateCommitInitialAcceleration(&system_.GetState());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::TryStep(double t, double dt, StepOutcome *outcome)
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
  TimeScheme scheme             = MakeTimeScheme(analysis.integrator, analysis.spectral_radius, dt);
  scheme.energy_correction      = analysis.em_correction;
  const StepEquations equations = dynamic_ ? DynamicStep(scheme, t) : StaticStep(t, t + dt);
  PetscCall(assembler.BeginStep(equations));
  PetscCall(assembler.PredictIncrements(increments_));
  PetscCall(SNESSolve(snes_, nullptr, increments_));
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
  if (reason > 0 && !rotation_too_large) {
    if (dynamic_) {
      double work;
      PetscCall(assembler.StepExternalWork(&work));
      external_work_ += work;
    }
    if (map_->global_count.joints > 0) PetscCall(assembler.EvaluateJointReactions(dt));
    StateCommitStep(*model_, &system_.GetState());
    outcome->converged = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // Why, in words and naming where (element, node, joint), before the increments are dropped.
  outcome->reason = rotation_too_large ? "max_rotation_increment" : SNESConvergedReasons[reason];
  if (rotation_too_large) {
    outcome->why = Format("a nodal rotation increment of %.4g rad exceeds max_rotation_increment = %.4g rad", max_rotation, analysis.max_rotation_increment);
  } else {
    PetscCall(NewtonDescribeFailure(snes_, &newton_context_, &outcome->why));
    PetscCall(NewtonForgetFactorization(snes_));
  }
  StateDiscardStep(*model_, &system_.GetState());
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
  std::vector<msflex::ElementResults> unused;
  PetscFunctionBeginUser;
  PetscCall(system_.ElementResults(&unused, strain_energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode Integrator::MomentaOfState(Momenta *momenta)
{
  PetscFunctionBeginUser;
  PetscCall(system_.Momenta(momenta));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
