// From the distributed solver state to the arrays the output file takes: the mesh, frames
// (distributed, or gathered on rank 0 with serial HDF5), and probe samples.
#pragma once

#include "assembly/assembler.hpp"
#include "output/output_file.hpp"

namespace msflex {

// The mesh, with the rigid bodies (their principal axes: RigidBodyPrincipalAxes) and the ground
// markers (joints to the ground, fully fixed nodes). From the whole model.
void BuildOutputMesh(const Model &model, OutputMesh *mesh);

struct BodyPrincipalAxes {
  Vec3 moments;   // principal moments of inertia about the centre of mass, ascending, kg m^2
  Mat3 axes;      // the principal axes (columns, unit, right-handed) at the reference configuration
  Vec3 semi_axes; // semi-axes of the uniform solid ellipsoid of the same mass and inertia, m
};
BodyPrincipalAxes RigidBodyPrincipalAxes(const RigidBody &body);

// Node and element results with the nodal velocities when asked (dynamics): a distributed frame,
// each rank holding its owned nodes and elements, rows numbered by DofMap::global_nodes and
// global_elements, the rigid bodies of its owned nodes and its owned joints (the frame's body and
// joint rows). Works on the whole or the restricted model.
PetscErrorCode GatherFrame(MPI_Comm comm, const Model &model, const Assembler &assembler, const std::vector<ElementResults> &element_results, int step,
                           double time, bool with_velocities, OutputFrame *frame);

// One sample per probe, valid on every rank. Collective.
PetscErrorCode SampleProbes(MPI_Comm comm, const Model &model, const Assembler &assembler, std::vector<ProbeSample> *samples);

} // namespace msflex
