// msflex: the command-line program. Reads the model (or a checkpoint with --restart), applies the
// options and runs the analysis (app/run_analysis.hpp).
#include "app/settings.hpp"
#include "core/errors.hpp"
#include "core/hdf5_util.hpp"
#include "core/mpi_util.hpp"
#include "io/input_reader.hpp"
#include "model/analysis_types.hpp"
#include "model/joint_kinds.hpp"
#include "schemes/time_scheme.hpp"
#include "state/checkpoint.hpp"

#include <petscsys.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <utility>

using namespace msflex;

// The usage, the options and the registered choices (analysis types, integrators, joint kinds), as
// -help prints them before PETSc's own options.
static std::string HelpText()
{
  std::string text = "msflex: flexible mechanisms of geometrically exact beams.\n\n"
                     "Usage: msflex INPUT.yaml [PETSc and msflex options]\n"
                     "       msflex --restart CHECKPOINT.h5 [options]   continue a run from its checkpoint\n"
                     "  -analysis_<key> value   override a key of the input's analysis section (see docs/input.md)\n"
                     "  -output_file FILE.h5    result file (default: the input's output.file, or <input name>.h5)\n"
                     "  -output_every N         write every N-th step\n"
                     "  -output_overwrite       replace an existing result file\n"
                     "  -partitioner metis|simple  node partitioning over MPI ranks (default: metis on more than one rank)\n"
                     "  -progress_every N       a progress line every N steps\n"
                     "  -quiet                  no progress lines\n"
                     "  -checkpoint_every N     a checkpoint every N steps\n"
                     "  -checkpoint_wall_time S a checkpoint every S seconds of wall time\n"
                     "  -checkpoint_file FILE   checkpoint file (default: <output>.ckpt.h5); SIGTERM or SIGUSR1 writes one and\n"
                     "                          stops with exit status 75\n"
                     "Solver options (-snes_*, -ksp_*, -pc_*) are PETSc's; the default is Newton with line search and MUMPS LU.\n";
  int         count;
  text += "\nAnalysis types (analysis.type, -analysis_type):\n";
  for (const AnalysisTypeInfo *info = AnalysisTypes(&count), *end = info + count; info != end; ++info)
    text += "  " + std::string(info->name) + std::string(12 - std::min<size_t>(11, std::string(info->name).size()), ' ') + info->description + "\n";
  text += "Path controls of static analyses (analysis.control, -analysis_control):\n";
  for (const PathControlInfo *info = PathControls(&count), *end = info + count; info != end; ++info)
    text += "  " + std::string(info->name) + std::string(14 - std::min<size_t>(13, std::string(info->name).size()), ' ') + info->description + "\n";
  text += "Integrators (analysis.integrator, -analysis_integrator):\n";
  for (const IntegratorInfo *info = Integrators(&count), *end = info + count; info != end; ++info)
    text += "  " + std::string(info->name) + std::string(12 - std::min<size_t>(11, std::string(info->name).size()), ' ') + info->description + "\n";
  text += "Joint kinds (joints: type):\n";
  for (const JointKindInfo *info = JointKinds(&count), *end = info + count; info != end; ++info)
    text += "  " + std::string(info->name) + std::string(12 - std::min<size_t>(11, std::string(info->name).size()), ' ') + info->description + "\n";
  return text;
}

// Every rank reads the model (collectively: the input text and the mesh are shared) and each drops
// what it does not hold once set-up is done. The ranks agree on the outcome, so that every rank
// stops together on bad input; `source` says where an input stored elsewhere came from.
static PetscErrorCode AgreeOnModel(MPI_Comm comm, bool ok, const InputError &error, const std::string &source)
{
  const PetscBool mine = ok ? PETSC_TRUE : PETSC_FALSE;
  PetscBool       all_ok;
  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(&mine, &all_ok, 1, MPIU_BOOL, MPI_LAND, comm));
  PetscCheck(all_ok, comm, PETSC_ERR_USER_INPUT, "%s%s", ok ? "the input could not be read on another rank" : error.Format().c_str(), source.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The checkpoint named by --restart (or -restart), or empty.
static std::string RestartFile(int argc, char **argv)
{
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], "--restart") == 0 || std::strcmp(argv[i], "-restart") == 0) return argv[i + 1];
  return "";
}

// A restart runs with the options of the original run (stored in the checkpoint), overridden by
// those given now; not carried over: the restart option itself, options about one process's
// report, and -output_overwrite (a restart continues its result file, never replaces it).
static PetscErrorCode RestoreOptions(const CheckpointRun &run, int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsInsertString(nullptr, run.options.c_str()));
  for (const char *name : {"--restart", "-restart", "-log_view", "-memory_view", "-options_left", "-help", "-output_overwrite"})
    PetscCall(PetscOptionsClearValue(nullptr, name));
  PetscCall(PetscOptionsInsertArgs(nullptr, argc - 1, argv + 1));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The file-safety policy of the run (docs/options.md, "Files msflex writes"), checked once on
// rank 0 before any file is created or changed: the run's identity (a restart keeps its
// checkpoint's), whether a restart continues its result file, and CheckRunFiles. Collective.
static PetscErrorCode CheckRunFilesOfRun(MPI_Comm comm, const Model &model, const std::string &restart, const CheckpointRun &run, const char *input,
                                         RunOptions *options)
{
  PetscMPIInt rank;
  int         continue_output = 0;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    options->run_id            = restart.empty() ? NewRunId() : run.run_id;
    options->model_fingerprint = restart.empty() ? ModelFingerprint(model.input_text, options->options_database) : run.model_fingerprint;
    ResolvedPath output;
    continue_output = !restart.empty() && ResolvePath(options->output_file, &output).empty() && output.exists ? 1 : 0;
  }
  PetscCallMPI(BroadcastString(comm, &options->run_id));
  PetscCallMPI(BroadcastString(comm, &options->model_fingerprint));
  PetscCallMPI(MPI_Bcast(&continue_output, 1, MPI_INT, 0, comm));
  PetscCheck(!options->run_id.empty(), comm, PETSC_ERR_FILE_OPEN, "cannot obtain random bytes for the run's identity (getrandom, /dev/urandom)");
  options->continue_output = continue_output != 0;
  RunFiles files;
  files.input           = restart.empty() ? input : run.input_file;
  files.mesh            = model.mesh_file;
  files.restart         = restart;
  files.output          = options->output_file;
  files.checkpoint      = options->checkpoint_file;
  files.overwrite       = options->output_overwrite; // never carried into a restart (RestoreOptions)
  files.continue_output = options->continue_output;
  files.run             = restart.empty() ? "" : run.run_id;
  PetscCall(CheckRunFilesCollective(comm, files));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode RunMsflex(int argc, char **argv, RunEnd *end)
{
  MPI_Comm          comm    = PETSC_COMM_WORLD;
  const std::string restart = RestartFile(argc, argv);
  PetscFunctionBeginUser;
  Model         model;
  CheckpointRun run;
  if (!restart.empty()) {
    PetscCall(CheckpointReadRun(comm, restart, &run));
    PetscCall(RestoreOptions(run, argc, argv));
    InputError error;
    const bool ok = ReadModelString(run.input_text, run.input_file, &model, &error, comm);
    PetscCall(AgreeOnModel(comm, ok, error, " (the input stored in " + restart + ")"));
  } else {
    PetscCheck(argc >= 2 && argv[1][0] != '-', comm, PETSC_ERR_USER_INPUT,
               "usage: msflex INPUT.yaml [options] or msflex --restart CHECKPOINT.h5 [options]; run 'msflex -help' for the options");
    InputError error;
    const bool ok = ReadModelFile(argv[1], &model, &error, comm);
    PetscCall(AgreeOnModel(comm, ok, error, ""));
  }
  // A malformed option value (-analysis_end_time abc) is a user error, found alike on every rank.
  RunOptions options;
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  const PetscErrorCode settings_status = SettingsFromOptions(comm, &model, &options);
  PetscCall(PetscPopErrorHandler());
  if (settings_status != PETSC_SUCCESS) {
    char *specific = nullptr;
    PetscCall(PetscErrorMessage(settings_status, nullptr, &specific));
    SETERRQ(comm, PETSC_ERR_USER_INPUT, "bad option: %s", specific ? specific : "unreadable value");
  }
  options.restart_file = restart;
  PetscCall(CheckRunFilesOfRun(comm, model, restart, run, argc >= 2 ? argv[1] : "", &options));
  PetscCall(RunAnalysis(comm, std::move(model), options, restart.empty() ? nullptr : &run, end));
  PetscFunctionReturn(PETSC_SUCCESS);
}

int main(int argc, char **argv)
{
  static const std::string help = HelpText();
  PetscCall(PetscInitialize(&argc, &argv, nullptr, help.c_str()));
  PetscCall(PetscPushErrorHandler(ErrorHandler, nullptr));
  // Nothing of HDF5's error stack is ever printed: every failure is translated into one line
  // where it happens (core/hdf5_files.hpp).
  Hdf5SilenceErrorStack();
  PetscBool help_requested = PETSC_FALSE;
  PetscCall(PetscOptionsHasHelp(nullptr, &help_requested));
  const bool     has_input = (argc >= 2 && argv[1][0] != '-') || !RestartFile(argc, argv).empty();
  PetscErrorCode code      = PETSC_SUCCESS;
  RunEnd         end       = RunEnd::Completed;
  if (has_input || !help_requested) code = RunMsflex(argc, argv, &end);
  // User errors, non-convergence and file errors are agreed on by every rank (RunOnRoot,
  // RunCollective) and reported in one line: finish cleanly. Anything else may have left ranks
  // inside a collective call: abort them all.
  if (code != PETSC_SUCCESS && !IsOneLineError(code)) MPI_Abort(PETSC_COMM_WORLD, (int)code);
  PetscCall(PetscFinalize());
  // 75 (EX_TEMPFAIL): stopped by a signal after a checkpoint; a job script may resubmit.
  if (code != PETSC_SUCCESS) return 1;
  return end == RunEnd::StoppedBySignal ? 75 : 0;
}
