// From the distributed solver state to the arrays the output file takes: the mesh, frames
// gathered on rank 0, and probe samples.
#pragma once

#include "assembly/assembler.hpp"
#include "output/output_file.hpp"

namespace msflex {

void BuildOutputMesh(const Model &model, OutputMesh *mesh);

// Node and element results of the whole model on rank 0 (other ranks get empty arrays), with the
// nodal velocities when asked (dynamics). Collective.
PetscErrorCode GatherFrame(MPI_Comm comm, const Model &model, const Assembler &assembler, const std::vector<ElementResults> &element_results, int step,
                           double time, bool with_velocities, OutputFrame *frame);

// One sample per probe, valid on every rank. Collective.
PetscErrorCode SampleProbes(MPI_Comm comm, const Model &model, const Assembler &assembler, std::vector<ProbeSample> *samples);

} // namespace msflex
