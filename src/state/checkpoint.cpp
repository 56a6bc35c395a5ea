#include "state/checkpoint.hpp"

#include "core/hdf5_util.hpp"
#include "core/mpi_util.hpp"

#include <cstdio>

namespace msflex {

namespace {

constexpr const char *kFormat     = "msflex checkpoint 3";
constexpr int         kRunNumbers = 12;

// The run record's numbers, in a fixed order.
void PackNumbers(const CheckpointRun &run, double *numbers)
{
  const double values[kRunNumbers] = {(double)run.step,
                                      run.time,
                                      run.external_work,
                                      (double)run.last_written,
                                      (double)run.history_rows,
                                      run.controller_step,
                                      (double)run.controller_easy_run,
                                      (double)run.num_nodes,
                                      (double)run.num_joints,
                                      (double)run.num_rigid_bodies,
                                      run.initial_energy,
                                      run.dissipated_energy};
  std::copy(values, values + kRunNumbers, numbers);
}

void UnpackNumbers(const double *numbers, CheckpointRun *run)
{
  run->step                = (int)numbers[0];
  run->time                = numbers[1];
  run->external_work       = numbers[2];
  run->last_written        = (int)numbers[3];
  run->history_rows        = (long long)numbers[4];
  run->controller_step     = numbers[5];
  run->controller_easy_run = (int)numbers[6];
  run->num_nodes           = (long long)numbers[7];
  run->num_joints          = (long long)numbers[8];
  run->num_rigid_bodies    = (long long)numbers[9];
  run->initial_energy      = numbers[10];
  run->dissipated_energy   = numbers[11];
}

// Text as a 1-D dataset of bytes (any length, also 0).
PetscErrorCode WriteText(const std::string &label, hid_t parent, const char *name, const std::string &text)
{
  const hsize_t size = text.size();
  H5Id          space, dataset;
  PetscFunctionBeginUser;
  PetscCallHDF5At(label, space = H5Screate_simple(1, &size, nullptr));
  PetscCallHDF5At(label, dataset = H5Dcreate2(parent, name, H5T_NATIVE_CHAR, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (size > 0) PetscCallHDF5At(label, H5Dwrite(dataset, H5T_NATIVE_CHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode ReadText(const std::string &label, hid_t parent, const char *name, std::string *text)
{
  H5Id dataset, space;
  PetscFunctionBeginUser;
  PetscCheck(H5Lexists(parent, name, H5P_DEFAULT) > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s' is not an msflex checkpoint: no %s", label.c_str(),
             name);
  PetscCallHDF5At(label, dataset = H5Dopen2(parent, name, H5P_DEFAULT));
  PetscCallHDF5At(label, space = H5Dget_space(dataset));
  const hssize_t size = H5Sget_simple_extent_npoints(space);
  text->assign((size_t)std::max<hssize_t>(size, 0), '\0');
  if (size > 0) PetscCallHDF5At(label, H5Dread(dataset, H5T_NATIVE_CHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text->data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The start-of-step state in records of fixed size: node: position (3), tracked rotation
// quaternion w x y z (4), translational velocity, acceleration and pseudo-acceleration (9), the
// same for the rotation in the body frame (9), the reaction on its prescribed DOFs (6); joint:
// released coordinates (6), the free rotation's C_n row-major (9), the drive's reaction (1), the
// coordinates' rates, accelerations and pseudo-accelerations (18); rigid body: motion of its
// centre of mass (9); damped beam element: the motion of its strains and curvatures at its two
// Gauss points (36). Only start-of-step values are
// kept: everything else (current configuration, slave placement, loads, the time scheme's
// coefficients) follows from them and the time at the next step, so a restarted run repeats the
// original one to the last bit.
constexpr int kNodeStateSize = 31, kJointStateSize = 34, kRigidBodyStateSize = 9, kBeamStrainSize = 36;

struct StateRecords {
  std::vector<int>    numbers; // in the whole model
  std::vector<double> values;
};

void PutVec3(const Vec3 &v, double *out)
{
  for (int i = 0; i < 3; ++i) out[i] = v(i);
}

Vec3 GetVec3(const double *in) { return Vec3(in[0], in[1], in[2]); }

void PutMotion(const MotionState &motion, double *out)
{
  PutVec3(motion.velocity, out);
  PutVec3(motion.acceleration, out + 3);
  PutVec3(motion.pseudo_acceleration, out + 6);
}

MotionState GetMotion(const double *in) { return {GetVec3(in), GetVec3(in + 3), GetVec3(in + 6)}; }

// The records of what this rank owns, with their numbers in the whole model.
void ExportState(const State &state, const DofMap &map, int rank, StateRecords *nodes, StateRecords *joints, StateRecords *bodies)
{
  *nodes = *joints = *bodies = StateRecords{};
  for (PetscInt l = 0; l < map.num_owned_nodes; ++l) {
    const NodeState &s = state.nodes[l];
    double           record[kNodeStateSize];
    PutVec3(s.position_start, record);
    record[3] = s.rotation_start.w, record[4] = s.rotation_start.x, record[5] = s.rotation_start.y, record[6] = s.rotation_start.z;
    PutMotion(s.translation_motion, record + 7);
    PutMotion(s.rotation_motion, record + 16);
    for (int i = 0; i < 6; ++i) record[25 + i] = s.prescribed_reaction(i);
    nodes->numbers.push_back(map.global_nodes[map.local_nodes[l]]);
    nodes->values.insert(nodes->values.end(), record, record + kNodeStateSize);
  }
  for (const JointState &J : state.joints) {
    if (map.joint_rank[J.joint] != rank) continue;
    double record[kJointStateSize];
    for (int c = 0; c < kJointMaxReleased; ++c) record[c] = J.start.q[c];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) record[kJointMaxReleased + 3 * i + k] = J.start.free_rotation_start(i, k);
    record[kJointMaxReleased + 9] = J.drive_reaction;
    PutMotion(J.coordinate_motion[0], record + 16);
    PutMotion(J.coordinate_motion[1], record + 25);
    joints->numbers.push_back(map.global_joints[J.joint]);
    joints->values.insert(joints->values.end(), record, record + kJointStateSize);
  }
  for (const RigidBodyState &body : state.bodies) {
    double record[kRigidBodyStateSize];
    PutMotion(body.centre_of_mass, record);
    bodies->numbers.push_back(body.global_index);
    bodies->values.insert(bodies->values.end(), record, record + kRigidBodyStateSize);
  }
}

// The strain motion of the local (damped) elements, with their numbers in the whole model.
void ExportBeamStrains(const State &state, const DofMap &map, StateRecords *records)
{
  *records = StateRecords{};
  for (size_t k = 0; k < state.beam_strains.size(); ++k) {
    double record[kBeamStrainSize];
    for (int gp = 0; gp < 2; ++gp) {
      PutMotion(state.beam_strains[k].strain[gp], record + 18 * gp);
      PutMotion(state.beam_strains[k].curvature[gp], record + 18 * gp + 9);
    }
    records->numbers.push_back(map.global_elements[map.local_elements[k]]);
    records->values.insert(records->values.end(), record, record + kBeamStrainSize);
  }
}

// Takes the records of every local node and joint and of the rank's rigid bodies, in state order.
PetscErrorCode ImportState(const std::vector<double> &nodes, const std::vector<double> &joints, const std::vector<double> &bodies, State *state)
{
  PetscFunctionBeginUser;
  PetscCheck(nodes.size() == kNodeStateSize * state->nodes.size() && joints.size() == kJointStateSize * state->joints.size() &&
                 bodies.size() == kRigidBodyStateSize * state->bodies.size(),
             PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "state records do not match the local nodes, joints and rigid bodies");
  for (size_t l = 0; l < state->nodes.size(); ++l) {
    const double *record = &nodes[kNodeStateSize * l];
    NodeState    &s      = state->nodes[l];
    s.position_start     = GetVec3(record);
    s.rotation_start     = Quaternion{record[3], record[4], record[5], record[6]};
    s.translation_motion = GetMotion(record + 7);
    s.rotation_motion    = GetMotion(record + 16);
    for (int i = 0; i < 6; ++i) s.prescribed_reaction(i) = record[25 + i];
    s.displacement_increment.setZero();
    s.rotation_increment.setZero();
    StateUpdateNode(StaticStep(0.0, 0.0), &s);
  }
  for (size_t j = 0; j < state->joints.size(); ++j) {
    const double *record = &joints[kJointStateSize * j];
    JointState   &J      = state->joints[j];
    for (int c = 0; c < kJointMaxReleased; ++c) J.start.q[c] = record[c], J.increment[c] = 0.0;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) J.start.free_rotation_start(i, k) = record[kJointMaxReleased + 3 * i + k];
    J.drive_reaction       = record[kJointMaxReleased + 9];
    J.coordinate_motion[0] = GetMotion(record + 16);
    J.coordinate_motion[1] = GetMotion(record + 25);
  }
  for (size_t b = 0; b < state->bodies.size(); ++b) state->bodies[b].centre_of_mass = GetMotion(&bodies[kRigidBodyStateSize * b]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode CheckpointWrite(MPI_Comm comm, const std::string &path, const CheckpointRun &run, const State &state, const DofMap &map)
{
  PetscMPIInt       rank;
  const std::string temporary = path + ".tmp";
  PetscFunctionBeginUser;
  // Rank 0: the run record.
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    H5Id   file, group;
    double numbers[kRunNumbers];
    PetscFunctionBeginUser;
    PetscCallHDF5At(temporary, file = H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
    PetscCallHDF5At(temporary, group = H5Gcreate2(file, "/run", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    PetscCall(WriteText(temporary, group, "format", kFormat));
    PackNumbers(run, numbers);
    const hsize_t count = kRunNumbers;
    H5Id          space, dataset;
    PetscCallHDF5At(temporary, space = H5Screate_simple(1, &count, nullptr));
    PetscCallHDF5At(temporary, dataset = H5Dcreate2(group, "numbers", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    PetscCallHDF5At(temporary, H5Dwrite(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, numbers));
    PetscCall(WriteText(temporary, group, "input_file", run.input_file));
    PetscCall(WriteText(temporary, group, "input_text", run.input_text));
    PetscCall(WriteText(temporary, group, "options", run.options));
    PetscCall(WriteText(temporary, group, "output_file", run.output_file));
    PetscCallHDF5At(temporary, H5Fclose(file.Release()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  // Every rank: the state records it owns, collectively.
  StateRecords nodes, joints, bodies, strains;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  ExportState(state, map, rank, &nodes, &joints, &bodies);
  ExportBeamStrains(state, map, &strains);
  int local_damped = state.beam_strains.empty() ? 0 : 1, damped;
  PetscCallMPI(MPI_Allreduce(&local_damped, &damped, 1, MPI_INT, MPI_MAX, comm));
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCall(OpenFileCollective(comm, temporary, &file));
    PetscCall(WriteRowsCollective(temporary, file, "nodes", (hsize_t)run.num_nodes, kNodeStateSize, nodes.numbers, nodes.values));
    PetscCall(WriteRowsCollective(temporary, file, "joints", (hsize_t)run.num_joints, kJointStateSize, joints.numbers, joints.values));
    PetscCall(WriteRowsCollective(temporary, file, "rigid_bodies", (hsize_t)run.num_rigid_bodies, kRigidBodyStateSize, bodies.numbers, bodies.values));
    if (damped)
      PetscCall(WriteRowsCollective(temporary, file, "beam_strains", (hsize_t)map.global_count.elements, kBeamStrainSize, strains.numbers, strains.values));
    PetscCallHDF5At(temporary, H5Fclose(file.Release()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    PetscFunctionBeginUser;
    PetscCheck(std::rename(temporary.c_str(), path.c_str()) == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "cannot rename checkpoint '%s' to '%s'",
               temporary.c_str(), path.c_str());
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckpointReadRun(MPI_Comm comm, const std::string &path, CheckpointRun *run)
{
  double numbers[kRunNumbers] = {0};
  PetscFunctionBeginUser;
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    H5Id        file, group, dataset;
    std::string format;
    PetscFunctionBeginUser;
    PetscCheck(H5Fis_hdf5(path.c_str()) > 0, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT, "restart file '%s' does not exist or is not an HDF5 file", path.c_str());
    PetscCallHDF5At(path, file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    PetscCheck(H5Lexists(file, "run", H5P_DEFAULT) > 0, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT, "restart file '%s' is not an msflex checkpoint (no /run)",
               path.c_str());
    PetscCallHDF5At(path, group = H5Gopen2(file, "/run", H5P_DEFAULT));
    PetscCall(ReadText(path, group, "format", &format));
    PetscCheck(format == kFormat, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT, "restart file '%s' has format '%s', this msflex reads '%s'", path.c_str(),
               format.c_str(), kFormat);
    PetscCallHDF5At(path, dataset = H5Dopen2(group, "numbers", H5P_DEFAULT));
    PetscCallHDF5At(path, H5Dread(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, numbers));
    PetscCall(ReadText(path, group, "input_file", &run->input_file));
    PetscCall(ReadText(path, group, "input_text", &run->input_text));
    PetscCall(ReadText(path, group, "options", &run->options));
    PetscCall(ReadText(path, group, "output_file", &run->output_file));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCallMPI(MPI_Bcast(numbers, kRunNumbers, MPI_DOUBLE, 0, comm));
  UnpackNumbers(numbers, run);
  for (std::string *text : {&run->input_file, &run->input_text, &run->options, &run->output_file}) PetscCallMPI(BroadcastString(comm, text));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckpointReadState(MPI_Comm comm, const std::string &path, const Model &model, const DofMap &map, State *state)
{
  std::vector<int>    node_numbers, joint_numbers, body_numbers, element_numbers;
  std::vector<double> nodes, joints, bodies, strains;
  PetscFunctionBeginUser;
  // The numbers of what this rank needs: every local node and joint, its own rigid bodies.
  for (size_t l = 0; l < state->nodes.size(); ++l) node_numbers.push_back(map.global_nodes[map.local_nodes[l]]);
  for (const JointState &J : state->joints) joint_numbers.push_back(map.global_joints[J.joint]);
  for (const RigidBodyState &body : state->bodies) body_numbers.push_back(body.global_index);
  for (size_t k = 0; k < state->beam_strains.size(); ++k) element_numbers.push_back(map.global_elements[map.local_elements[k]]);
  int local_damped = state->beam_strains.empty() ? 0 : 1, damped;
  PetscCallMPI(MPI_Allreduce(&local_damped, &damped, 1, MPI_INT, MPI_MAX, comm));
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCallHDF5At(path, file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    PetscCall(ReadRows(path, file, "nodes", kNodeStateSize, node_numbers, &nodes));
    PetscCall(ReadRows(path, file, "joints", kJointStateSize, joint_numbers, &joints));
    PetscCall(ReadRows(path, file, "rigid_bodies", kRigidBodyStateSize, body_numbers, &bodies));
    if (damped) PetscCall(ReadRows(path, file, "beam_strains", kBeamStrainSize, element_numbers, &strains));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCall(ImportState(nodes, joints, bodies, state));
  for (size_t k = 0; k < state->beam_strains.size(); ++k)
    for (int gp = 0; gp < 2; ++gp) {
      state->beam_strains[k].strain[gp]    = GetMotion(&strains[kBeamStrainSize * k + 18 * gp]);
      state->beam_strains[k].curvature[gp] = GetMotion(&strains[kBeamStrainSize * k + 18 * gp + 9]);
    }
  StateUpdateSlaves(model, state);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
