#include "integrators/step_controller.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {
// The step factor a local error estimate asks for: the estimate goes as dt^2 relative to the
// step's motion (docs/dynamics.md), so the step that meets the tolerance is dt / sqrt(ratio),
// taken with a safety factor of 0.9 as TSAdapt's basic adaptor does. (Where the floor of motion
// dominates it goes as dt^3 and this overshoots a growth, which growth_factor bounds.)
double ErrorStepFactor(double error_ratio) { return error_ratio > 0.0 ? 0.9 / std::sqrt(error_ratio) : INFINITY; }
} // namespace

StepControllerSettings StepControllerSettingsOf(const AnalysisSettings &analysis)
{
  StepControllerSettings settings;
  settings.error_control      = analysis.type == AnalysisType::Dynamic && analysis.step_tolerance > 0.0;
  settings.initial_step       = analysis.initial_step;
  settings.min_step           = analysis.min_step;
  settings.max_step           = analysis.max_step;
  settings.growth_factor      = analysis.growth_factor;
  settings.easy_iterations    = analysis.easy_iterations;
  settings.easy_steps_to_grow = analysis.easy_steps_to_grow;
  return settings;
}

double StepController::Propose(double t, double target) const
{
  const double remaining = target - t;
  // Avoid leaving a sliver shorter than a hundredth of the step before the target.
  if (step_ >= remaining * (1.0 - 1e-12) || remaining - step_ < 1e-2 * step_) return remaining;
  return step_;
}

void StepController::Accept(double dt, int iterations, double error_ratio)
{
  if (settings_.error_control) {
    // easy_run_ holds 1 after a rejection (it is in the checkpoint): the step after it does not
    // grow, as in Hairer and Wanner's controllers (after Newton failures and rotation limits the
    // step otherwise grew back at once into the next failure, a sawtooth: 678 rejections in 1172
    // steps of the slider-crank with max_newton_iterations 2; a user trial).
    const bool after_rejection = easy_run_ > 0;
    easy_run_                  = 0;
    if (error_ratio < 0.0) return; // a step without an estimate (mc's and em's first) keeps the step
    // Grow by at most growth_factor, shrink by at most 5; a step shortened to land on an output
    // time keeps the nominal step unless its estimate asks for less (it says nothing of more).
    // (For a landed step the estimate's own step, unbounded above: a landing of 1e-8 s says the
    // next may be far longer, and the nominal step stays unless it asks for less.)
    const double factor = std::max(ErrorStepFactor(error_ratio), 0.2);
    const bool   landed = dt < step_ * (1.0 - 1e-12);
    step_ = std::clamp(landed ? std::min(step_, dt * factor) : dt * std::min(factor, after_rejection ? 1.0 : settings_.growth_factor), settings_.min_step,
                       settings_.max_step);
    return;
  }
  if (settings_.desired_iterations > 0) {
    const double factor = std::sqrt((double)settings_.desired_iterations / std::max(iterations, 1));
    step_               = std::clamp(dt * std::clamp(factor, 0.5, settings_.growth_factor), settings_.min_step, settings_.max_step);
    return;
  }
  // A step shortened to hit an output time says nothing about the nominal step unless it failed.
  if (iterations <= settings_.easy_iterations) {
    if (++easy_run_ >= settings_.easy_steps_to_grow) {
      step_     = std::min(settings_.max_step, std::max(step_, dt) * settings_.growth_factor);
      easy_run_ = 0;
    }
  } else {
    easy_run_ = 0;
  }
}

bool StepController::Reject(double dt, double error_ratio)
{
  const bool from_min_step = step_ <= settings_.min_step * (1.0 + 1e-12); // (a step Propose stretched from it counts as min_step)
  easy_run_                = settings_.error_control ? 1 : 0;             // see Accept
  step_                    = error_ratio > 1.0 ? dt * std::clamp(ErrorStepFactor(error_ratio), 0.2, 0.9) : 0.5 * dt;
  // Under error control min_step itself is tried before the run gives up (a step asked for just
  // below it stopped the run where min_step might have passed).
  if (settings_.error_control && step_ < settings_.min_step && !from_min_step) step_ = settings_.min_step;
  return step_ >= settings_.min_step;
}

} // namespace msflex
