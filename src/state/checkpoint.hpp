// Checkpoints for restarts (docs/options.md, "Checkpoints and restart"): the run's position (step,
// time, step controller, output position, accumulated work), what it was started from (input
// text and path, the options database) and the start-of-step state of every node, joint and rigid
// body, numbered as in the whole model, so that a run continues on any number of ranks. A
// checkpoint is written to a new temporary file beside it (O_EXCL, never through a symbolic link)
// renamed over it at the end, so a run killed while writing one keeps the previous checkpoint.
// Reading validates everything before anything is used (docs/options.md, "Files msflex writes"):
// the marker and format, the fingerprint of the stored input and options, every dataset's shape
// and storage, integer fields, the consistency of the run numbers and finite state values; every
// problem is one line naming the checkpoint (PETSC_ERR_FILE_OPEN / PETSC_ERR_FILE_UNEXPECTED).
#pragma once

#include "state/state.hpp"

#include <petscsys.h>

#include <string>

namespace msflex {

struct CheckpointRun {
  int         step                = 0;   // converged steps so far
  double      time                = 0.0; // (pseudo-)time reached
  double      external_work       = 0.0; // work of the external loads so far (dynamics)
  double      dissipated_energy   = 0.0; // energy dissipated by dampers so far (dynamics)
  int         last_written        = 0;   // step of the last frame written
  long long   history_rows        = 0;   // rows of /history written so far
  double      controller_step     = 0.0; // the step controller's current step and run of easy steps
  int         controller_easy_run = 0;
  double      previous_step       = 0.0;                           // the last converged step's length (Integrator::PreviousStep)
  long long   num_nodes = 0, num_joints = 0, num_rigid_bodies = 0; // sizes of the whole model
  double      initial_energy = 0.0;                                // total energy at the start of the run (dynamics: the energy balance)
  bool        pivoting_lu    = false;                              // Newton factors by MUMPS since the banded LU failed (Integrator::PivotingLUForced)
  std::string input_file;                                          // absolute path of the input file
  std::string input_text;                                          // the input as read
  std::string options;                                             // the PETSc options database of the run (msflex's and the solvers')
  std::string output_file;                                         // the result file the run writes
  std::string run_id;                                              // msflex_run of the result file this checkpoint belongs to (core/file_safety.hpp)
  std::string model_fingerprint; // msflex_model: ModelFingerprint(input_text, options), set by CheckpointWrite / CheckpointReadRun
  std::string mesh_fingerprint;  // FileFingerprint of the mesh file the run read (`mesh:`), "" without one or in older checkpoints
};

// Writes `run` and the start-of-step state to `path` (through a unique temporary beside it), with
// the marker {kCheckpointFormat, ModelFingerprint(run.input_text, run.options), run.run_id}; `run`
// is read on rank 0. Collective.
PetscErrorCode CheckpointWrite(MPI_Comm comm, const std::string &path, const CheckpointRun &run, const State &state, const DofMap &map);
// Reads and validates the run record (rank 0 reads, every rank receives it). Collective.
PetscErrorCode CheckpointReadRun(MPI_Comm comm, const std::string &path, CheckpointRun *run);
// Checks the state tables against the run record's validated counts (shape, storage) and that
// every value is finite and every node's rotation a unit quaternion, reading them on rank 0 in
// blocks of rows; nothing is kept. Collective. For a restart to call before it changes any file.
PetscErrorCode CheckpointValidateState(MPI_Comm comm, const std::string &path, const CheckpointRun &run);
// Gives the state (created for the checkpoint's model, on any number of ranks) the start-of-step
// state of its local nodes, joints and rigid bodies; slaves follow. Collective.
PetscErrorCode CheckpointReadState(MPI_Comm comm, const std::string &path, const Model &model, const DofMap &map, State *state);

} // namespace msflex
