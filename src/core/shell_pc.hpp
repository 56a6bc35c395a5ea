// msflex's own direct solvers are PCSHELLs told apart by name (core/dense_lu.hpp,
// core/block_envelope_pc.hpp).
#pragma once

#include <petscksp.h>

namespace msflex {

// The context of `pc` when it is a PCSHELL named `name`, else nullptr.
PetscErrorCode ShellContextIfNamed(PC pc, const char *name, void **context);

} // namespace msflex
