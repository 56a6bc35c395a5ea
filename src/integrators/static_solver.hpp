// Static analysis: Newton (SNES) on the increments of each load step, with the step controller
// driving the pseudo-time t (the load factor when the load functions are the default ramp).
#pragma once

#include "model/model.hpp"

#include <petscsys.h>

#include <string>

namespace msflex {

struct RunOptions {
  std::string output_file;
  PetscBool   output_overwrite = PETSC_FALSE;
  PetscInt    output_every     = 1;
  PetscBool   quiet            = PETSC_FALSE;
};

PetscErrorCode RunStaticAnalysis(MPI_Comm comm, const Model &model, const RunOptions &options);

} // namespace msflex
