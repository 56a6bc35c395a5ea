#include "core/shell_pc.hpp"

#include <cstring>

namespace msflex {

PetscErrorCode ShellContextIfNamed(PC pc, const char *name, void **context)
{
  PetscBool   shell;
  const char *shell_name = nullptr;
  PetscFunctionBeginUser;
  *context = nullptr;
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCSHELL, &shell));
  if (!shell) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PCShellGetName(pc, &shell_name));
  if (shell_name && std::strcmp(shell_name, name) == 0) PetscCall(PCShellGetContext(pc, context));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
