// Error conventions. User errors (bad input, impossible models) carry PETSC_ERR_USER_INPUT and a
// message "file:line: error: ..."; a run that cannot converge stops with PETSC_ERR_NOT_CONVERGED
// and a message saying where and why; a file that cannot be read, created or written, or that the
// run must not write (core/file_safety.hpp), carries PETSC_ERR_FILE_OPEN, _READ, _WRITE or
// _UNEXPECTED and a message naming the path and the reason ("cannot create 'x/y.h5': No such file
// or directory"), printed as "msflex: error: <message>". All of these are printed as one line by
// the msflex error handler and end the run with status 1 on every rank; anything else gets PETSc's
// usual trace-back.
#pragma once

#include <petscksp.h>

#include <string>

// PetscCheck for a model error located by a SourceMark.
#define MSFLEX_INPUT_CHECK(cond, mark, fmt, ...)                                                                                                               \
  PetscCheck(cond, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT, "%s:%d: error: " fmt, (mark).file.c_str(), (mark).line, ##__VA_ARGS__)

// A call that reads options (XSetFromOptions, PetscOptionsEnum, ...): an error in it is a bad
// option value (an unknown -snes_type, -pc_type or -partitioner, a value that is not a number),
// reported as one line "bad option: ..." with PETSC_ERR_USER_INPUT instead of a trace. Errors
// that cannot come from a value (memory, MPI, signals, PETSc's own bugs) keep their code.
#define MSFLEX_CALL_READING_OPTIONS(comm, call)                                                                                                                \
  do {                                                                                                                                                         \
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));                                                                                        \
    const PetscErrorCode msflex_options_status_ = (call);                                                                                                      \
    PetscCall(PetscPopErrorHandler());                                                                                                                         \
    if (msflex_options_status_ != PETSC_SUCCESS) PetscCall(msflex::OptionsError(comm, msflex_options_status_));                                                \
  } while (0)

namespace msflex {

// PETSc's message about an option value it cannot convert, which names the value alone, with the
// option that has it in front ("-snes_max_it abc: Input string abc has no integer value"); any
// other message as it is.
std::string WithOptionNamed(const std::string &message);
// Raises the error of a failed call made under MSFLEX_CALL_READING_OPTIONS again, with its message.
PetscErrorCode OptionsError(MPI_Comm comm, PetscErrorCode status);
// Error handler that keeps the first message of the error raised (into the std::string `context`,
// when it is empty) and returns the code unprinted: a library call that may fail for reasons the
// caller reports itself (a Newton solve, an eigensolve) runs under it, and the caller quotes it.
PetscErrorCode CaptureFirstErrorMessage(MPI_Comm comm, int line, const char *function, const char *file, PetscErrorCode code, PetscErrorType type,
                                        const char *message, void *context);
// Whether `code` is one of the errors above that are reported as one line (and end every rank
// cleanly, exit status 1) rather than with a trace-back and MPI_Abort.
bool IsOneLineError(PetscErrorCode code);

// The factorisation package the options name for `ksp` (-[prefix]pc_factor_mat_solver_type) must
// exist for LU or Cholesky of `matrix`'s type: PETSc would find out only at the first
// factorisation, deep inside the first step or eigensolve, with a trace-back. Checked once the
// options are read, it is one line "bad option: ..." before anything is written.
PetscErrorCode CheckFactorSolverAvailable(KSP ksp, Mat matrix);

// Error handler: one clean line for user errors (printed by rank 0 of PETSC_COMM_WORLD, since
// user errors are detected identically on every rank), PETSc's trace-back otherwise.
PetscErrorCode ErrorHandler(MPI_Comm comm, int line, const char *function, const char *file, PetscErrorCode code, PetscErrorType type, const char *message,
                            void *context);

} // namespace msflex
