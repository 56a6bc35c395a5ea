// From the State to the arrays the output file takes: the mesh, distributed frames, probe samples
// and the joints' history series. Reads the State and the element results (a results view), never
// the assembler.
#pragma once

#include "contributors/beam_contributor.hpp"
#include "dofs/dof_map.hpp"
#include "model/model.hpp"
#include "output/output_file.hpp"
#include "state/state.hpp"

#include <string>
#include <vector>

namespace msflex {

// The mesh, with the rigid bodies (their principal axes: RigidBodyPrincipalAxes) and the ground
// markers (joints to the ground, fully fixed and pinned nodes). From the whole model.
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
PetscErrorCode GatherFrame(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, const std::vector<ElementResults> &element_results,
                           int step, double time, bool with_velocities, OutputFrame *frame);

// One sample per point probe (a node's point: its position x + Lambda offset, displacement from
// the point's reference position, the node's rotation), valid on every rank; *samples is
// overwritten in place. `scratch` (may be null): the records' buffer, kept by a caller that samples
// every step. Collective.
PetscErrorCode SampleProbes(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, std::vector<ProbeSample> *samples,
                            std::vector<double> *scratch = nullptr);

// The series' names in the model's order, whatever the partition (gathered once, on rank 0), and
// where each value gathered in the ranks' order goes: the joints' and the force elements' alike.
struct HistoryGather {
  bool                     gathered = false;
  std::vector<std::string> names;       // in order
  std::vector<size_t>      permutation; // gathered position (the ranks' parts one after the other) -> place in names
  // Scratch kept from row to row (a row allocates nothing once the first has sized them).
  std::vector<double>             local_values;
  std::vector<char>               gathered_values;
  std::vector<const JointState *> owned_joints; // JointHistory's joints of this rank, in slot order
};

// The joints' history series, per joint "<joint>.<quantity>": the released coordinates (tx ty tz
// along, rx ry rz about the joint axes; a free rotation as the rotation vector of the relative
// rotation in joint axes; a dependent translation under its axis) and their rates, and the force
// and moment the joint exerts on its slave (State::joints' reactions). The names are gathered to
// rank 0 once (kept in *cache); values and names are filled on rank 0, empty elsewhere; `names`
// may be null (the rows after the first). Collective.
PetscErrorCode JointHistory(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, HistoryGather *cache, std::vector<std::string> *names,
                            std::vector<double> *values);

// The series of the reaction and element probes, "<probe>.<quantity>": a reaction probe's
// force_x/_y/_z and moment_x/_y/_z (what the supports exert on the node, global axes,
// State::probe_reactions), an element probe's N1 N2 N3 M1 M2 M3 (section frame, mean over the
// Gauss points, from `element_results` of the local elements). Values on every rank; `names` may be
// null (the rows after the first, whose names the result file knows). Collective.
PetscErrorCode ProbeHistory(MPI_Comm comm, const Model &model, const DofMap &map, const State &state, const std::vector<ElementResults> &element_results,
                            std::vector<std::string> *names, std::vector<double> *values);

// History values the ranks hold (HistoryValue: force elements), gathered to rank 0 in the order
// of their keys; names and order are gathered once (kept in *cache). Values and names on rank 0,
// empty elsewhere; `names` may be null. Collective.
PetscErrorCode GatherHistory(MPI_Comm comm, const std::vector<HistoryValue> &local, HistoryGather *cache, std::vector<std::string> *names,
                             std::vector<double> *values);

} // namespace msflex
