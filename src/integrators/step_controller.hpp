// Step-size control in the style of PETSc's TSAdapt: halve on failure, grow after a run of easy
// steps, and never step past the next output time or the end. Shared by statics (the step is a
// load-factor / pseudo-time increment) and dynamics.
#pragma once

#include "model/model.hpp"

#include <algorithm>

namespace msflex {

struct StepControllerSettings {
  double initial_step       = 0.1;
  double min_step           = 1e-6;
  double max_step           = 1.0;
  double growth_factor      = 1.5;
  int    easy_iterations    = 5;
  int    easy_steps_to_grow = 2;
  // > 0: after every converged step the step becomes dt * sqrt(desired_iterations / iterations),
  // within [dt / 2, growth_factor * dt] and [min_step, max_step] (Crisfield's adaptive arc length),
  // instead of growing after runs of easy steps.
  int desired_iterations = 0;
  // Dynamics with step_tolerance: the step follows the local error estimate (Accept's and Reject's
  // error_ratio, the estimate over the tolerance, which goes as dt^2) instead of easy iterations.
  bool error_control = false;
};

// The analysis' step settings (initial, min and max step, growth, easy iterations and steps);
// desired_iterations stays 0 (the caller sets it for arc length).
StepControllerSettings StepControllerSettingsOf(const AnalysisSettings &analysis);

class StepController {
public:
  explicit StepController(const StepControllerSettings &settings) : settings_(settings), step_(settings.initial_step) {}
  // The next step from t, shortened to land exactly on `target` (next output time or the end).
  double Propose(double t, double target) const;
  // A converged step of size dt taking `iterations` Newton iterations; error_ratio: its local error
  // estimate over the tolerance (error control), negative without one.
  void Accept(double dt, int iterations, double error_ratio = -1.0);
  // A failed attempt of size dt: halves it, or with error_ratio > 1 (a converged step whose error
  // estimate exceeds the tolerance) shortens it to the step that estimate asks for. Returns false
  // when the new step is below min_step (under error control min_step itself is tried first).
  bool Reject(double dt, double error_ratio = -1.0);
  // The state a checkpoint keeps, and its restoration.
  double CurrentStep() const { return step_; }
  int    EasyRun() const { return easy_run_; }
  // A restart may narrow [min_step, max_step]: the restored step is kept within them (bitwise the
  // checkpoint's when they are unchanged: every step the controller proposes lies within them).
  void Restore(double step, int easy_run) { step_ = std::min(std::max(step, settings_.min_step), settings_.max_step), easy_run_ = easy_run; }

private:
  StepControllerSettings settings_;
  double                 step_;
  int                    easy_run_ = 0;
};

} // namespace msflex
