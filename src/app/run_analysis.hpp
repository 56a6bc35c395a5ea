// The analysis driver: set-up (partition, unknowns, the distributed model), one step loop with the
// step controller over the integrator's steps (integrators/integrator.hpp), output, checkpoints,
// progress lines and stop signals. Statics steps a load factor (pseudo-time), dynamics time.
#pragma once

#include "model/model.hpp"
#include "state/checkpoint.hpp"

#include <petscsys.h>

#include <csignal>

#include <string>

namespace msflex {

struct RunOptions {
  std::string output_file;
  PetscBool   output_overwrite      = PETSC_FALSE;
  PetscInt    output_every          = 1;
  std::string output_xdmf           = "xdmf3"; // the sidecar's syntax, xdmf3 or xdmf2; set from output.xdmf
  PetscReal   output_flush_interval = 10.0;    // wall-time seconds between flushes of the result file (0: every step); set from output.flush_interval
  PetscBool   quiet                 = PETSC_FALSE;
  PetscInt    progress_every        = 1;
  PetscReal   progress_interval     = 1.0; // wall-time seconds between progress lines (0: no limit); set from output.progress_interval
  // Checkpoints (docs/options.md): every n converged steps, every so many seconds of wall time
  // (0: never), and always on SIGTERM or SIGUSR1, into checkpoint_file.
  PetscInt    checkpoint_every     = 0;
  PetscReal   checkpoint_wall_time = 0.0;
  std::string checkpoint_file;
  std::string options_database; // the run's options, stored in checkpoints
  // Whether an option may ask PETSc for a viewer during the steps (-ksp_view,
  // -snes_converged_reason, ...); without one, the step loop turns PETSc's viewer lookups off.
  bool        petsc_viewers_requested = true;
  std::string restart_file; // the checkpoint a restarted run continues from
  // File safety (docs/options.md, "Files msflex writes"), decided once by main after the run-file
  // policy passed: whether a restart continues its existing result file, the run's identity
  // (msflex_run of its result file and checkpoints) and the model fingerprint (msflex_model).
  bool        continue_output = false;
  std::string run_id;
  std::string model_fingerprint;
  std::string mesh_fingerprint; // FileFingerprint of the mesh file (`mesh:`) when the run started, kept by its checkpoints
};

// How a run ended when it did not fail.
// StoppedBySignal: a checkpoint was written (exit 75); StoppedBySignalWithoutCheckpoint: a run no
// checkpoint can continue (a static analysis under arc length or displacement control) stopped
// with its results written (exit 128 + the signal, the shell's convention for a signalled stop).
enum class RunEnd { Completed, StoppedBySignal, StoppedBySignalWithoutCheckpoint };
// Catches SIGTERM and SIGUSR1 (what batch schedulers send before the wall-time limit), SIGINT and
// SIGHUP while it lives, so that the run finishes its step, checkpoints and stops (a signal before
// the first step stops the run after it); the previous handlers (PETSc's) come back afterwards.
// main holds one from just after PetscInitialize: a signal while the model was read killed the run
// with status 143 and no word, a restart included.
class StopSignalHandlers {
public:
  StopSignalHandlers();
  ~StopSignalHandlers();
  StopSignalHandlers(const StopSignalHandlers &)            = delete;
  StopSignalHandlers &operator=(const StopSignalHandlers &) = delete;

private:
  struct sigaction previous_term_ = {}, previous_usr1_ = {}, previous_int_ = {}, previous_hup_ = {}, previous_xfsz_ = {};
};

// Takes the model: after set-up each rank keeps only its part of it (DofMapRestrictToLocal).
// `restart`: the run record of a checkpoint to continue from (null: a new run); the model must be
// the checkpoint's. A SIGTERM or SIGUSR1 makes the run write a checkpoint after the current step
// and return with *end = StoppedBySignal.
PetscErrorCode RunAnalysis(MPI_Comm comm, Model model, const RunOptions &options, const CheckpointRun *restart, RunEnd *end);

} // namespace msflex
