// Run settings: the input's analysis and output sections, overridable by PETSc options.
#pragma once

#include "app/run_analysis.hpp"
#include "model/model.hpp"

#include <petscsys.h>

namespace msflex {

// Applies -analysis_<key> overrides to model->analysis (the input's values are the defaults) and
// reads the -output_* and -quiet options into *options. Collective.
PetscErrorCode SettingsFromOptions(MPI_Comm comm, Model *model, RunOptions *options);

} // namespace msflex
