#include "app/settings.hpp"

#include "app/command_line.hpp"
#include "io/input_reader.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace msflex {

// Whether an option of the database (PetscOptionsGetAll's "-name value -name ...") may be one
// that PETSc reads through PetscOptionsGetViewer while a solve runs: every viewer, converged-reason,
// monitor, draw and test option has one of these words in its name.
namespace {
bool MayRequestViewers(const std::string &database)
{
  std::istringstream words(database);
  std::string        word;
  while (words >> word) {
    if (word.size() < 2 || word[0] != '-' || !std::isalpha((unsigned char)word[1])) continue; // a value
    for (const char *part : {"view", "reason", "monitor", "draw", "test"})
      if (word.find(part) != std::string::npos) return true;
  }
  return false;
}
} // namespace

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
  char                   linear_solver[32], direct_solver[32];
  char                   type[32], integrator[32], em_correction[32], reactions[32], control[32], control_node[256], control_joint[256], control_dof[8] = "";
  PetscInt               condensation_depth = a.condensation_depth; // default: the input's (AnalysisSettings)
  PetscInt               desired_iterations = a.desired_iterations, max_steps = a.max_steps, eigenvalues = a.eigenvalues;
  PetscBool              stability = a.stability ? PETSC_TRUE : PETSC_FALSE, preload = a.preload ? PETSC_TRUE : PETSC_FALSE, shift_set = PETSC_FALSE;
  PetscReal              shift          = a.shift;
  PetscBool              max_step_set   = PETSC_FALSE;
  PetscBool              control_set[4] = {PETSC_FALSE, PETSC_FALSE, PETSC_FALSE, PETSC_FALSE}; // node, joint, dof, value given as options
  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(control, PathControlName(a.control), sizeof(control)));
  PetscCall(PetscStrncpy(control_node, a.control_node.c_str(), sizeof(control_node)));
  PetscCall(PetscStrncpy(control_joint, a.control_joint.c_str(), sizeof(control_joint)));
  PetscCall(PetscStrncpy(type, AnalysisTypeName(a.type), sizeof(type)));
  PetscCall(PetscStrncpy(integrator, TimeSchemeName(a.integrator), sizeof(integrator)));
  PetscCall(PetscStrncpy(linear_solver, LinearSolverKindName(a.linear_solver), sizeof(linear_solver)));   // default: the input's
  PetscCall(PetscStrncpy(direct_solver, DirectSolverChoiceName(a.direct_solver), sizeof(direct_solver))); // default: the input's
  PetscCall(PetscStrncpy(initial_velocities, a.project_initial_velocities ? "projected" : "given", sizeof(initial_velocities)));
  PetscCall(PetscStrncpy(em_correction, EnergyCorrectionName(a.em_correction), sizeof(em_correction))); // default: the input's
  PetscCall(PetscStrncpy(reactions, ReactionPointName(a.reactions), sizeof(reactions)));                // default: the input's
  const std::string type_list = AnalysisTypeNameList(), integrator_list = IntegratorNameList(), control_list = PathControlNameList();
  PetscOptionsBegin(comm, "analysis_", "Analysis settings (defaults: the input's analysis section)", "msflex");
  PetscCall(PetscOptionsString("-type", OptionDescription("-analysis_type"), "", type, type, sizeof(type), nullptr));
  PetscCall(PetscOptionsString("-integrator", OptionDescription("-analysis_integrator"), "", integrator, integrator, sizeof(integrator), nullptr));
  PetscCall(PetscOptionsReal("-spectral_radius", OptionDescription("-analysis_spectral_radius"), "", a.spectral_radius, &a.spectral_radius, nullptr));
  PetscCall(
      PetscOptionsString("-em_correction", OptionDescription("-analysis_em_correction"), "", em_correction, em_correction, sizeof(em_correction), nullptr));
  PetscCall(PetscOptionsString("-reactions", OptionDescription("-analysis_reactions"), "", reactions, reactions, sizeof(reactions), nullptr));
  PetscCall(PetscOptionsReal("-end_time", OptionDescription("-analysis_end_time"), "", a.end_time, &a.end_time, nullptr));
  PetscCall(PetscOptionsReal("-initial_step", OptionDescription("-analysis_initial_step"), "", a.initial_step, &a.initial_step, nullptr));
  PetscCall(PetscOptionsReal("-min_step", OptionDescription("-analysis_min_step"), "", a.min_step, &a.min_step, nullptr));
  PetscCall(PetscOptionsReal("-max_step", OptionDescription("-analysis_max_step"), "", a.max_step, &a.max_step, &max_step_set));
  PetscCall(PetscOptionsReal("-step_tolerance", OptionDescription("-analysis_step_tolerance"), "", a.step_tolerance, &a.step_tolerance, nullptr));
  PetscCall(PetscOptionsReal("-growth_factor", OptionDescription("-analysis_growth_factor"), "", a.growth_factor, &a.growth_factor, nullptr));
  PetscCall(PetscOptionsInt("-easy_iterations", OptionDescription("-analysis_easy_iterations"), "", easy_iterations, &easy_iterations, nullptr));
  PetscCall(PetscOptionsInt("-easy_steps_to_grow", OptionDescription("-analysis_easy_steps_to_grow"), "", easy_steps, &easy_steps, nullptr));
  PetscCall(PetscOptionsInt("-max_newton_iterations", OptionDescription("-analysis_max_newton_iterations"), "", max_newton, &max_newton, nullptr));
  PetscCall(PetscOptionsReal("-max_rotation_increment", OptionDescription("-analysis_max_rotation_increment"), "", a.max_rotation_increment,
                             &a.max_rotation_increment, nullptr));
  PetscCall(PetscOptionsReal("-newton_rtol", OptionDescription("-analysis_newton_rtol"), "", a.newton_rtol, &a.newton_rtol, nullptr));
  PetscCall(PetscOptionsReal("-newton_atol", OptionDescription("-analysis_newton_atol"), "", a.newton_atol, &a.newton_atol, nullptr));
  PetscCall(PetscOptionsReal("-jacobian_reuse", OptionDescription("-analysis_jacobian_reuse"), "", a.jacobian_reuse, &a.jacobian_reuse, nullptr));
  PetscCall(PetscOptionsInt("-condensation_depth", OptionDescription("-analysis_condensation_depth"), "", condensation_depth, &condensation_depth, nullptr));
  PetscCall(
      PetscOptionsString("-linear_solver", OptionDescription("-analysis_linear_solver"), "", linear_solver, linear_solver, sizeof(linear_solver), nullptr));
  PetscCall(
      PetscOptionsString("-direct_solver", OptionDescription("-analysis_direct_solver"), "", direct_solver, direct_solver, sizeof(direct_solver), nullptr));
  PetscCall(PetscOptionsRealArray("-output_times", OptionDescription("-analysis_output_times"), "", output_times.data(), &num_output_times, &output_times_set));
  PetscCall(PetscOptionsString("-control", OptionDescription("-analysis_control"), "", control, control, sizeof(control), nullptr));
  PetscCall(PetscOptionsReal("-arc_length_psi", OptionDescription("-analysis_arc_length_psi"), "", a.arc_length_psi, &a.arc_length_psi, nullptr));
  PetscCall(PetscOptionsInt("-desired_iterations", OptionDescription("-analysis_desired_iterations"), "", desired_iterations, &desired_iterations, nullptr));
  PetscCall(PetscOptionsInt("-max_steps", OptionDescription("-analysis_max_steps"), "", max_steps, &max_steps, nullptr));
  PetscCall(
      PetscOptionsString("-control_node", OptionDescription("-analysis_control_node"), "", control_node, control_node, sizeof(control_node), &control_set[0]));
  PetscCall(PetscOptionsString("-control_joint", OptionDescription("-analysis_control_joint"), "", control_joint, control_joint, sizeof(control_joint),
                               &control_set[1]));
  PetscCall(PetscOptionsString("-control_dof", OptionDescription("-analysis_control_dof"), "", control_dof, control_dof, sizeof(control_dof), &control_set[2]));
  PetscCall(PetscOptionsReal("-control_value", OptionDescription("-analysis_control_value"), "", a.control_value, &a.control_value, &control_set[3]));
  PetscCall(PetscOptionsBool("-stability", OptionDescription("-analysis_stability"), "", stability, &stability, nullptr));
  PetscCall(PetscOptionsInt("-eigenvalues", OptionDescription("-analysis_eigenvalues"), "", eigenvalues, &eigenvalues, nullptr));
  PetscCall(PetscOptionsReal("-shift", OptionDescription("-analysis_shift"), "", shift, &shift, &shift_set));
  PetscCall(PetscOptionsBool("-preload", OptionDescription("-analysis_preload"), "", preload, &preload, nullptr));
  PetscCall(PetscOptionsBool("-static_stage", OptionDescription("-analysis_static_stage"), "", static_stage, &static_stage, nullptr));
  PetscCall(PetscOptionsInt("-static_stage_steps", OptionDescription("-analysis_static_stage_steps"), "", static_stage_steps, &static_stage_steps, nullptr));
  PetscCall(PetscOptionsString("-initial_velocities", OptionDescription("-analysis_initial_velocities"), "", initial_velocities, initial_velocities,
                               sizeof(initial_velocities), nullptr));
  PetscOptionsEnd();
  PetscCheck(static_stage_steps >= 1, comm, PETSC_ERR_USER_INPUT, "option -analysis_static_stage_steps must be >= 1, got %" PetscInt_FMT, static_stage_steps);
  PetscCheck(!strcmp(initial_velocities, "projected") || !strcmp(initial_velocities, "given"), comm, PETSC_ERR_USER_INPUT,
             "option -analysis_initial_velocities must be projected or given, got '%s'", initial_velocities);
  a.static_stage                   = static_stage == PETSC_TRUE;
  a.static_stage_steps             = (int)static_stage_steps;
  a.project_initial_velocities     = !strcmp(initial_velocities, "projected");
  const AnalysisType input_type    = a.type;
  const bool         input_preload = a.preload;
  PetscCheck(AnalysisTypeFromName(type, &a.type), comm, PETSC_ERR_USER_INPUT, "option -analysis_type must be one of %s, got '%s'", type_list.c_str(), type);
  PetscCheck(TimeSchemeKindFromName(integrator, &a.integrator), comm, PETSC_ERR_USER_INPUT, "option -analysis_integrator must be one of %s, got '%s'",
             integrator_list.c_str(), integrator);
  PetscCheck(EnergyCorrectionFromName(em_correction, &a.em_correction), comm, PETSC_ERR_USER_INPUT,
             "option -analysis_em_correction must be resultants or forces, got '%s'", em_correction);
  PetscCheck(ReactionPointFromName(reactions, &a.reactions), comm, PETSC_ERR_USER_INPUT, "option -analysis_reactions must be consistent or scheme, got '%s'",
             reactions);
  PetscCheck(LinearSolverKindFromName(linear_solver, &a.linear_solver), comm, PETSC_ERR_USER_INPUT,
             "option -analysis_linear_solver must be direct or multigrid, got '%s'", linear_solver);
  PetscCheck(DirectSolverChoiceFromName(direct_solver, &a.direct_solver), comm, PETSC_ERR_USER_INPUT,
             "option -analysis_direct_solver must be auto or mumps, got '%s'", direct_solver);
  PetscCheck(PathControlFromName(control, &a.control), comm, PETSC_ERR_USER_INPUT, "option -analysis_control must be one of %s, got '%s'", control_list.c_str(),
             control);
  a.preload = preload == PETSC_TRUE;
  // Dynamics without a max_step steps at initial_step (the input reader's rule), also after
  // -analysis_initial_step or -analysis_type dynamic; statics keep max_step's default of 1.
  if (max_step_set) a.max_step_given = true;
  PetscCheck(std::isfinite(a.step_tolerance) && a.step_tolerance >= 0.0 && a.step_tolerance < 1.0, comm, PETSC_ERR_USER_INPUT,
             "option -analysis_step_tolerance must lie in [0, 1), got %.6g", a.step_tolerance);
  if (!a.max_step_given) a.max_step = DefaultMaxStep(a);
  // The reader checked the input for its own analysis only.
  if (a.type != input_type || a.preload != input_preload) {
    InputError error;
    PetscCheck(CheckModelForAnalysisType(*model, a.type, a.preload, &error), comm, PETSC_ERR_USER_INPUT, "with -analysis_type %s: %s", AnalysisTypeName(a.type),
               error.Format().c_str());
  }
  PetscCheck(std::isfinite(a.arc_length_psi) && a.arc_length_psi >= 0, comm, PETSC_ERR_USER_INPUT, "option -analysis_arc_length_psi must be >= 0, got %.6g",
             a.arc_length_psi);
  PetscCheck(desired_iterations >= 1 && max_steps >= 1 && eigenvalues >= 1, comm, PETSC_ERR_USER_INPUT,
             "options -analysis_desired_iterations, -analysis_max_steps and -analysis_eigenvalues must be >= 1, got %" PetscInt_FMT ", %" PetscInt_FMT
             " and %" PetscInt_FMT,
             desired_iterations, max_steps, eigenvalues);
  // SLEPc's -eps_nev is the number of modes asked for, as analysis.eigenvalues is: given, it
  // replaces it (the solver's own nev follows it, and the modes written are that many).
  PetscInt  nev     = 0;
  PetscBool nev_set = PETSC_FALSE;
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-eps_nev", &nev, &nev_set));
  PetscCheck(!nev_set || nev >= 1, comm, PETSC_ERR_USER_INPUT, "bad option: -eps_nev must be >= 1, got %" PetscInt_FMT, nev);
  if (nev_set) eigenvalues = nev;
  a.desired_iterations = (int)desired_iterations;
  a.max_steps          = (int)max_steps;
  a.eigenvalues        = (int)eigenvalues;
  a.stability          = stability == PETSC_TRUE;
  PetscCheck(!shift_set || std::isfinite(shift), comm, PETSC_ERR_USER_INPUT, "option -analysis_shift must be a finite number, got %.6g", (double)shift);
  a.shift = shift;
  // As the input's keys (the reader's check): the controlled DOF's options apply to displacement
  // control only (they were taken without a word under load control and in dynamics; a user trial).
  static const char *const control_options[4] = {"-analysis_control_node", "-analysis_control_joint", "-analysis_control_dof", "-analysis_control_value"};
  for (int k = 0; k < 4; ++k)
    PetscCheck(!control_set[k] || a.control == PathControl::Displacement, comm, PETSC_ERR_USER_INPUT,
               "option %s applies to displacement control (-analysis_control displacement), but the control is %s", control_options[k],
               PathControlName(a.control));
  PetscCheck(std::isfinite(a.control_value) && a.control_value != 0.0, comm, PETSC_ERR_USER_INPUT,
             "option -analysis_control_value must be a finite number other than zero, got %.6g", a.control_value);
  a.control_node  = control_node;
  a.control_joint = control_joint;
  if (control_dof[0]) {
    a.control_dof = PathControlDof(control_dof);
    PetscCheck(a.control_dof >= 0, comm, PETSC_ERR_USER_INPUT, "option -analysis_control_dof must be one of ux, uy, uz, rx, ry, rz, tx, ty, tz, got '%s'",
               control_dof);
    const std::string mismatch = PathControlDofMismatch(control_dof, !a.control_joint.empty());
    // (Both or neither controlled: the analysis check names that instead.)
    PetscCheck(mismatch.empty() || a.control_joint.empty() == a.control_node.empty(), comm, PETSC_ERR_USER_INPUT, "option -analysis_control_dof: %s",
               mismatch.c_str());
  }
  {
    InputError error;
    PetscCheck(CheckAnalysisSettings(*model, &error), comm, PETSC_ERR_USER_INPUT, "%s", error.Format().c_str());
  }
  PetscCheck(a.spectral_radius >= 0.0 && a.spectral_radius <= 1.0, comm, PETSC_ERR_USER_INPUT, "option -analysis_spectral_radius must lie in [0, 1], got %.6g",
             a.spectral_radius);
  if (output_times_set) a.output_times.assign(output_times.begin(), output_times.begin() + num_output_times);
  PetscCheck(std::isfinite(a.jacobian_reuse) && a.jacobian_reuse >= 0.0 && a.jacobian_reuse < 1.0, comm, PETSC_ERR_USER_INPUT,
             "option -analysis_jacobian_reuse must lie in [0, 1), got %.6g", a.jacobian_reuse);
  PetscCheck(condensation_depth >= 0 && condensation_depth <= 1000000, comm, PETSC_ERR_USER_INPUT,
             "option -analysis_condensation_depth must lie in [0, 1000000] (0: condense whole chains), got %" PetscInt_FMT, condensation_depth);
  a.condensation_depth    = (int)condensation_depth;
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
    PetscCheck(std::isfinite(p.value) && p.value > 0, comm, PETSC_ERR_USER_INPUT, "option %s must be positive, got %.6g", p.name, p.value);
  PetscCheck(a.growth_factor >= 1.0, comm, PETSC_ERR_USER_INPUT, "option -analysis_growth_factor must be >= 1, got %.6g", a.growth_factor);
  // A restart continues with the checkpoint's step (kept within the new min and max steps), not
  // with initial_step: a restart narrowing max_step below the input's initial_step was refused.
  if (!options->restart_file.empty()) {
    PetscCheck(a.min_step <= a.max_step, comm, PETSC_ERR_USER_INPUT, "min_step %.6g is larger than max_step %.6g", a.min_step, a.max_step);
    a.initial_step = std::min(std::max(a.initial_step, a.min_step), a.max_step);
  }
  PetscCheck(a.min_step <= a.initial_step, comm, PETSC_ERR_USER_INPUT, "min_step %.6g is larger than initial_step %.6g", a.min_step, a.initial_step);
  PetscCheck(a.initial_step <= a.max_step, comm, PETSC_ERR_USER_INPUT, "initial_step %.6g is larger than max_step %.6g", a.initial_step, a.max_step);
  PetscCheck(std::isfinite(a.newton_atol) && a.newton_atol >= 0, comm, PETSC_ERR_USER_INPUT, "option -analysis_newton_atol must be >= 0, got %.6g",
             a.newton_atol);
  PetscCheck(a.max_rotation_increment < M_PI, comm, PETSC_ERR_USER_INPUT,
             "option -analysis_max_rotation_increment (max_rotation_increment) must be below pi, got %.6g", a.max_rotation_increment);
  // A run shortened with -analysis_end_time keeps the output times it still reaches, and says
  // which it drops (they went without a word, where the same times in the input are an error).
  const auto beyond = std::stable_partition(a.output_times.begin(), a.output_times.end(), [&a](double t) { return t <= a.end_time; });
  if (beyond != a.output_times.end())
    PetscCall(PetscFPrintf(comm, PETSC_STDERR, "msflex: warning: %zu output time(s) beyond end_time = %.9g are dropped (the first: %.9g)\n",
                           (size_t)(a.output_times.end() - beyond), a.end_time, *beyond));
  a.output_times.erase(beyond, a.output_times.end());
  PetscCheck(a.control != PathControl::ArcLength || a.output_times.empty(), comm, PETSC_ERR_USER_INPUT,
             "output times do not apply to arc-length control, whose steps are lengths along the path");
  for (size_t i = 0; i < a.output_times.size(); ++i)
    PetscCheck(a.output_times[i] > 0 && (i == 0 || a.output_times[i] > a.output_times[i - 1]), comm, PETSC_ERR_USER_INPUT,
               "output time %.6g must be positive and exceed the one before it", a.output_times[i]);

  char     file[PETSC_MAX_PATH_LEN];
  PetscInt every = model->output.every; // default: the input's output.every
  PetscCall(PetscStrncpy(file, model->output.file.c_str(), sizeof(file)));
  options->output_flush_interval = model->output.flush_interval; // default: the input's output.flush_interval
  char xdmf[16];
  PetscCall(PetscStrncpy(xdmf, model->output.xdmf.c_str(), sizeof(xdmf))); // default: the input's output.xdmf
  PetscOptionsBegin(comm, "output_", "Output settings", "msflex");
  PetscCall(PetscOptionsString("-file", OptionDescription("-output_file"), "", file, file, sizeof(file), nullptr));
  PetscCall(PetscOptionsInt("-every", OptionDescription("-output_every"), "", every, &every, nullptr));
  PetscCall(PetscOptionsBool("-overwrite", OptionDescription("-output_overwrite"), "", options->output_overwrite, &options->output_overwrite, nullptr));
  PetscCall(PetscOptionsReal("-flush_interval", OptionDescription("-output_flush_interval"), "", options->output_flush_interval,
                             &options->output_flush_interval, nullptr));
  PetscCall(PetscOptionsString("-xdmf", OptionDescription("-output_xdmf"), "", xdmf, xdmf, sizeof(xdmf), nullptr));
  PetscOptionsEnd();
  PetscCheck(!strcmp(xdmf, "xdmf3") || !strcmp(xdmf, "xdmf2"), comm, PETSC_ERR_USER_INPUT, "option -output_xdmf must be xdmf3 or xdmf2, got '%s'", xdmf);
  options->output_xdmf = xdmf;
  PetscCheck(every >= 1, comm, PETSC_ERR_USER_INPUT, "option -output_every must be >= 1, got %" PetscInt_FMT, every);
  PetscCheck(std::isfinite(options->output_flush_interval) && options->output_flush_interval >= 0, comm, PETSC_ERR_USER_INPUT,
             "option -output_flush_interval must be a finite number of seconds >= 0, got %.6g", (double)options->output_flush_interval);
  options->output_file       = file;
  options->output_every      = every;
  options->progress_every    = model->output.progress_every;    // default: the input's output.progress_every
  options->progress_interval = model->output.progress_interval; // default: the input's output.progress_interval
  PetscOptionsBegin(comm, nullptr, "Progress", "msflex");
  PetscCall(PetscOptionsBool("-quiet", OptionDescription("-quiet"), "", options->quiet, &options->quiet, nullptr));
  PetscCall(PetscOptionsInt("-progress_every", OptionDescription("-progress_every"), "", options->progress_every, &options->progress_every, nullptr));
  PetscCall(
      PetscOptionsReal("-progress_interval", OptionDescription("-progress_interval"), "", options->progress_interval, &options->progress_interval, nullptr));
  PetscOptionsEnd();
  PetscCheck(options->progress_every >= 1, comm, PETSC_ERR_USER_INPUT, "option -progress_every must be >= 1, got %" PetscInt_FMT, options->progress_every);
  PetscCheck(std::isfinite(options->progress_interval) && options->progress_interval >= 0, comm, PETSC_ERR_USER_INPUT,
             "option -progress_interval must be a finite number of seconds >= 0, got %.6g", (double)options->progress_interval);

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
  PetscCall(PetscOptionsInt("-every", OptionDescription("-checkpoint_every"), "", options->checkpoint_every, &options->checkpoint_every, nullptr));
  PetscCall(
      PetscOptionsReal("-wall_time", OptionDescription("-checkpoint_wall_time"), "", options->checkpoint_wall_time, &options->checkpoint_wall_time, nullptr));
  PetscCall(PetscOptionsString("-file", OptionDescription("-checkpoint_file"), "", checkpoint_file, checkpoint_file, sizeof(checkpoint_file), nullptr));
  PetscOptionsEnd();
  PetscCheck(options->checkpoint_every >= 0, comm, PETSC_ERR_USER_INPUT, "option -checkpoint_every must be >= 0, got %" PetscInt_FMT,
             options->checkpoint_every);
  PetscCheck(std::isfinite(options->checkpoint_wall_time) && options->checkpoint_wall_time >= 0, comm, PETSC_ERR_USER_INPUT,
             "option -checkpoint_wall_time must be a finite number of seconds >= 0, got %.6g", (double)options->checkpoint_wall_time);
  options->checkpoint_file = checkpoint_file;
  // Whether the checkpoint is the output file (or any other file of the run), after links, `.`
  // and `..`: the run-file policy in main (CheckRunFiles).
  char *database;
  PetscCall(PetscOptionsGetAll(nullptr, &database));
  options->options_database        = database;
  options->petsc_viewers_requested = MayRequestViewers(database);
  PetscCall(PetscFree(database));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
