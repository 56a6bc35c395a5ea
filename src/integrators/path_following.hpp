// Path following in statics and the stability of the path (docs/stability.md).
//
// Load control (analysis.control: load) steps the load factor lambda = t as the integrator always
// did. Arc length (Crisfield 1981) and displacement control (Batoz & Dhatt 1979) make lambda an
// unknown beside the increments x, with one more equation:
//
//   arc length     x^T W x + psi^2 c_ref dlambda^2 = dl^2   (W: 1 for translations, l^2 for
//                  rotations; c_ref = dx_F0^T W dx_F0 of the first step, so psi = 1 weighs load
//                  and displacement alike; psi = 0: cylindrical)
//   displacement   x_c = c(t + dt) - c_n                    (c = control_value * t)
//
// solved by the bordering method: per iteration one factorisation of the tangent K and two solves,
// K dx_R = -R, K dx_F = q (q = -dR/dlambda), then dlambda from the constraint and
// dx = dx_R + dlambda dx_F. The arc-length predictor is dx_F of the last equilibrium scaled to the
// arc length, its sign that of the previous step's increment projected on dx_F (Feng, Peric &
// Owen 1995); of the two roots of the quadratic constraint the corrector takes the one whose
// increment turns least from the current one (Crisfield). The pseudo-time t of an arc-length
// analysis is the arc length scaled so that the first step's t-increment is its load increment
// (t ~ lambda while the path is straight); the step controller's halving and growth act on it
// unchanged, and the arc length shrinks or grows with sqrt(desired_iterations / iterations).
//
// After every converged step, whatever the control, the tangent at the new equilibrium (omega =
// 0) is factored (integrators/tangent_factor.hpp): its negative pivots, its lowest eigenvalue mu,
// and the current stiffness parameter S = c_0 / c with c = q^T K^{-1} q (1 at the start; 0 at a
// limit point, where c passes through infinity and S changes sign; unchanged in sign at a
// bifurcation, where q is orthogonal to the critical mode). A change of the negative pivots
// between two steps is a critical point: a limit point when S changed sign, else a bifurcation
// point. Between the two equilibria lambda(t) is the cubic through their load factors and rates
// (Hermite; the rate d lambda / dt follows from the path tangent K^{-1} q): a limit load is its
// extremum, a bifurcation load its value where mu, interpolated linearly in t, passes zero.
#pragma once

#include "integrators/integrator.hpp"
#include "integrators/tangent_factor.hpp"

#include <string>
#include <vector>

namespace msflex {

// Jump: a load- or displacement-controlled step that converged on another branch of the path,
// having passed a limit point of its control (a snap-through, or a snap-back under displacement
// control); the path in between is not followed.
enum class CriticalPointKind { None = 0, Limit = 1, Bifurcation = 2, Jump = 3 };
const char *CriticalPointName(CriticalPointKind kind);

// What the path says at one equilibrium.
struct PathPoint {
  double         t = 0.0, load_factor = 0.0, load_factor_increment = 0.0;
  TangentInertia inertia;
  double         lowest_eigenvalue   = NAN; // mu of the pencil (K, D)
  double         stiffness_parameter = NAN; // S = c_0 / c
  double         load_factor_rate    = NAN; // d lambda / d t along the path, from its tangent K^{-1} q
};

struct CriticalPoint {
  CriticalPointKind kind          = CriticalPointKind::None;
  double            load_factor   = NAN;
  int               step          = 0;
  PetscInt          pivots_before = -1, pivots_after = -1;
  // The step's ends when the point could not be located within it (the lowest eigenvalue, which
  // locates it, did not pass zero: a second critical point after a first); load_factor is then
  // the step's middle.
  double step_start = NAN, step_end = NAN;
};

class PathFollower {
public:
  PathFollower()                                = default;
  PathFollower(const PathFollower &)            = delete;
  PathFollower &operator=(const PathFollower &) = delete;
  ~PathFollower();

  // For the static analysis of `integrator` (its model and map). Collective.
  PetscErrorCode Setup(MPI_Comm comm, Integrator *integrator);
  // The equilibrium at pseudo-time t (the reference at the start, or a restart's state: load
  // control only, which the restart's own check ensures). Collective.
  PetscErrorCode Start(double t);
  // One attempt at the step t -> t + dt under the analysis' control; as Integrator::TryStep. A
  // converged step is linearised and checked for critical points. Collective.
  PetscErrorCode TryStep(double t, double dt, StepOutcome *outcome);

  // Whether the analysis has reached its end at pseudo-time t: t = end_time, or for arc length
  // lambda >= end_time (or max_steps steps).
  bool   ReachedEnd(double t) const;
  bool   StoppedByMaxSteps() const { return steps_ >= model_->analysis.max_steps && !ReachedLoad(); }
  double LoadFactor() const { return point_.load_factor; }
  // The critical point found by the last step (kind None if none).
  const CriticalPoint              &LastCriticalPoint() const { return last_critical_; }
  const std::vector<CriticalPoint> &CriticalPoints() const { return critical_points_; }

  // History series of a static analysis: load_factor and, with stability on, negative_pivots,
  // determinant_sign, lowest_eigenvalue, stiffness_parameter, critical_point (0 none, 1 limit,
  // 2 bifurcation, 3 snap-through) and critical_load_factor (NaN when none). The names never change during a run.
  void HistoryColumns(std::vector<std::string> *names, std::vector<double> *values) const;
  // For the progress line: "lambda = ..., neg. pivots ..." and the critical point passed, if any.
  std::string ProgressNote() const;
  // After the last attempt at a step from t failed: what the path says about why (a limit point
  // under load control), or "". Collective.
  std::string StopAdvice() const;

private:
  bool ReachedLoad() const { return point_.load_factor >= model_->analysis.end_time * (1.0 - 1e-14); }
  // The equilibrium just reached at pseudo-time t and load factor lambda.
  PetscErrorCode Linearize(double t, double lambda, double load_factor_increment);
  PetscErrorCode DetectCriticalPoint(const PathPoint &previous);
  // point_.load_factor_rate from the path tangent at the last equilibrium.
  PetscErrorCode LoadFactorRate();
  // After a load- or displacement-controlled step of size dt with increments x: whether it jumped
  // to another branch (previous_rate: d lambda / dt at the step's start).
  PetscErrorCode DetectJump(double dt, double previous_rate, Vec x);
  // The bordered Newton iterations from the predictor (x_, dlambda) to convergence. Collective.
  PetscErrorCode Correct(double dl, double displacement_target, double *dlambda, StepOutcome *outcome);
  PetscErrorCode TryArcLengthStep(double t, double dt, StepOutcome *outcome);
  PetscErrorCode TryDisplacementStep(double t, double dt, StepOutcome *outcome);
  // After a converged corrector: the rotation check, joint reactions and the commit.
  PetscErrorCode Commit(double dt, double dlambda, StepOutcome *outcome);
  PetscErrorCode WeightedDot(Vec a, Vec b, double *dot);
  // The corrector's banded LU failed at `where` (null: Newton's did) and MUMPS factors from here on,
  // Newton's tangent too.
  PetscErrorCode UsePivotingLU(const char *where, const char *why);

  MPI_Comm      comm_       = MPI_COMM_NULL;
  Integrator   *integrator_ = nullptr;
  const Model  *model_      = nullptr;
  const DofMap *map_        = nullptr;
  PathControl   control_    = PathControl::Load;
  bool          stability_  = true;

  Mat           tangent_ = nullptr; // K at the last equilibrium (the factors refer to it)
  TangentFactor factor_;
  KSP           ksp_       = nullptr; // the corrector's linear solver (prefix path_)
  bool          banded_lu_ = false;   // it factors by a banded LU chosen by structure (no pivoting between nodes)
  Vec           x_ = nullptr, residual_ = nullptr, q_ = nullptr, dx_R_ = nullptr, dx_F_ = nullptr, dx_ = nullptr, trial_ = nullptr, work_ = nullptr;
  Vec           weights_ = nullptr, scale_ = nullptr, mode_ = nullptr, path_tangent_ = nullptr, previous_increment_ = nullptr, previous_tangent_ = nullptr;

  PathPoint              point_;  // the last equilibrium
  std::vector<PathPoint> recent_; // the last three, oldest first
  // StopAdvice's reference: the load factor's rate at the path's first point, and the largest
  // before the last three points.
  double                     first_rate_ = NAN, earlier_rate_ = 0.0;
  CriticalPoint              last_critical_;
  std::vector<CriticalPoint> critical_points_;
  double                     c_0_ = NAN, c_ref_ = NAN, arc_scale_ = NAN, psi2_c_ref_ = 0.0;
  double                     symmetry_tolerance_      = 0.0; // the tangent's symmetry test: < 0 (never symmetric) under follower loads
  double                     previous_load_increment_ = 0.0;
  bool                       have_previous_increment_ = false, tangent_ready_ = false;
  int                        steps_ = 0;
  // Displacement control: the controlled unknown and its value at the last equilibrium.
  PetscInt control_row_   = -1;
  double   control_value_ = 0.0;
};

} // namespace msflex
