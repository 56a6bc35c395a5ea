// Error conventions. User errors (bad input, impossible models) carry PETSC_ERR_USER_INPUT and a
// message "file:line: error: ..."; a run that cannot converge stops with PETSC_ERR_NOT_CONVERGED
// and a message saying where and why; a file that cannot be read, created or written, or that the
// run must not write (core/file_safety.hpp), carries PETSC_ERR_FILE_OPEN, _READ, _WRITE or
// _UNEXPECTED and a message naming the path and the reason ("cannot create 'x/y.h5': No such file
// or directory"), printed as "msflex: error: <message>". All of these are printed as one line by
// the msflex error handler and end the run with status 1 on every rank; anything else gets PETSc's
// usual trace-back.
#pragma once

#include <petscsys.h>

// PetscCheck for a model error located by a SourceMark.
#define MSFLEX_INPUT_CHECK(cond, mark, fmt, ...)                                                                                                               \
  PetscCheck(cond, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT, "%s:%d: error: " fmt, (mark).file.c_str(), (mark).line, ##__VA_ARGS__)

namespace msflex {

// Whether `code` is one of the errors above that are reported as one line (and end every rank
// cleanly, exit status 1) rather than with a trace-back and MPI_Abort.
bool IsOneLineError(PetscErrorCode code);

// Error handler: one clean line for user errors (printed by rank 0 of PETSC_COMM_WORLD, since
// user errors are detected identically on every rank), PETSc's trace-back otherwise.
PetscErrorCode ErrorHandler(MPI_Comm comm, int line, const char *function, const char *file, PetscErrorCode code, PetscErrorType type, const char *message,
                            void *context);

} // namespace msflex
