// The integrator of one analysis: it owns the mechanical system (the State, the force
// contributors, the assembler) and the Newton solver, and takes the steps (of time, or of the load factor in statics) that the
// driver (app/run_analysis.hpp) proposes under its step control.
//
// Statics: r(x_{t+dt}) = 0 by Newton from the last equilibrium. Dynamics: the scheme named by
// analysis.integrator (schemes/time_scheme.hpp), Newton on the step's increments from a
// constant-velocity predictor; the Newmark family first solves for the initial accelerations.
#pragma once

#include "assembly/mechanical_system.hpp"
#include "integrators/newton.hpp"

#include <petscsnes.h>

#include <limits>
#include <string>
#include <vector>

namespace msflex {

// How one attempt at a step ended.
struct StepOutcome {
  bool        converged         = false;
  int         newton_iterations = 0;
  double      residual_norm     = 0.0;
  std::string why; // when not converged: why, in words, naming where (element, node, joint)
  // For the run's summary: Krylov iterations of the attempt, and when not converged a short tag
  // (SNES's reason, e.g. DIVERGED_LINEAR_SOLVE, or max_rotation_increment).
  int         linear_iterations = 0;
  std::string reason;
  // Iterations of an attempt at the same step before this one, inside the same call (the banded
  // LU's, retried with MUMPS): counted among all attempts, never among the accepted step's.
  int retried_newton_iterations = 0, retried_linear_iterations = 0;
  // A failure that a shorter step cannot mend (it depends on the last equilibrium only): the run
  // stops at once instead of halving down to min_step.
  bool step_size_irrelevant = false;
  // When converged: the length of the step in the driver's parameter when it is not the step
  // proposed (an arc-length step that lands on end_time by load control covers that fraction of
  // its pseudo-time); NaN: the proposed one.
  double step_taken = std::numeric_limits<double>::quiet_NaN();
  // Dynamics with step_tolerance: the step's local error estimate over the tolerance (a step
  // converged by Newton whose ratio exceeds 1 is rejected with reason step_tolerance, except at
  // min_step); -1: none.
  double error_ratio = -1.0;
};

class Integrator {
public:
  Integrator()                              = default;
  Integrator(const Integrator &)            = delete;
  Integrator &operator=(const Integrator &) = delete;
  ~Integrator();

  // Set-up on the rank's part of the model (dofs/dof_map.hpp, DofMapRestrictToLocal); `pattern`
  // and `nodal_mass` were computed on the whole model. The model and map must outlive the
  // integrator. Collective.
  PetscErrorCode Setup(MPI_Comm comm, const Model &model, const DofMap &map, MatrixPattern pattern, NodalMass nodal_mass, PetscLogStage assembly_stage);

  // The initial configuration of the initial conditions (displacements, rotations, joint
  // coordinates). Collective.
  PetscErrorCode InitialiseConfiguration();
  // Initial velocities, and for the Newmark family the accelerations that satisfy the equations of
  // motion at t (a linear problem, solved by the same Newton solver in one iteration; unknowns no
  // mass reaches get zero acceleration). Collective.
  PetscErrorCode InitialiseMotion(double t);
  // The start of a static analysis (the force elements' recorded forces). Collective.
  PetscErrorCode InitialiseStatics();
  // One attempt at a step of the static stage: equilibrium at t with the loads scaled from
  // load_factor to load_factor + step; committed when converged, as TryStep. Collective.
  PetscErrorCode TryStaticStageStep(double t, double load_factor, double step, StepOutcome *outcome);
  // One attempt at the step t -> t + dt. Converged (and the rotation increments within
  // max_rotation_increment): the external work is accumulated, the joint reactions are
  // evaluated and the step is committed; otherwise the state is back at t and outcome->why says
  // why. Collective.
  PetscErrorCode TryStep(double t, double dt, StepOutcome *outcome);

  // Results view (collective): element results and strain energy of the current state, momenta
  // of the start-of-step state.
  PetscErrorCode ElementResults(std::vector<msflex::ElementResults> *results, double *strain_energy);
  // The results of the local elements `only` alone, the others zero (not collective).
  PetscErrorCode ElementResultsOf(const std::vector<int> &only, std::vector<msflex::ElementResults> *results)
  {
    return system_.ElementResultsOf(only, results);
  }
  PetscErrorCode StrainEnergy(double *strain_energy);
  PetscErrorCode MomentaOfState(Momenta *momenta);
  // Stored energy of the force elements' springs in the current state (collective).
  PetscErrorCode SpringEnergy(double *energy) { return system_.SpringEnergy(energy); }
  bool           HasForceElementsOrDamping() const { return system_.HasForceElementsOrDamping(); }
  void           ForceElementHistory(bool with_names, std::vector<HistoryValue> *values) const { system_.ForceElementHistory(with_names, values); }

  bool Dynamic() const { return dynamic_; }
  // The -log_view stages of a Newton solve's assembly and linear solves (the path follower's own
  // Newton loop logs into them too).
  PetscLogStage AssemblyStage() const { return newton_context_.assembly_stage; }
  PetscLogStage SolveStage() const { return solve_stage_; }
  // No messages (-quiet).
  void   SetQuiet(bool quiet) { quiet_ = quiet; }
  double ExternalWork() const { return external_work_; }
  void   SetExternalWork(double work) { external_work_ = work; }
  // Energy dissipated by the dampers since t = 0 (dynamics).
  double DissipatedEnergy() const { return dissipated_energy_; }
  void   SetDissipatedEnergy(double energy) { dissipated_energy_ = energy; }
  // The length of the last converged step (0 before the first): the mid-point schemes' error
  // estimate spans the two steps' mid-points; a checkpoint keeps it.
  double PreviousStep() const { return previous_step_; }
  void   SetPreviousStep(double step) { previous_step_ = step; }
  // A restart from a checkpoint of the initial state: the mid-point schemes' first step from it goes
  // unestimated, as from InitialiseMotion.
  void SetMotionStart(double t) { motion_start_time_ = t; }
  // em's beta of the last committed step (the consistent reactions' solve after it has none).
  double       EnergyCorrectionFactor() const { return step_energy_correction_; }
  const State &GetState() const { return system_.GetState(); }
  // Modified Newton (AnalysisSettings::jacobian_reuse): tangents assembled and factored, and
  // iterations that reused the last one, over the whole run.
  long long TangentsFormed() const { return newton_context_.tangents_formed; }
  long long TangentsReused() const { return newton_context_.tangents_reused; }
  // Newton factors by MUMPS since the banded LU failed (NewtonUsePivotingLU); a restart makes
  // the same choice (UsePivotingLU) so that it repeats the run to the last bit.
  // analysis.reactions consistent: acceleration solves made for the reactions, and the failed ones.
  long long      ConsistentReactionSolves() const { return consistent_reaction_solves_; }
  double         ConsistentReactionSeconds() const { return consistent_reaction_seconds_; }
  long long      ConsistentReactionFailures() const { return consistent_reaction_failures_; }
  bool           PivotingLUForced() const { return newton_context_.pivoting_lu_forced; }
  PetscErrorCode UsePivotingLU();
  // The next Newton iteration assembles a new tangent (after a checkpoint, as a restart would).
  void ForgetKeptTangent()
  {
    newton_context_.tangent_factored = false;
    newton_context_.last_contracted  = false;
  }
  // The State to change directly (a restart reads it in): the assembler forgets what it kept of
  // the last residual.
  State *MutableState()
  {
    system_.GetAssembler().ForgetIncrements();
    return &system_.GetState();
  }
  const Model &GetModel() const { return *model_; }
  // The mechanical system, for what linearises it about the current state (path following,
  // stability, eigenanalysis).
  MechanicalSystem &System() { return system_; }
  // Commits the converged increments of a step of length dt (the step's own or a path
  // follower's): the joints' and reaction probes' reactions at them, the contributors' own state
  // (force elements, damping), then the State. Collective.
  PetscErrorCode CommitConvergedStep(double dt);
  // The increments of the last converged step (Newton's solution).
  Vec           LastIncrements() const { return increments_; }
  const DofMap &Map() const { return *map_; }

private:
  MPI_Comm         comm_    = MPI_COMM_NULL;
  const Model     *model_   = nullptr;
  const DofMap    *map_     = nullptr;
  bool             dynamic_ = false;
  MechanicalSystem system_;
  NewtonContext    newton_context_;
  SNES             snes_              = nullptr;
  Vec              increments_        = nullptr;
  double           external_work_     = 0.0;   // accumulated work of the external loads (dynamics)
  double           dissipated_energy_ = 0.0;   // accumulated dissipation of the dampers (dynamics)
  bool             reaction_probes_   = false; // the model has reaction probes
  bool             quiet_             = false;
  // An attempt at a step with these equations (TryStep, TryStaticStageStep); failed with the banded
  // LU, a second with MUMPS, which keeps the run if it converges (said on stdout).
  PetscErrorCode TryEquations(const StepEquations &equations, double dt, StepOutcome *outcome);
  // After the retry with MUMPS of what the banded LU failed (`what`, with the banded LU's failure
  // `why`): converged, MUMPS keeps the run (said in one line); else the banded LU comes back.
  PetscErrorCode SettleRetryWithMumps(bool converged, const std::string &what, const std::string &why);
  PetscErrorCode ReportSlaveVelocityChange(const SlaveVelocityChange &change);
  // The accelerations of the initial-acceleration problem set up in the Assembler when its mass
  // matrix is singular without empty rows (a node without mass between joints, whose coordinates
  // also carry the mass beyond it): a dense tangent's least-squares solution of least norm
  // (LAPACK gelss), else MUMPS with null-pivot detection, one unknown of each massless motion held
  // at zero acceleration. *mismatch: |M a - f| / |f|, above round-off where the part without mass
  // is not in equilibrium (the equations then have no solution); *null_pivots: the rank deficiency
  // found. Collective.
  PetscErrorCode SolveSingularMassProblem(Vec accelerations, bool *solved, double *mismatch, PetscInt *null_pivots);
  // The accelerations of the initial-acceleration problem set up in the Assembler, into
  // `accelerations`: by Newton's solver, where it fails (or the mass matrix was found singular) by
  // SolveSingularMassProblem, and then (hand_over) by MUMPS after the banded LU hands the run over.
  // *singular_mismatch: SolveSingularMassProblem's, 0 otherwise. Collective.
  PetscErrorCode           SolveAccelerations(Vec accelerations, bool hand_over, bool *solved, double *singular_mismatch);
  PetscErrorCode           WarnIfMasslessOutOfEquilibrium(double t, double singular_mismatch);
  KSP                      null_pivot_ksp_            = nullptr; // SolveSingularMassProblem's, kept
  Mat                      null_pivot_matrix_         = nullptr;
  double                   motion_start_time_         = -INFINITY;        // InitialiseMotion's t (a restart continues after it)
  double                   previous_step_             = 0.0;              // PreviousStep
  double                   model_size_                = 0.0;              // ModelLength: the bounding box's diagonal, 1 for one point (LocalErrorRatio's floor)
  bool                     error_over_tolerance_said_ = false;            // the warning of a step at min_step over step_tolerance
  bool                     singular_mass_             = false;            // the mass matrix was found singular (ConsistentReactions)
  Vec                      mass_forces_ = nullptr, mass_check_ = nullptr; // SolveSingularMassProblem's f and M a - f
  std::vector<PetscScalar> dense_work_, dense_lapack_work_;               // its copy of a dense mass matrix, gelss's work
  std::vector<PetscReal>   dense_singular_values_;
  PetscLogStage            solve_stage_ = -1;
  std::string              solver_error_; // the first message of an error raised inside SNESSolve (TryEquations)
  // The reactions at t_end from the accelerations that satisfy the equations of motion in the
  // converged state (analysis.reactions: consistent), replacing the scheme's; see
  // docs/joints.md. After the step is committed; its rates stay. Collective.
  bool           ConsistentReactionsWanted() const;
  PetscErrorCode ConsistentReactions(double t);
  // The converged step's local error estimate over step_tolerance (StateLocalErrorSums): the
  // larger of the translations' |e_x| / (tol (|u| + floor)) and the rotations'
  // |e_theta| / (tol (|omega| + floor)), norms over the whole model, u and omega the step's
  // increments, the floors 1e-3 of the model's size and of a radian per node; the mid-point
  // schemes' scaled by 2 dt / (dt_prev + dt). Collective.
  PetscErrorCode LocalErrorRatio(double dt, double *ratio);
  PetscLogEvent  consistent_reactions_event_ = 0;
  Vec            accelerations_              = nullptr;
  long long      consistent_reaction_solves_ = 0, consistent_reaction_failures_ = 0;
  double         consistent_reaction_seconds_ = 0.0; // wall time of those solves, this rank
  double         step_energy_correction_      = 0.0; // em's beta of the last committed step
};

} // namespace msflex
