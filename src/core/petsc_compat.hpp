// Compatibility with Debian's PETSc 3.18: PETSC_SUCCESS (an enum from 3.19 on) stands for 0.
// Force-included into every translation unit by CMakeLists.txt.
#pragma once

#include <petscversion.h>

#if PETSC_VERSION_LT(3, 19, 0)
#define PETSC_SUCCESS 0
#endif
