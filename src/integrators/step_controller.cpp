#include "integrators/step_controller.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

StepControllerSettings StepControllerSettingsOf(const AnalysisSettings &analysis)
{
  StepControllerSettings settings;
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

void StepController::Accept(double dt, int iterations)
{
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

bool StepController::Reject(double dt)
{
  easy_run_ = 0;
  step_     = 0.5 * dt;
  return step_ >= settings_.min_step;
}

} // namespace msflex
