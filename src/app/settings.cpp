#include "app/settings.hpp"

#include "io/input_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace msflex {

PetscErrorCode SettingsFromOptions(MPI_Comm comm, Model *model, RunOptions *options)
{
  AnalysisSettings &a               = model->analysis;
  PetscInt          easy_iterations = a.easy_iterations, easy_steps = a.easy_steps_to_grow, max_newton = a.max_newton_iterations;
  PetscInt          static_stage_steps = a.static_stage_steps;
  PetscBool         static_stage       = a.static_stage ? PETSC_TRUE : PETSC_FALSE;
  char              initial_velocities[32];
  // -analysis_output_times replaces the input's list; room for as many entries as anyone types.
  std::vector<PetscReal> output_times(1024);
  PetscInt               num_output_times = (PetscInt)output_times.size();
  PetscBool              output_times_set = PETSC_FALSE;
  char                   type[32], integrator[32];
  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(type, AnalysisTypeName(a.type), sizeof(type)));
  PetscCall(PetscStrncpy(integrator, TimeSchemeName(a.integrator), sizeof(integrator)));
  PetscCall(PetscStrncpy(initial_velocities, a.project_initial_velocities ? "projected" : "given", sizeof(initial_velocities)));
  const std::string type_list = AnalysisTypeNameList(), integrator_list = IntegratorNameList();
  PetscOptionsBegin(comm, "analysis_", "Analysis settings (defaults: the input's analysis section)", "msflex");
  PetscCall(PetscOptionsString("-type", type_list.c_str(), "", type, type, sizeof(type), nullptr));
  PetscCall(PetscOptionsString("-integrator", integrator_list.c_str(), "", integrator, integrator, sizeof(integrator), nullptr));
  PetscCall(PetscOptionsReal("-spectral_radius", "rho_infinity of genalpha", "", a.spectral_radius, &a.spectral_radius, nullptr));
  PetscCall(PetscOptionsReal("-end_time", "Final (pseudo-)time", "", a.end_time, &a.end_time, nullptr));
  PetscCall(PetscOptionsReal("-initial_step", "First step size", "", a.initial_step, &a.initial_step, nullptr));
  PetscCall(PetscOptionsReal("-min_step", "Smallest step before giving up", "", a.min_step, &a.min_step, nullptr));
  PetscCall(PetscOptionsReal("-max_step", "Largest step", "", a.max_step, &a.max_step, nullptr));
  PetscCall(PetscOptionsReal("-growth_factor", "Step growth after easy steps", "", a.growth_factor, &a.growth_factor, nullptr));
  PetscCall(PetscOptionsInt("-easy_iterations", "Newton iterations of an easy step", "", easy_iterations, &easy_iterations, nullptr));
  PetscCall(PetscOptionsInt("-easy_steps_to_grow", "Easy steps in a row before growing", "", easy_steps, &easy_steps, nullptr));
  PetscCall(PetscOptionsInt("-max_newton_iterations", "Newton iterations per step", "", max_newton, &max_newton, nullptr));
  PetscCall(
      PetscOptionsReal("-max_rotation_increment", "Largest nodal rotation per step, rad", "", a.max_rotation_increment, &a.max_rotation_increment, nullptr));
  PetscCall(PetscOptionsReal("-newton_rtol", "Newton relative residual tolerance", "", a.newton_rtol, &a.newton_rtol, nullptr));
  PetscCall(PetscOptionsReal("-newton_atol", "Newton absolute residual tolerance", "", a.newton_atol, &a.newton_atol, nullptr));
  PetscCall(
      PetscOptionsRealArray("-output_times", "Times the steps must land on (comma separated)", "", output_times.data(), &num_output_times, &output_times_set));
  PetscCall(PetscOptionsBool("-static_stage", "Dynamic analyses: equilibrium under the loads at t = 0 first", "", static_stage, &static_stage, nullptr));
  PetscCall(PetscOptionsInt("-static_stage_steps", "Load steps of the static stage at first", "", static_stage_steps, &static_stage_steps, nullptr));
  PetscCall(PetscOptionsString("-initial_velocities", "projected, given", "", initial_velocities, initial_velocities, sizeof(initial_velocities), nullptr));
  PetscOptionsEnd();
  PetscCheck(static_stage_steps >= 1, comm, PETSC_ERR_USER_INPUT, "option -analysis_static_stage_steps must be >= 1, got %" PetscInt_FMT, static_stage_steps);
  PetscCheck(!strcmp(initial_velocities, "projected") || !strcmp(initial_velocities, "given"), comm, PETSC_ERR_USER_INPUT,
             "option -analysis_initial_velocities must be projected or given, got '%s'", initial_velocities);
  a.static_stage                = static_stage == PETSC_TRUE;
  a.static_stage_steps          = (int)static_stage_steps;
  a.project_initial_velocities  = !strcmp(initial_velocities, "projected");
  const AnalysisType input_type = a.type;
  PetscCheck(AnalysisTypeFromName(type, &a.type), comm, PETSC_ERR_USER_INPUT, "option -analysis_type must be one of %s, got '%s'", type_list.c_str(), type);
  PetscCheck(TimeSchemeKindFromName(integrator, &a.integrator), comm, PETSC_ERR_USER_INPUT, "option -analysis_integrator must be one of %s, got '%s'",
             integrator_list.c_str(), integrator);
  const bool made_static = input_type != AnalysisType::Static && a.type == AnalysisType::Static;
  if (made_static) { // the reader checked the input for its own (dynamic) analysis only
    InputError error;
    PetscCheck(CheckStaticModel(*model, &error), comm, PETSC_ERR_USER_INPUT, "with -analysis_type static: %s", error.Format().c_str());
  }
  PetscCheck(a.spectral_radius >= 0.0 && a.spectral_radius <= 1.0, comm, PETSC_ERR_USER_INPUT, "option -analysis_spectral_radius must lie in [0, 1], got %g",
             a.spectral_radius);
  if (output_times_set) a.output_times.assign(output_times.begin(), output_times.begin() + num_output_times);
  a.easy_iterations       = (int)easy_iterations;
  a.easy_steps_to_grow    = (int)easy_steps;
  a.max_newton_iterations = (int)max_newton;
  const struct {
    const char *name;
    double      value;
  } positive[] = {{"-analysis_end_time", a.end_time},
                  {"-analysis_initial_step", a.initial_step},
                  {"-analysis_min_step", a.min_step},
                  {"-analysis_max_step", a.max_step},
                  {"-analysis_max_rotation_increment", a.max_rotation_increment},
                  {"-analysis_newton_rtol", a.newton_rtol},
                  {"-analysis_easy_iterations", (double)a.easy_iterations},
                  {"-analysis_easy_steps_to_grow", (double)a.easy_steps_to_grow},
                  {"-analysis_max_newton_iterations", (double)a.max_newton_iterations}};
  for (const auto &p : positive)
    PetscCheck(std::isfinite(p.value) && p.value > 0, comm, PETSC_ERR_USER_INPUT, "option %s must be positive, got %g", p.name, p.value);
  PetscCheck(a.growth_factor >= 1.0, comm, PETSC_ERR_USER_INPUT, "option -analysis_growth_factor must be >= 1, got %g", a.growth_factor);
  PetscCheck(a.min_step <= a.initial_step, comm, PETSC_ERR_USER_INPUT, "min_step %g is larger than initial_step %g", a.min_step, a.initial_step);
  PetscCheck(a.initial_step <= a.max_step, comm, PETSC_ERR_USER_INPUT, "initial_step %g is larger than max_step %g", a.initial_step, a.max_step);
  PetscCheck(std::isfinite(a.newton_atol) && a.newton_atol >= 0, comm, PETSC_ERR_USER_INPUT, "option -analysis_newton_atol must be >= 0, got %g",
             a.newton_atol);
  PetscCheck(a.max_rotation_increment < M_PI, comm, PETSC_ERR_USER_INPUT, "max_rotation_increment must be below pi, got %g", a.max_rotation_increment);
  // A run shortened with -analysis_end_time keeps the output times it still reaches.
  a.output_times.erase(std::remove_if(a.output_times.begin(), a.output_times.end(), [&a](double t) { return t > a.end_time; }), a.output_times.end());
  for (size_t i = 0; i < a.output_times.size(); ++i)
    PetscCheck(a.output_times[i] > 0 && (i == 0 || a.output_times[i] > a.output_times[i - 1]), comm, PETSC_ERR_USER_INPUT,
               "output time %g must be positive and exceed the one before it", a.output_times[i]);

  char     file[PETSC_MAX_PATH_LEN];
  PetscInt every = model->output.every; // default: the input's output.every
  PetscCall(PetscStrncpy(file, model->output.file.c_str(), sizeof(file)));
  PetscOptionsBegin(comm, "output_", "Output settings", "msflex");
  PetscCall(PetscOptionsString("-file", "HDF5 result file", "", file, file, sizeof(file), nullptr));
  PetscCall(PetscOptionsInt("-every", "Write every n-th converged step", "", every, &every, nullptr));
  PetscCall(PetscOptionsBool("-overwrite", "Replace an existing result file", "", options->output_overwrite, &options->output_overwrite, nullptr));
  PetscOptionsEnd();
  PetscCheck(every >= 1, comm, PETSC_ERR_USER_INPUT, "option -output_every must be >= 1, got %" PetscInt_FMT, every);
  options->output_file  = file;
  options->output_every = every;
  PetscCall(PetscOptionsGetBool(nullptr, nullptr, "-quiet", &options->quiet, nullptr));
  options->progress_every = model->output.progress_every; // default: the input's output.progress_every
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-progress_every", &options->progress_every, nullptr));
  PetscCheck(options->progress_every >= 1, comm, PETSC_ERR_USER_INPUT, "option -progress_every must be >= 1, got %" PetscInt_FMT, options->progress_every);

  // Checkpoints; defaults: the input's output.checkpoint, the file next to the output file.
  std::string default_checkpoint = model->output.checkpoint_file;
  if (default_checkpoint.empty()) {
    const std::string &out = options->output_file;
    default_checkpoint     = (out.size() > 3 && out.compare(out.size() - 3, 3, ".h5") == 0 ? out.substr(0, out.size() - 3) : out) + ".ckpt.h5";
  }
  char checkpoint_file[PETSC_MAX_PATH_LEN];
  PetscCall(PetscStrncpy(checkpoint_file, default_checkpoint.c_str(), sizeof(checkpoint_file)));
  options->checkpoint_every     = model->output.checkpoint_every;
  options->checkpoint_wall_time = model->output.checkpoint_wall_time;
  PetscOptionsBegin(comm, "checkpoint_", "Checkpoints for restarts", "msflex");
  PetscCall(PetscOptionsInt("-every", "Converged steps between checkpoints (0: none)", "", options->checkpoint_every, &options->checkpoint_every, nullptr));
  PetscCall(PetscOptionsReal("-wall_time", "Seconds of wall time between checkpoints (0: none)", "", options->checkpoint_wall_time,
                             &options->checkpoint_wall_time, nullptr));
  PetscCall(PetscOptionsString("-file", "Checkpoint file", "", checkpoint_file, checkpoint_file, sizeof(checkpoint_file), nullptr));
  PetscOptionsEnd();
  PetscCheck(options->checkpoint_every >= 0, comm, PETSC_ERR_USER_INPUT, "option -checkpoint_every must be >= 0, got %" PetscInt_FMT,
             options->checkpoint_every);
  PetscCheck(std::isfinite(options->checkpoint_wall_time) && options->checkpoint_wall_time >= 0, comm, PETSC_ERR_USER_INPUT,
             "option -checkpoint_wall_time must be >= 0 seconds, got %g", (double)options->checkpoint_wall_time);
  options->checkpoint_file = checkpoint_file;
  PetscCheck(options->checkpoint_file != options->output_file, comm, PETSC_ERR_USER_INPUT, "the checkpoint file must differ from the output file '%s'",
             options->output_file.c_str());
  char *database;
  PetscCall(PetscOptionsGetAll(nullptr, &database));
  options->options_database = database;
  PetscCall(PetscFree(database));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
