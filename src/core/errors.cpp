#include "core/errors.hpp"

#include <cstring>

#include <string>

namespace msflex {

PetscErrorCode CaptureFirstErrorMessage(MPI_Comm, int, const char *, const char *, PetscErrorCode code, PetscErrorType type, const char *message, void *context)
{
  std::string *captured = static_cast<std::string *>(context);
  if (type == PETSC_ERROR_INITIAL && message && captured->empty()) *captured = message;
  return code;
}

bool IsOneLineError(PetscErrorCode code)
{
  return code == PETSC_ERR_USER_INPUT || code == PETSC_ERR_NOT_CONVERGED || code == PETSC_ERR_FILE_OPEN || code == PETSC_ERR_FILE_READ ||
         code == PETSC_ERR_FILE_WRITE || code == PETSC_ERR_FILE_UNEXPECTED;
}

PetscErrorCode ErrorHandler(MPI_Comm comm, int line, const char *function, const char *file, PetscErrorCode code, PetscErrorType type, const char *message,
                            void *context)
{
  if (!IsOneLineError(code)) return PetscTraceBackErrorHandler(comm, line, function, file, code, type, message, context);
  if (type == PETSC_ERROR_INITIAL) {
    PetscMPIInt world_rank = 0;
    MPI_Comm_rank(PETSC_COMM_WORLD, &world_rank);
    if (world_rank == 0) {
      const bool file_error = code != PETSC_ERR_USER_INPUT && code != PETSC_ERR_NOT_CONVERGED;
      fprintf(stderr, "msflex: %s%s\n", file_error ? "error: " : "", message);
      fflush(stderr);
    }
  }
  return code;
}

// The option given `value` on the command line or in PETSc's options ("" when none is): PETSc's
// messages about a value it cannot convert name the value alone ("Input string abc has no integer
// value"), and the user must find which of the options it was.
static std::string OptionWithValue(const std::string &value)
{
  char *all = nullptr;
  if (value.empty() || PetscOptionsGetAll(nullptr, &all) != PETSC_SUCCESS || !all) return "";
  const std::string text(all);
  std::string       previous, found;
  for (size_t at = 0, end; found.empty(); at = end) {
    at = text.find_first_not_of(' ', at);
    if (at == std::string::npos) break;
    end = text.find(' ', at);
    if (end == std::string::npos) end = text.size();
    const std::string word = text.substr(at, end - at);
    if (word == value && previous.size() > 1 && previous[0] == '-') found = previous;
    previous = word;
  }
  (void)PetscFree(all);
  return found;
}

std::string WithOptionNamed(const std::string &message)
{
  // "Input string abc has no integer value" (or numeric), "Unknown logical value: abc".
  for (const char *pattern : {"Input string ", "Unknown logical value: "}) {
    if (message.rfind(pattern, 0) != 0) continue;
    const size_t      start = std::strlen(pattern);
    const std::string value = message.substr(start, message.find(' ', start) - start);
    if (const std::string option = OptionWithValue(value); !option.empty()) return option + " " + value + ": " + message;
  }
  return message;
}

PetscErrorCode OptionsError(MPI_Comm comm, PetscErrorCode status)
{
  char *specific = nullptr;
  PetscFunctionBeginUser;
  PetscCall(PetscErrorMessage(status, nullptr, &specific));
  const std::string message = WithOptionNamed(specific && specific[0] ? specific : "unreadable value");
  if (status == PETSC_ERR_USER_INPUT || status == PETSC_ERR_NOT_CONVERGED) SETERRQ(comm, status, "%s", message.c_str());
  if (status == PETSC_ERR_MEM || status == PETSC_ERR_PLIB || status == PETSC_ERR_MPI || status == PETSC_ERR_SIG || status == PETSC_ERR_FP)
    SETERRQ(comm, status, "%s", message.c_str());
  SETERRQ(comm, PETSC_ERR_USER_INPUT, "bad option: %s", message.c_str());
}

PetscErrorCode CheckFactorSolverAvailable(KSP ksp, Mat matrix)
{
  PC            pc;
  PetscBool     lu, cholesky, available;
  MatSolverType package;
  MatType       matrix_type;
  const char   *prefix;
  PetscFunctionBeginUser;
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCLU, &lu));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCHOLESKY, &cholesky));
  if (!lu && !cholesky) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCFactorGetMatSolverType(pc, &package));
  if (!package) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCGetOptionsPrefix(pc, &prefix));
  PetscCall(MatGetType(matrix, &matrix_type));
  PetscCall(MatGetFactorAvailable(matrix, package, lu ? MAT_FACTOR_LU : MAT_FACTOR_CHOLESKY, &available));
  if (!available) {
    // What this matrix type can be factored by instead ("mumps always is" was wrong for a dense
    // tangent, -jacobian_mat_type dense).
    std::string others;
    for (const char *candidate : {MATSOLVERMUMPS, MATSOLVERPETSC, MATSOLVERSUPERLU, MATSOLVERSUPERLU_DIST, MATSOLVERUMFPACK, MATSOLVERKLU, MATSOLVERCHOLMOD}) {
      PetscBool can = PETSC_FALSE;
      PetscCall(MatGetFactorAvailable(matrix, candidate, lu ? MAT_FACTOR_LU : MAT_FACTOR_CHOLESKY, &can));
      if (can) others += (others.empty() ? "" : ", ") + std::string(candidate);
    }
    SETERRQ(PetscObjectComm((PetscObject)ksp), PETSC_ERR_USER_INPUT,
            "bad option: -%spc_factor_mat_solver_type %s: no %s factorisation of that name for matrix type %s (available for it: %s)", prefix ? prefix : "",
            package, lu ? "LU" : "Cholesky", matrix_type, others.empty() ? "none" : others.c_str());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
