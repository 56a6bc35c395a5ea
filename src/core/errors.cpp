#include "core/errors.hpp"

namespace msflex {

PetscErrorCode ErrorHandler(MPI_Comm comm, int line, const char *function, const char *file, PetscErrorCode code, PetscErrorType type, const char *message,
                            void *context)
{
  if (code != PETSC_ERR_USER_INPUT && code != PETSC_ERR_NOT_CONVERGED)
    return PetscTraceBackErrorHandler(comm, line, function, file, code, type, message, context);
  if (type == PETSC_ERROR_INITIAL) {
    PetscMPIInt world_rank = 0;
    MPI_Comm_rank(PETSC_COMM_WORLD, &world_rank);
    if (world_rank == 0) {
      fprintf(stderr, "msflex: %s\n", message);
      fflush(stderr);
    }
  }
  return code;
}

} // namespace msflex
