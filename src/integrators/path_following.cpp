#include "integrators/path_following.hpp"
#include "core/block_envelope_pc.hpp"
#include "core/dense_lu.hpp"
#include "core/errors.hpp"

#include "core/format.hpp"
#include "integrators/linearization.hpp"
#include "model/joint_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// A tangent is taken as symmetric (an LDL^T factorisation with its inertia) within this relative
// asymmetry: at a converged equilibrium under conservative loads the spin-form tangent is
// symmetric up to the residual.
constexpr double kSymmetryTolerance = 1e-8;
// A load step whose increment differs from the path tangent's prediction by more than this many
// times the prediction, at both ends, has jumped to another branch. A continuous step that ends at
// a limit point, where x' grows like (lambda_c - lambda)^(-1/2), deviates by at most 1 from its
// start's prediction (x = 2 (a - sqrt(a b)) / (a - b) times it, a and b the distances of its ends
// to lambda_c, at most 2 at b = 0) and by 1 from its end's; a snap-through of the Williams toggle
// in one step of 4 deviated by 1.99 and 7.1 (2.0 missed it), the continuous steps of that run by
// at most 0.51.
constexpr double kJumpDeviation = 1.5;

} // namespace

const char *CriticalPointName(CriticalPointKind kind)
{
  switch (kind) {
  case CriticalPointKind::Limit:
    return "limit point";
  case CriticalPointKind::Bifurcation:
    return "bifurcation point";
  case CriticalPointKind::Jump:
    return "jump to another branch";
  default:
    return "no critical point";
  }
}

PathFollower::~PathFollower()
{
  MatDestroy(&tangent_);
  KSPDestroy(&ksp_);
  for (Vec *v :
       {&x_, &residual_, &q_, &dx_R_, &dx_F_, &dx_, &trial_, &work_, &weights_, &scale_, &mode_, &path_tangent_, &previous_increment_, &previous_tangent_})
    VecDestroy(v);
}

PetscErrorCode PathFollower::Setup(MPI_Comm comm, Integrator *integrator)
{
  PC pc;
  PetscFunctionBeginUser;
  comm_       = comm;
  integrator_ = integrator;
  model_      = &integrator->GetModel();
  map_        = &integrator->Map();
  control_    = model_->analysis.control;
  stability_  = model_->analysis.stability;
  // Follower loads make the tangent non-symmetric, however little next to stiff axial and shear
  // terms (EA = 1e8 under a follower force of 20: an asymmetry of 1e-9 of the tangent, below the
  // symmetry test's tolerance, and an LDL^T that counted "negative pivots" where there were none).
  int follower = 0, any_follower = 0;
  for (const NodalLoad &load : model_->nodal_loads) follower = follower || load.follower;
  PetscCallMPI(MPIU_Allreduce(&follower, &any_follower, 1, MPI_INT, MPI_MAX, comm));
  symmetry_tolerance_  = any_follower ? -1.0 : kSymmetryTolerance;
  Assembler &assembler = integrator->System().GetAssembler();
  for (Vec *v :
       {&x_, &residual_, &q_, &dx_R_, &dx_F_, &dx_, &trial_, &work_, &weights_, &scale_, &mode_, &path_tangent_, &previous_increment_, &previous_tangent_})
    PetscCall(VecDuplicate(assembler.SolutionTemplate(), v));
  PetscCall(MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &tangent_));
  double length;
  PetscCall(ModelLength(comm, *model_, *map_, &length));
  PetscCall(UnknownWeights(comm, *model_, *map_, integrator->GetState(), length, weights_));
  // The corrector's linear solver, chosen as Newton's (options -path_ksp_*, -path_pc_*): by the
  // tangent's structure a banded LU on one rank (PETSc's LU in RCM order: the tangent stays AIJ for
  // the stability account's Cholesky), whose failure hands the corrector and Newton to MUMPS
  // (UsePivotingLU); else MUMPS, or msflex's dense LU for a dense tangent. Relay nodes' zero
  // diagonals need a pivoting LU.
  PetscCall(KSPCreate(comm, &ksp_));
  PetscCall(KSPSetOptionsPrefix(ksp_, "path_"));
  PetscCall(KSPSetType(ksp_, KSPPREONLY));
  PetscCall(KSPGetPC(ksp_, &pc));
  const bool by_structure = model_->analysis.direct_solver == DirectSolverChoice::Auto && map_->num_relays == 0;
  if (by_structure) PetscCall(ChooseDirectSolver(assembler.BandedUnderRcm(), assembler.Jacobian(), pc));
  else PetscCall(SetDirectSolver(pc, assembler.Jacobian()));
  MSFLEX_CALL_READING_OPTIONS(PetscObjectComm((PetscObject)ksp_), KSPSetFromOptions(ksp_));
  banded_lu_ = false;
  if (by_structure) PetscCall(BandedLUByStructure(pc, &banded_lu_));
  if (map_->num_relays > 0) {
    PetscCall(PrepareRelayDirectSolver(pc, assembler.Jacobian(), "-path_pc_factor_mat_solver_type", model_->analysis.condensation_depth));
    factor_.SetRelays(map_->num_relays);
  }
  if (control_ == PathControl::Displacement) {
    // The controlled unknown: a free DOF of an independent node or a released joint coordinate
    // (the reader checked both), held by the rank that owns the node or the joint.
    const AnalysisSettings &a = model_->analysis;
    PetscMPIInt             rank;
    PetscCallMPI(MPI_Comm_rank(comm, &rank));
    PetscInt row = -1;
    if (!a.control_node.empty()) {
      for (PetscInt l = 0; l < map_->num_owned_nodes; ++l)
        if (model_->nodes[map_->local_nodes[l]].name == a.control_node && !map_->IsRelay((int)l)) row = map_->node_dofs[map_->local_nodes[l]][a.control_dof];
    } else {
      for (const JointState &J : integrator->GetState().joints) {
        const Joint &joint = model_->joints[J.joint];
        if (joint.name != a.control_joint || map_->joint_rank[J.joint] != rank) continue;
        const int c = JointCoordinateOfAxis(joint, a.control_dof);
        if (c >= 0) row = map_->joint_dofs[J.joint][c];
      }
    }
    PetscCall(MPIU_Allreduce(&row, &control_row_, 1, MPIU_INT, MPI_MAX, comm));
    PetscCheck(control_row_ >= 0, comm, PETSC_ERR_USER_INPUT, "the DOF of displacement control ('%s') is not an unknown of the model",
               (a.control_node.empty() ? a.control_joint : a.control_node).c_str());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::WeightedDot(Vec a, Vec b, double *dot)
{
  PetscScalar value;
  PetscFunctionBeginUser;
  PetscCall(VecPointwiseMult(work_, weights_, a));
  PetscCall(VecDot(work_, b, &value));
  *dot = PetscRealPart(value);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::Start(double t)
{
  PetscFunctionBeginUser;
  point_   = PathPoint{};
  point_.t = t;
  recent_.clear();
  PetscCall(Linearize(t, t, 0.0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::Linearize(double t, double lambda, double load_factor_increment)
{
  MechanicalSystem &system   = integrator_->System();
  const PathPoint   previous = point_;
  PetscFunctionBeginUser;
  point_                       = PathPoint{};
  point_.t                     = t;
  point_.load_factor           = lambda;
  point_.load_factor_increment = load_factor_increment;
  last_critical_               = CriticalPoint{};
  tangent_ready_               = false;
  if (stability_ || control_ != PathControl::Load) {
    PetscBool ok;
    double    force_scale;
    // In the stages of -log_view and the summary (Assembly, then LinearSolve for the factorisation
    // and what is done with it): the stability account's work was in Main Stage and "other", 0.40
    // of a 1.07 s run.
    PetscCall(PetscLogStagePush(integrator_->AssemblyStage()));
    PetscCall(EquilibriumTangent(system, lambda, tangent_));
    PetscCall(StaticResidual(system, lambda, lambda, nullptr, residual_, &ok, &force_scale));
    PetscCall(StaticLoadPattern(system, lambda, lambda, nullptr, residual_, q_));
    PetscCall(PetscLogStagePop());
    PetscCall(PetscLogStagePush(integrator_->SolveStage()));
    PetscCall(factor_.Factor(tangent_, symmetry_tolerance_, &point_.inertia));
    Assembler &assembler = system.GetAssembler();
    if (point_.inertia.factored) {
      PetscScalar c;
      PetscCall(factor_.Solve(q_, path_tangent_));
      PetscCall(assembler.ZeroRelayEntries(path_tangent_)); // the condensed rows of K^{-1} q are the condensed solve's
      PetscCall(VecDot(q_, path_tangent_, &c));
      if (std::isnan(c_0_)) {
        // The first equilibrium sets the scales: the current stiffness, the arc length per unit
        // load factor, the scaling of the lowest eigenvalue.
        c_0_ = PetscRealPart(c);
        PetscCall(WeightedDot(path_tangent_, path_tangent_, &c_ref_));
        const double psi = model_->analysis.arc_length_psi;
        psi2_c_ref_      = psi * psi * c_ref_;
        arc_scale_       = std::sqrt(c_ref_ + psi2_c_ref_);
        PetscCall(MatGetDiagonal(tangent_, scale_));
        PetscCall(VecAbs(scale_));
        PetscScalar *d;
        PetscInt     n;
        PetscCall(VecGetLocalSize(scale_, &n));
        PetscCall(VecGetArray(scale_, &d));
        for (PetscInt i = 0; i < n; ++i)
          if (!(PetscRealPart(d[i]) > 0)) d[i] = 1.0;
        PetscCall(VecRestoreArray(scale_, &d));
        // D = 0 on the relays' rows: inverse iteration then applies the condensed K^{-1}.
        PetscCall(assembler.ZeroRelayEntries(scale_));
        PetscCall(VecSet(mode_, 1.0));
      }
      point_.stiffness_parameter = PetscRealPart(c) != 0.0 ? c_0_ / PetscRealPart(c) : NAN;
      PetscCall(LoadFactorRate());
      if (stability_) PetscCall(factor_.LowestEigenvalue(scale_, mode_, &point_.lowest_eigenvalue));
      PetscCall(assembler.ZeroRelayEntries(mode_));
      tangent_ready_ = true;
    }
    PetscCall(PetscLogStagePop());
  }
  recent_.push_back(point_);
  if (recent_.size() > 3) {
    // The largest rate of the path before the last three points (StopAdvice's reference).
    if (std::isfinite(recent_.front().load_factor_rate)) earlier_rate_ = std::max(earlier_rate_, std::abs(recent_.front().load_factor_rate));
    recent_.erase(recent_.begin());
  }
  if (!std::isfinite(first_rate_)) first_rate_ = point_.load_factor_rate;
  if (steps_ > 0 && stability_) PetscCall(DetectCriticalPoint(previous));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::DetectCriticalPoint(const PathPoint &previous)
{
  const TangentInertia &before = previous.inertia, &after = point_.inertia;
  PetscFunctionBeginUser;
  if (!before.factored || !after.factored) PetscFunctionReturn(PETSC_SUCCESS);
  const bool counted = before.symmetric && after.symmetric;
  const bool passed  = counted ? before.negative_pivots != after.negative_pivots : before.determinant_sign != after.determinant_sign;
  if (!passed) PetscFunctionReturn(PETSC_SUCCESS);
  CriticalPoint point;
  point.step          = steps_;
  point.pivots_before = counted ? before.negative_pivots : -1;
  point.pivots_after  = counted ? after.negative_pivots : -1;
  // At a limit point c = q^T K^{-1} q passes through infinity (q is not orthogonal to the
  // critical mode), so S = c_0 / c changes sign; at a bifurcation it keeps its sign.
  point.kind = previous.stiffness_parameter * point_.stiffness_parameter < 0 ? CriticalPointKind::Limit : CriticalPointKind::Bifurcation;
  // Where the lowest eigenvalue passes zero, as a fraction of the step: on the parabola through
  // the last three equilibria when it has a root in the step (mu is quadratic in lambda where the
  // loads couple modes, as in lateral-torsional buckling), else on the line through the last two.
  const double mu0 = previous.lowest_eigenvalue, mu1 = point_.lowest_eigenvalue;
  double       fraction = std::isfinite(mu0) && std::isfinite(mu1) && mu0 * mu1 < 0 ? mu0 / (mu0 - mu1) : 0.5;
  if (recent_.size() == 3 && std::isfinite(recent_[0].lowest_eigenvalue) && std::isfinite(mu0) && std::isfinite(mu1) && mu0 * mu1 < 0) {
    // mu(s) = mu0 + s (mu1 - mu0) + c s (s - 1) with s = 0 at the previous point, s = 1 at this one.
    const double h = point_.t - previous.t, s_first = (recent_[0].t - previous.t) / h;
    const double line = mu0 + s_first * (mu1 - mu0), c = (recent_[0].lowest_eigenvalue - line) / (s_first * (s_first - 1.0));
    const double a = c, b = mu1 - mu0 - c, discriminant = b * b - 4 * a * mu0;
    if (a != 0.0 && discriminant >= 0.0)
      for (double root : {(-b + std::sqrt(discriminant)) / (2 * a), (-b - std::sqrt(discriminant)) / (2 * a)})
        if (root >= 0.0 && root <= 1.0) fraction = root;
  }
  point.load_factor = previous.load_factor + fraction * (point_.load_factor - previous.load_factor);
  // Not located: the lowest eigenvalue kept its sign (negative since a first critical point), and
  // the point is known only to lie in the step (the middle of which read like a located value).
  if (!(std::isfinite(mu0) && std::isfinite(mu1) && mu0 * mu1 < 0)) point.step_start = previous.load_factor, point.step_end = point_.load_factor;
  // lambda(s), s in [0, 1] over the step: the cubic through both ends' values and rates.
  const double h = point_.t - previous.t, l0 = previous.load_factor, l1 = point_.load_factor;
  const double m0 = h * previous.load_factor_rate, m1 = h * point_.load_factor_rate;
  if (std::isfinite(m0) && std::isfinite(m1)) {
    auto cubic = [&](double s) {
      return (2 * s * s * s - 3 * s * s + 1) * l0 + (s * s * s - 2 * s * s + s) * m0 + (-2 * s * s * s + 3 * s * s) * l1 + (s * s * s - s * s) * m1;
    };
    point.load_factor = cubic(fraction);
    if (point.kind == CriticalPointKind::Limit) {
      // A limit load is the extremum of the cubic in the step where the path turns: a maximum
      // when it was rising (a root of the derivative A s^2 + B s + C).
      const double A = 6 * l0 + 3 * m0 - 6 * l1 + 3 * m1, B = -6 * l0 - 4 * m0 + 6 * l1 - 2 * m1, C = m0, rising = m0 >= 0 ? 1.0 : -1.0;
      double       best     = NAN;
      auto         consider = [&](double s) {
        if (s >= 0.0 && s <= 1.0 && (std::isnan(best) || rising * cubic(s) > rising * cubic(best))) best = s;
      };
      if (A != 0.0) {
        const double discriminant = B * B - 4 * A * C;
        if (discriminant >= 0) consider((-B + std::sqrt(discriminant)) / (2 * A)), consider((-B - std::sqrt(discriminant)) / (2 * A));
      } else if (B != 0.0) {
        consider(-C / B);
      }
      if (std::isfinite(best)) point.load_factor = cubic(best);
    }
  }
  last_critical_ = point;
  critical_points_.push_back(point);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::DetectJump(double dt, double previous_rate, Vec x)
{
  // The step's increment x against the path tangent's prediction dt (d lambda / dt) K^{-1} q at
  // either end: on a continuous path one of them predicts it to O(dt); after a jump both are far off.
  double deviation[2];
  PetscFunctionBeginUser;
  for (int end = 0; end < 2; ++end) {
    const Vec    tangent   = end == 0 ? previous_tangent_ : path_tangent_;
    const double scale     = dt * (end == 0 ? previous_rate : point_.load_factor_rate);
    double       predicted = 0, error = 0;
    PetscCall(VecWAXPY(dx_, -scale, tangent, x));
    PetscCall(WeightedDot(dx_, dx_, &error));
    PetscCall(WeightedDot(tangent, tangent, &predicted));
    // A path tangent of zero (nothing loads the model: K^{-1} q = 0) or a load factor at rest
    // predicts nothing, so it cannot tell a jump: such an end does not report one (it reported a
    // jump at every step of a path without load).
    deviation[end] = predicted > 0 && scale != 0 ? std::sqrt(error / predicted) / std::abs(scale) : 0.0;
  }
  // Under load control the load factor only grows, so a step cannot pass a limit point (an extreme
  // of the load factor along the path) and stay on it: it jumped, whatever the tangents predicted
  // (stepped past the buckling load of a slightly eccentric column, both ends' deviations were
  // 3.4 and 1.4).
  const bool limit_under_load = control_ == PathControl::Load && last_critical_.kind == CriticalPointKind::Limit && last_critical_.step == steps_;
  if ((limit_under_load || std::min(deviation[0], deviation[1]) > kJumpDeviation) && last_critical_.kind != CriticalPointKind::Jump) {
    // A step that left the path and changed the negative pivots passed no critical point: it
    // converged on another branch, an unstable one when it has negative pivots (a column under a
    // slightly eccentric load, stepped past its buckling load, landed on the unstable branch
    // bent against the load, and the run called it a limit point).
    CriticalPoint jump;
    if (last_critical_.kind != CriticalPointKind::None && last_critical_.step == steps_) {
      jump.pivots_before = last_critical_.pivots_before;
      jump.pivots_after  = last_critical_.pivots_after;
      critical_points_.pop_back();
    }
    jump.kind        = CriticalPointKind::Jump;
    jump.step        = steps_;
    jump.load_factor = point_.load_factor;
    last_critical_   = jump;
    critical_points_.push_back(last_critical_);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::LoadFactorRate()
{
  PetscFunctionBeginUser;
  if (control_ == PathControl::Load) {
    point_.load_factor_rate = 1.0;
  } else if (control_ == PathControl::Displacement) {
    double path_c;
    PetscCall(VecEntry(path_tangent_, control_row_, &path_c));
    point_.load_factor_rate = model_->analysis.control_value / path_c;
  } else {
    // t advances with the arc length per arc_scale_; the path goes on the way the last step went.
    double norm2 = 0, projection = 1.0;
    PetscCall(WeightedDot(path_tangent_, path_tangent_, &norm2));
    if (have_previous_increment_) {
      PetscCall(WeightedDot(previous_increment_, path_tangent_, &projection));
      projection += psi2_c_ref_ * previous_load_increment_;
    }
    point_.load_factor_rate = (projection < 0 ? -1.0 : 1.0) * arc_scale_ / std::sqrt(norm2 + psi2_c_ref_);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::TryStep(double t, double dt, StepOutcome *outcome)
{
  PetscFunctionBeginUser;
  if (control_ == PathControl::ArcLength) PetscCall(TryArcLengthStep(t, dt, outcome));
  else if (control_ == PathControl::Displacement) PetscCall(TryDisplacementStep(t, dt, outcome));
  else {
    const bool had_tangent = tangent_ready_;
    if (had_tangent) PetscCall(VecCopy(path_tangent_, previous_tangent_));
    PetscCall(integrator_->TryStep(t, dt, outcome));
    if (outcome->converged) {
      ++steps_;
      PetscCall(Linearize(t + dt, t + dt, dt));
      if (had_tangent && tangent_ready_ && stability_) PetscCall(DetectJump(dt, 1.0, integrator_->LastIncrements()));
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::TryArcLengthStep(double t, double dt, StepOutcome *outcome)
{
  const double lambda = point_.load_factor, end = model_->analysis.end_time;
  PetscFunctionBeginUser;
  *outcome = StepOutcome{};
  if (!tangent_ready_) {
    outcome->why = "the tangent at the last equilibrium cannot be factored (it is singular), so there is no arc-length predictor";
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCheck(c_ref_ > 0, comm_, PETSC_ERR_USER_INPUT, "arc-length control needs loads (or prescribed motions) that move the structure");
  const double dl = dt * arc_scale_;
  // Predictor: along K^{-1} q, the way the previous step went.
  double tangent_norm2 = 0, projection = 1.0;
  PetscCall(WeightedDot(path_tangent_, path_tangent_, &tangent_norm2));
  if (have_previous_increment_) {
    PetscCall(WeightedDot(previous_increment_, path_tangent_, &projection));
    projection += psi2_c_ref_ * previous_load_increment_;
  }
  double dlambda = (projection < 0 ? -1.0 : 1.0) * dl / std::sqrt(tangent_norm2 + psi2_c_ref_);
  PetscCall(VecAXPBY(x_, dlambda, 0.0, path_tangent_));
  PetscCall(Correct(dl, NAN, &dlambda, outcome));
  if (!outcome->converged) {
    integrator_->System().GetAssembler().DiscardStep();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  // A step that passes end_time on a rising path lands on it by load control when it can.
  if (dlambda > 0 && lambda < end && lambda + dlambda > end * (1.0 + 1e-12)) {
    StepOutcome landing;
    PetscCall(VecCopy(x_, trial_));
    integrator_->System().GetAssembler().DiscardStep();
    PetscCall(integrator_->TryStep(lambda, end - lambda, &landing));
    if (landing.converged) {
      *outcome = landing;
      ++steps_;
      // The pseudo-time of end_time: the arc step's, in the proportion of its load increment
      // (the last row read t = 1.2 for a load factor of 1 on a straight path).
      outcome->step_taken = dt * (end - lambda) / dlambda;
      PetscCall(Linearize(t + outcome->step_taken, end, end - lambda));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(integrator_->System().GetAssembler().BeginStep(StaticStep(lambda, lambda + dlambda)));
    PetscCall(integrator_->System().GetAssembler().SetIncrements(trial_));
    PetscCall(VecCopy(trial_, x_));
  }
  PetscCall(Commit(dt, dlambda, outcome));
  if (outcome->converged) PetscCall(Linearize(t + dt, lambda + dlambda, dlambda));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::TryDisplacementStep(double t, double dt, StepOutcome *outcome)
{
  double path_c = 0;
  PetscFunctionBeginUser;
  *outcome = StepOutcome{};
  if (!tangent_ready_) {
    outcome->why                  = "the tangent at the last equilibrium cannot be factored (it is singular), so there is no predictor";
    outcome->step_size_irrelevant = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const double target = model_->analysis.control_value * (t + dt), dc = target - control_value_;
  PetscReal    scale;
  PetscCall(VecEntry(path_tangent_, control_row_, &path_c));
  PetscCall(VecNorm(path_tangent_, NORM_INFINITY, &scale));
  if (!(std::abs(path_c) > 1e-12 * scale)) {
    outcome->why = "the controlled coordinate does not move under the load pattern (a turning point of the controlled coordinate); use arc length";
    outcome->step_size_irrelevant = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  double dlambda = dc / path_c;
  PetscCall(VecAXPBY(x_, dlambda, 0.0, path_tangent_));
  PetscCall(Correct(NAN, dc, &dlambda, outcome));
  if (!outcome->converged) {
    integrator_->System().GetAssembler().DiscardStep();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const double previous_rate = point_.load_factor_rate;
  PetscCall(VecCopy(path_tangent_, previous_tangent_));
  PetscCall(Commit(dt, dlambda, outcome));
  if (outcome->converged) {
    control_value_ = target;
    PetscCall(Linearize(t + dt, point_.load_factor + dlambda, dlambda));
    if (tangent_ready_ && stability_) PetscCall(DetectJump(dt, previous_rate, previous_increment_));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::Commit(double dt, double dlambda, StepOutcome *outcome)
{
  MechanicalSystem       &system    = integrator_->System();
  Assembler              &assembler = system.GetAssembler();
  const AnalysisSettings &analysis  = model_->analysis;
  double                  max_rotation;
  PetscFunctionBeginUser;
  PetscCall(assembler.MaxRotationIncrement(&max_rotation));
  if (max_rotation > analysis.max_rotation_increment) {
    outcome->converged = false;
    outcome->why =
        Format("a rotation increment (of a node) of %.4g rad exceeds max_rotation_increment = %.4g rad", max_rotation, analysis.max_rotation_increment);
    assembler.DiscardStep();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecCopy(x_, previous_increment_));
  previous_load_increment_ = dlambda;
  have_previous_increment_ = true;
  // As a load-controlled step commits (the reaction probes and the force elements' state were left
  // at their start: the rows of arc-length and displacement-controlled steps read 0 there).
  PetscCall(integrator_->CommitConvergedStep(dt));
  ++steps_;
  outcome->converged = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::UsePivotingLU(const char *where, const char *why)
{
  PC pc;
  PetscFunctionBeginUser;
  PetscCall(KSPGetPC(ksp_, &pc));
  PetscCall(PCUseMumps(pc));
  banded_lu_ = false;
  // Newton's too, which the checkpoint records: a restart factors as this run does.
  PetscCall(integrator_->UsePivotingLU());
  if (where)
    PetscCall(PetscPrintf(
        comm_, "msflex: a linear solve of %s failed with the banded LU, which does not pivot between nodes (%s); MUMPS factors from here on\n", where, why));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PathFollower::Correct(double dl, double displacement_target, double *dlambda, StepOutcome *outcome)
{
  MechanicalSystem       &system    = integrator_->System();
  Assembler              &assembler = system.GetAssembler();
  const AnalysisSettings &analysis  = model_->analysis;
  const bool              arc       = control_ == PathControl::ArcLength;
  const double            lambda    = point_.load_factor;
  const char             *name      = arc ? "arc-length" : "displacement-control";
  PetscBool               ok;
  PetscReal               norm, first_norm;
  double                  force_scale;
  PetscFunctionBeginUser;
  outcome->converged = false;
  // Newton's banded LU handed over to MUMPS (here, or before the checkpoint this run continues):
  // so does the corrector's, as the run it continues did.
  if (banded_lu_ && integrator_->PivotingLUForced()) PetscCall(UsePivotingLU(nullptr, nullptr));
  PetscCall(StaticResidual(system, lambda, lambda + *dlambda, x_, residual_, &ok, &force_scale));
  if (!ok) {
    std::string where;
    PetscCall(assembler.DescribeUnevaluable(&where));
    outcome->why = "the predicted configuration cannot be evaluated" + (where.empty() ? std::string() : ": " + where);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecNorm(residual_, NORM_2, &first_norm));
  norm = first_norm;
  for (int iteration = 0;; ++iteration) {
    // Newton's test (integrators/newton.hpp): relative to the predictor's residual and to the
    // force level, or at round-off; and the constraint met.
    const double needed = std::max(
        {analysis.newton_atol, iteration > 0 ? analysis.newton_rtol * std::max((double)first_norm, force_scale) : 0.0, assembler.RoundoffForceLevel()});
    double constraint_error = 0.0;
    if (arc) {
      double xWx = 0;
      PetscCall(WeightedDot(x_, x_, &xWx));
      constraint_error = std::abs(xWx + psi2_c_ref_ * (*dlambda) * (*dlambda) - dl * dl) / (dl * dl);
    } else {
      double x_c = 0;
      PetscCall(VecEntry(x_, control_row_, &x_c));
      constraint_error = std::abs(x_c - displacement_target) / std::max(std::abs(displacement_target), 1e-300);
    }
    outcome->newton_iterations = iteration;
    outcome->residual_norm     = norm;
    if (norm <= needed && constraint_error <= 1e-8) {
      outcome->converged = true;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    if (iteration == analysis.max_newton_iterations) {
      outcome->why =
          Format("the %s corrector did not converge in %d iterations: |R| = %.3e at the predictor, %.3e after the last iteration (convergence needs %.3e)",
                 name, iteration, (double)first_norm, (double)norm, needed);
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    // The bordered solve with one factorisation: K dx_R = -R, K dx_F = q.
    KSPConvergedReason reason_R, reason_F;
    PetscBool          geometry_ok;
    PetscCall(PetscLogStagePush(integrator_->AssemblyStage()));
    PetscCall(StaticLoadPattern(system, lambda, lambda + *dlambda, x_, residual_, q_));
    PetscCall(assembler.AssembleJacobian(assembler.Jacobian(), &geometry_ok));
    PetscCall(PetscLogStagePop());
    PetscCall(KSPSetOperators(ksp_, assembler.Jacobian(), assembler.Jacobian()));
    PetscCall(VecAXPBY(work_, -1.0, 0.0, residual_));
    PetscInt iterations_R, iterations_F;
    for (int attempt = 0; attempt < 2; ++attempt) {
      PetscCall(PetscLogStagePush(integrator_->SolveStage()));
      PetscCall(KSPSolve(ksp_, work_, dx_R_));
      PetscCall(KSPGetConvergedReason(ksp_, &reason_R));
      PetscCall(KSPGetIterationNumber(ksp_, &iterations_R));
      PetscCall(KSPSolve(ksp_, q_, dx_F_));
      PetscCall(KSPGetConvergedReason(ksp_, &reason_F));
      PetscCall(KSPGetIterationNumber(ksp_, &iterations_F));
      PetscCall(PetscLogStagePop());
      outcome->linear_iterations += (int)(iterations_R + iterations_F); // the summary's Krylov count: two solves per iteration
      if ((reason_R >= 0 && reason_F >= 0) || !banded_lu_) break;
      // The banded LU does not pivot between nodes: MUMPS gets the same tangent.
      PetscCall(UsePivotingLU(Format("the %s corrector's iteration %d", name, iteration + 1).c_str(), KSPConvergedReasons[reason_R < 0 ? reason_R : reason_F]));
      PetscCall(KSPSetOperators(ksp_, assembler.Jacobian(), assembler.Jacobian()));
    }
    PetscCall(assembler.ZeroRelayEntries(dx_R_));
    PetscCall(assembler.ZeroRelayEntries(dx_F_));
    if (reason_R < 0 || reason_F < 0) {
      PC pc;
      outcome->why =
          Format("the %s corrector's linear solve failed (%s): the tangent is singular", name, KSPConvergedReasons[reason_R < 0 ? reason_R : reason_F]);
      PetscCall(KSPGetPC(ksp_, &pc));
      PetscCall(PCReset(pc));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    double step_lambda;
    if (arc) {
      // (x + dx_R + s dx_F)^T W (...) + psi^2 c_ref (dlambda + s)^2 = dl^2, a quadratic in s.
      double FF = 0, FX = 0, XX = 0, FXold = 0, XXold = 0;
      PetscCall(VecWAXPY(trial_, 1.0, x_, dx_R_));
      PetscCall(WeightedDot(dx_F_, dx_F_, &FF));
      PetscCall(WeightedDot(dx_F_, trial_, &FX));
      PetscCall(WeightedDot(trial_, trial_, &XX));
      PetscCall(WeightedDot(x_, dx_F_, &FXold));
      PetscCall(WeightedDot(x_, trial_, &XXold));
      const double a1 = FF + psi2_c_ref_, a2 = 2.0 * (FX + psi2_c_ref_ * (*dlambda)), a3 = XX + psi2_c_ref_ * (*dlambda) * (*dlambda) - dl * dl;
      const double discriminant = a2 * a2 - 4.0 * a1 * a3;
      if (!(discriminant >= 0) || !(a1 > 0)) {
        outcome->why =
            Format("the arc-length constraint has no real solution in corrector iteration %d (the path turns too sharply for the arc length)", iteration + 1);
        PetscFunctionReturn(PETSC_SUCCESS);
      }
      const double root = std::sqrt(discriminant), s1 = (-a2 + root) / (2.0 * a1), s2 = (-a2 - root) / (2.0 * a1);
      // The root whose increment turns least from the current one (Crisfield's criterion).
      auto turning = [&](double s) { return XXold + s * FXold + psi2_c_ref_ * (*dlambda) * (*dlambda + s); };
      step_lambda  = turning(s1) >= turning(s2) ? s1 : s2;
    } else {
      double x_c = 0, R_c = 0, F_c = 0;
      PetscCall(VecEntry(x_, control_row_, &x_c));
      PetscCall(VecEntry(dx_R_, control_row_, &R_c));
      PetscCall(VecEntry(dx_F_, control_row_, &F_c));
      if (!(std::abs(F_c) > 0)) {
        outcome->why = "the controlled coordinate does not move under the load pattern (a turning point of the controlled coordinate); use arc length";
        PetscFunctionReturn(PETSC_SUCCESS);
      }
      step_lambda = (displacement_target - x_c - R_c) / F_c;
    }
    PetscCall(VecWAXPY(dx_, step_lambda, dx_F_, dx_R_));
    // Safeguard as Newton's: halve the update while the configuration cannot be evaluated.
    double fraction = 1.0;
    for (int attempt = 0; attempt < 9; ++attempt, fraction *= 0.5) {
      PetscCall(VecWAXPY(trial_, fraction, dx_, x_));
      PetscCall(StaticResidual(system, lambda, lambda + *dlambda + fraction * step_lambda, trial_, residual_, &ok, &force_scale));
      if (ok) break;
    }
    if (!ok) {
      std::string where;
      PetscCall(assembler.DescribeUnevaluable(&where));
      outcome->why = Format("the %s update cannot be applied even shortened to 1/256: ", name) +
                     (where.empty() ? std::string("the residual is not finite") : where + ": its nodes turn by nearly pi relative to each other");
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(VecCopy(trial_, x_));
    *dlambda += fraction * step_lambda;
    PetscCall(VecNorm(residual_, NORM_2, &norm));
  }
}

bool PathFollower::ReachedEnd(double t) const
{
  if (control_ == PathControl::ArcLength) return ReachedLoad() || steps_ >= model_->analysis.max_steps;
  return t >= model_->analysis.end_time * (1.0 - 1e-14);
}

void PathFollower::HistoryColumns(std::vector<std::string> *names, std::vector<double> *values) const
{
  names->push_back("load_factor");
  values->push_back(point_.load_factor);
  if (!stability_) return;
  const TangentInertia &inertia = point_.inertia;
  names->insert(names->end(), {"negative_pivots", "determinant_sign", "lowest_eigenvalue", "stiffness_parameter", "critical_point", "critical_load_factor"});
  values->insert(values->end(),
                 {inertia.factored && inertia.symmetric ? (double)inertia.negative_pivots : -1.0, (double)inertia.determinant_sign, point_.lowest_eigenvalue,
                  point_.stiffness_parameter, (double)last_critical_.kind, last_critical_.kind == CriticalPointKind::None ? NAN : last_critical_.load_factor});
}

std::string PathFollower::ProgressNote() const
{
  std::string note;
  if (control_ != PathControl::Load) note += Format("  lambda = %-11.6g", point_.load_factor);
  if (!stability_) return note;
  const TangentInertia &inertia = point_.inertia;
  if (!inertia.factored) note += "  tangent singular";
  else if (inertia.symmetric) note += Format("  neg %" PetscInt_FMT, inertia.negative_pivots);
  else note += Format("  det %c", inertia.determinant_sign > 0 ? '+' : '-');
  if (last_critical_.kind != CriticalPointKind::None) {
    const CriticalPoint &c = last_critical_;
    if (std::isfinite(c.step_start))
      note += Format("  %s between lambda = %.6g and %.6g", CriticalPointName(c.kind), std::min(c.step_start, c.step_end), std::max(c.step_start, c.step_end));
    else note += Format("  %s at lambda = %.6g", CriticalPointName(c.kind), c.load_factor);
    if (c.pivots_before >= 0) note += Format(" (negative pivots %" PetscInt_FMT " -> %" PetscInt_FMT ")", c.pivots_before, c.pivots_after);
    // Pivots changing by more than one: as many critical points in the step, of which only one is
    // named (a column's two bifurcations, 2.0417 and 2.4674, in one step of 0.65).
    if (c.pivots_before >= 0 && c.kind != CriticalPointKind::Jump && std::abs(c.pivots_after - c.pivots_before) > 1)
      note += Format(": %" PetscInt_FMT " critical points in this step, shorter steps separate them", std::abs(c.pivots_after - c.pivots_before));
    if (c.kind == CriticalPointKind::Jump && c.pivots_after > 0) note += ": an unstable equilibrium; shorter steps or arc length follow the path";
  }
  return note;
}

std::string PathFollower::StopAdvice() const
{
  if (control_ == PathControl::Displacement) {
    // At a turning point t* of the controlled displacement (a snap-back in it) the load factor's
    // rate along it, r = d lambda / d t, grows without bound like 1/sqrt(t* - t), and changes sign
    // past it; the corrector then fails at a fixed t. Said when the last three rates grow with one
    // sign and 1/r^2, extrapolated linearly, reaches zero within two more steps of the last's
    // length; or when they change sign with both sides beyond every rate before and 10 times the
    // first, or both beyond 100 times the first (at a limit point of the load factor the rate passes through zero instead, which
    // displacement control passes). Lee's frame: 0.163 at the start; with min_step 1e-4, -4.36,
    // -9.32, -29.7 (t* 0.11 steps ahead); with 1e-6 the halved steps jumped across: -72.7, 92.4,
    // 122 after at most 44.2.
    if (recent_.size() < 3) return "";
    const PathPoint &p0 = recent_[0], &p1 = recent_[1], &p2 = recent_[2];
    const double     r0 = p0.load_factor_rate, r1 = p1.load_factor_rate, r2 = p2.load_factor_rate;
    if (!(std::isfinite(r0) && std::isfinite(r1) && std::isfinite(r2) && r0 != 0 && r1 != 0 && r2 != 0)) return "";
    bool         near = false;
    const double step = p2.t - p1.t;
    if (r0 * r1 > 0 && r1 * r2 > 0 && std::abs(r1) > std::abs(r0) && std::abs(r2) > std::abs(r1) && step > 0) {
      const double w1 = 1.0 / (r1 * r1), w2 = 1.0 / (r2 * r2); // falling linearly to 0 at t*
      near = w2 / (w1 - w2) < 2.0;                             // t* within two steps of the last's length
    }
    // A sign change between rates both a hundred times the first is conclusive on its own: on
    // another processor's rounding the halved steps of Lee's frame jumped back and forth near t*
    // (-154.7, 92.7, -269, 55.6, 758, -117.9), so the last crossing was not beyond every rate before.
    const auto crossed = [&](double a, double b) {
      const double smaller = std::min(std::abs(a), std::abs(b));
      return a * b < 0 && (smaller > std::max(earlier_rate_, 10.0 * std::abs(first_rate_)) || smaller > 100.0 * std::abs(first_rate_));
    };
    if (near || crossed(r0, r1) || crossed(r1, r2))
      return Format("; the load factor's rate along the controlled displacement has grown to %.3g (%.3g at the start), so the displacement "
                    "reaches a turning point of the path (a snap-back), which displacement control cannot pass: follow the path with analysis: "
                    "{control: arc_length} (docs/stability.md)",
                    std::abs(r2) >= std::abs(r1) ? r2 : r1, first_rate_);
    return "";
  }
  if (control_ != PathControl::Load || !stability_ || recent_.size() < 2) return "";
  const PathPoint &now = recent_.back(), &before = recent_[recent_.size() - 2];
  const double     S = now.stiffness_parameter, S_before = before.stiffness_parameter;
  if (!(std::isfinite(S) && S > 0 && S < 0.25)) return "";
  // Near a limit point S^2 falls linearly with lambda.
  std::string where;
  if (std::isfinite(S_before) && S_before > S) {
    const double estimate = now.load_factor + S * S * (now.load_factor - before.load_factor) / (S_before * S_before - S * S);
    where                 = Format(" near t = %.6g", estimate);
  }
  return Format("; the current stiffness parameter has fallen from 1 to %.3g, so the load factor reaches a maximum (a limit point)%s, which load "
                "control cannot pass: follow the path with analysis: {control: arc_length} (docs/stability.md)",
                S, where.c_str());
}

} // namespace msflex
