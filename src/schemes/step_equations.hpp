// What the equations of one step are, as every force contributor reads them: the problem, the
// time scheme's coefficients and the times at both ends of the step. The contributors never ask
// which analysis runs; they read these coefficients (as PETSc's IJacobian reads its shift).
//
//   statics               r(x_{n+1}) = 0 with the loads at t_{n+1}; unknowns: increments (u, omega)
//   dynamics              the scheme's balance of momenta (time_scheme.hpp); unknowns: increments
//   initial acceleration  the equations of motion at t with the configuration and velocities of
//                         the start state; unknowns: the accelerations (xddot, wdot spatial),
//                         stored where the increments are stored otherwise (state/state.hpp)
//   initial velocity      the projection of the initial velocities (assembly/velocity_projection.cpp);
//                         unknowns: the velocities (xdot, w spatial), stored like the accelerations
#pragma once

#include "schemes/time_scheme.hpp"

namespace msflex {

enum class StepProblem { Statics, Dynamics, InitialAcceleration, InitialVelocity };

struct StepEquations {
  StepProblem problem = StepProblem::Statics;
  TimeScheme  scheme; // dynamics only
  double      t_start = 0.0, t_end = 0.0;
  // Scales every load, weight and actuator: the load factor of the static stage that precedes a
  // dynamic analysis (the loads at t = 0 brought in gradually), 1 otherwise.
  double load_scale = 1.0;

  bool Dynamic() const { return problem == StepProblem::Dynamics; }
  bool InitialAcceleration() const { return problem == StepProblem::InitialAcceleration; }
  // The unknowns are rates (accelerations or velocities) at the start state, not increments.
  bool RateUnknowns() const { return problem == StepProblem::InitialAcceleration || problem == StepProblem::InitialVelocity; }
  // The mid-point family: forces at the mid-point, loads averaged over the step.
  bool Midpoint() const { return Dynamic() && scheme.Midpoint(); }
  // A step of the Newmark family (newmark, genalpha): equations at t_{n+1}, and the trapezoidal
  // rule for the work and dissipation over the step.
  bool NewmarkFamily() const { return Dynamic() && !scheme.Midpoint(); }
  bool Inertial() const { return problem == StepProblem::Dynamics || problem == StepProblem::InitialAcceleration; }
  // Weights of a load's values at the start and at the end of the step: (1/2, 1/2) for the
  // mid-point family, (0, 1) otherwise (statics and the Newmark family hold at t_{n+1}; the
  // initial-acceleration problem at t, where both ends coincide).
  double LoadWeightStart() const { return (Midpoint() ? 0.5 : 0.0) * load_scale; }
  double LoadWeightEnd() const { return (Midpoint() ? 0.5 : 1.0) * load_scale; }
  // d(inertial acceleration)/d(unknown): the scheme's coefficient, 1 when the unknowns are the
  // accelerations, 0 in statics.
  double InertiaCoefficient() const { return Dynamic() ? scheme.InertiaCoefficient() : InitialAcceleration() ? 1.0 : 0.0; }
};

inline StepEquations StaticStep(double t_start, double t_end) { return {StepProblem::Statics, TimeScheme{}, t_start, t_end}; }
inline StepEquations DynamicStep(const TimeScheme &scheme, double t_start) { return {StepProblem::Dynamics, scheme, t_start, t_start + scheme.dt}; }
inline StepEquations InitialAccelerationProblem(double t) { return {StepProblem::InitialAcceleration, TimeScheme{}, t, t}; }
inline StepEquations InitialVelocityProblem(double t) { return {StepProblem::InitialVelocity, TimeScheme{}, t, t}; }
// A step of the static stage: equilibrium at t with the loads scaled by `load_factor`.
inline StepEquations StaticStageStep(double t, double load_factor) { return {StepProblem::Statics, TimeScheme{}, t, t, load_factor}; }

} // namespace msflex
