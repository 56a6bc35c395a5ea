#include "state/checkpoint.hpp"

#include "core/file_safety.hpp"
#include "core/format.hpp"
#include "core/hdf5_util.hpp"
#include "core/mpi_util.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace msflex {

namespace {

constexpr int kRunNumbers = 13;
// Limits of the stored texts (ReadBoundedText): far above any real input, options database or
// path, and small enough that a damaged size can never exhaust the memory.
constexpr size_t kMaxInputBytes = size_t(256) << 20, kMaxOptionsBytes = size_t(16) << 20, kMaxPathBytes = size_t(64) << 10;
// A stored rotation is a unit quaternion to round-off; anything further off is damage.
constexpr double kUnitQuaternionTolerance = 1e-6;
// Rows read at once while validating the state tables.
constexpr hsize_t kValidationBlockRows = 4096;

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
                                      run.dissipated_energy,
                                      run.previous_step};
  std::copy(values, values + kRunNumbers, numbers);
}

// FNV-1a (64 bit) of the run record: its numbers, the LU flag and every text (each with its
// length), the top 53 bits as a double (exact). The state tables have their row checksums; the
// record's texts of input and options are checked by the model fingerprint, but a bit flipped in
// a number (the time, the step, the external work) that stays plausible restarted the run at the
// wrong time without a word.
double RunRecordChecksum(const CheckpointRun &run)
{
  double numbers[kRunNumbers];
  PackNumbers(run, numbers);
  uint64_t     hash        = Fnv1a(numbers, sizeof numbers);
  const double pivoting_lu = run.pivoting_lu ? 1.0 : 0.0;
  hash                     = Fnv1a(&pivoting_lu, sizeof pivoting_lu, hash);
  for (const std::string *text : {&run.input_file, &run.input_text, &run.options, &run.output_file, &run.mesh_fingerprint}) {
    const uint64_t length = text->size();
    hash                  = Fnv1a(text->data(), text->size(), Fnv1a(&length, sizeof length, hash));
  }
  return (double)(hash >> 11);
}

// "" when `value` is an integer in [lo, hi], else the one-line problem naming `what`.
std::string IntegerProblem(const char *what, double value, double lo, double hi)
{
  if (value == std::floor(value) && value >= lo && value <= hi) return "";
  // The shortest text that reads back as the value: 20 + 1e-14 must not print as "20".
  std::string text;
  for (int digits = 6; digits <= 17; ++digits) {
    text = Format("%.*g", digits, value);
    if (std::strtod(text.c_str(), nullptr) == value) break;
  }
  return Format("%s %s is not an integer in [%.0f, %.0f]", what, text.c_str(), lo, hi);
}

// Validates the numbers (every entry finite already: ReadExactDoubles) and unpacks them; "" or
// the problem. Every cast happens after its range check.
std::string UnpackNumbers(const std::vector<double> &numbers, CheckpointRun *run)
{
  const double kMaxCount = INT_MAX;
  const struct {
    const char *what;
    int         index;
  } integers[] = {{"the step", 0},       {"the last written step", 3}, {"the history row count", 4}, {"the run of easy steps", 6},
                  {"the node count", 7}, {"the joint count", 8},       {"the rigid-body count", 9}};
  for (const auto &field : integers)
    if (std::string problem = IntegerProblem(field.what, numbers[field.index], 0.0, kMaxCount); !problem.empty()) return problem;
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
  run->previous_step       = numbers[12];
  // One history row per converged step plus the initial state's.
  if (run->history_rows != (long long)run->step + 1)
    return Format("history rows %lld do not match step %d (expected %lld)", run->history_rows, run->step, (long long)run->step + 1);
  if (run->last_written > run->step) return Format("the last written step %d is beyond the step %d", run->last_written, run->step);
  if (!(run->controller_step > 0.0)) return Format("the step controller's step %.6g is not positive", run->controller_step);
  if (!(run->previous_step >= 0.0)) return Format("the last step's length %.6g is negative", run->previous_step);
  if (run->num_nodes == 0) return "the model has no nodes";
  return "";
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

// `count` doubles as a 1-D dataset.
PetscErrorCode WriteDoubles(const std::string &label, hid_t parent, const char *name, const double *values, hsize_t count)
{
  H5Id space, dataset;
  PetscFunctionBeginUser;
  PetscCallHDF5At(label, space = H5Screate_simple(1, &count, nullptr));
  PetscCallHDF5At(label, dataset = H5Dcreate2(parent, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  PetscCallHDF5At(label, H5Dwrite(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values));
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
constexpr int kNodeStateSize = 31, kJointStateSize = 34, kRigidBodyStateSize = 9,
              kBeamStrainSize = 63; // 2 Gauss points x (18 motion + 12 previous strains), 2 steps, count

// In the file every record carries one more column: RowChecksum of its values and its row number
// in the whole model. A bit flipped in a value that stays finite and plausible (a position, a
// velocity) passed every other check and changed the restarted run's results.
constexpr int kChecksumColumns = 1;

// FNV-1a (64 bit) of the row number and the record's bytes, its top 53 bits as a double (exact).
double RowChecksum(const double *record, int size, long long row)
{
  const uint64_t hash = Fnv1a(record, sizeof(double) * (size_t)size, Fnv1a(&row, sizeof row));
  return (double)(hash >> 11);
}

// The records with their checksum column appended (records of `size` values, numbered `numbers`).
std::vector<double> WithChecksums(const std::vector<double> &values, const std::vector<int> &numbers, int size)
{
  std::vector<double> out;
  out.reserve(values.size() + numbers.size());
  for (size_t k = 0; k < numbers.size(); ++k) {
    const double *record = &values[k * (size_t)size];
    out.insert(out.end(), record, record + size);
    out.push_back(RowChecksum(record, size, numbers[k]));
  }
  return out;
}

// The records without their checksum column, each checked; `numbers` are their rows.
std::string StripChecksums(const std::vector<double> &stored, const std::vector<int> &numbers, int size, const char *table, std::vector<double> *values)
{
  values->clear();
  values->reserve(numbers.size() * (size_t)size);
  for (size_t k = 0; k < numbers.size(); ++k) {
    const double *record = &stored[k * (size_t)(size + kChecksumColumns)];
    if (record[size] != RowChecksum(record, size, numbers[k]))
      return std::string(table) + " row " + std::to_string(numbers[k]) + " does not match its checksum: the file is damaged";
    values->insert(values->end(), record, record + size);
  }
  return "";
}

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
    double                  record[kBeamStrainSize];
    const BeamStrainMotion &motion = state.beam_strains[k];
    for (int gp = 0; gp < 2; ++gp) {
      PutMotion(motion.strain[gp], record + 18 * gp);
      PutMotion(motion.curvature[gp], record + 18 * gp + 9);
      for (int age = 0; age < 2; ++age)
        for (int i = 0; i < 3; ++i) {
          record[36 + 12 * gp + 6 * age + i]     = motion.previous_strain[age][gp](i);
          record[36 + 12 * gp + 6 * age + 3 + i] = motion.previous_curvature[age][gp](i);
        }
    }
    record[60] = motion.previous_steps[0], record[61] = motion.previous_steps[1], record[62] = motion.previous_count;
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
  PetscMPIInt   rank;
  TemporaryFile temporary; // rank 0; removed by its destructor unless committed
  std::string   temporary_path;
  PetscFunctionBeginUser;
  // Rank 0: a new file beside the checkpoint, with the marker and the run record.
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    H5Id   file, group;
    double numbers[kRunNumbers];
    PetscFunctionBeginUser;
    PetscCall(CreateHdf5Temporary(path, &temporary, &file));
    PetscCall(WriteFileMarkerChecked(path, file, {kCheckpointFormat, ModelFingerprint(run.input_text, run.options), run.run_id}));
    PetscCallHDF5At(path, group = H5Gcreate2(file, "/run", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    PetscCall(WriteText(path, group, "format", kCheckpointFormat));
    PackNumbers(run, numbers);
    PetscCall(WriteDoubles(path, group, "numbers", numbers, kRunNumbers));
    // Apart from the numbers, which checkpoints of this format without it also have: absent is 0.
    const double pivoting_lu = run.pivoting_lu ? 1.0 : 0.0;
    PetscCall(WriteDoubles(path, group, "pivoting_lu", &pivoting_lu, 1));
    PetscCall(WriteText(path, group, "input_file", run.input_file));
    PetscCall(WriteText(path, group, "input_text", run.input_text));
    PetscCall(WriteText(path, group, "options", run.options));
    PetscCall(WriteText(path, group, "output_file", run.output_file));
    // Apart from the texts above, which every checkpoint of this format has: absent is "".
    if (!run.mesh_fingerprint.empty()) PetscCall(WriteText(path, group, "mesh_fingerprint", run.mesh_fingerprint));
    const double checksum = RunRecordChecksum(run);
    PetscCall(WriteDoubles(path, group, "checksum", &checksum, 1));
    PetscCallHDF5At(path, H5Fclose(file.Release()));
    temporary_path = temporary.Path();
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCallMPI(BroadcastString(comm, &temporary_path));
  // Every rank: the state records it owns, collectively, into the temporary (by its unique name).
  StateRecords nodes, joints, bodies, strains;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  ExportState(state, map, rank, &nodes, &joints, &bodies);
  ExportBeamStrains(state, map, &strains);
  int local_damped = state.beam_strains.empty() ? 0 : 1, damped;
  PetscCallMPI(MPI_Allreduce(&local_damped, &damped, 1, MPI_INT, MPI_MAX, comm));
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCall(OpenFileCollective(comm, temporary_path, &file));
    PetscCall(WriteRowsCollective(path, file, "nodes", (hsize_t)run.num_nodes, kNodeStateSize + kChecksumColumns, nodes.numbers,
                                  WithChecksums(nodes.values, nodes.numbers, kNodeStateSize)));
    PetscCall(WriteRowsCollective(path, file, "joints", (hsize_t)run.num_joints, kJointStateSize + kChecksumColumns, joints.numbers,
                                  WithChecksums(joints.values, joints.numbers, kJointStateSize)));
    PetscCall(WriteRowsCollective(path, file, "rigid_bodies", (hsize_t)run.num_rigid_bodies, kRigidBodyStateSize + kChecksumColumns, bodies.numbers,
                                  WithChecksums(bodies.values, bodies.numbers, kRigidBodyStateSize)));
    if (damped)
      PetscCall(WriteRowsCollective(path, file, "beam_strains", (hsize_t)map.global_count.elements, kBeamStrainSize + kChecksumColumns, strains.numbers,
                                    WithChecksums(strains.values, strains.numbers, kBeamStrainSize)));
    PetscCallHDF5At(path, H5Fclose(file.Release()));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  // Rank 0: the complete file replaces the previous checkpoint in one rename.
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    PetscFunctionBeginUser;
    const std::string problem = AppendCheckpointFooter(temporary.Path());
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s", problem.c_str());
    PetscCall(CommitHdf5Temporary(&temporary, Durability::Synced));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

namespace {

// Rank 0's part of CheckpointReadRun: every check before anything is taken from the file.
PetscErrorCode ReadRunRecord(const std::string &path, CheckpointRun *run)
{
  const char *p = path.c_str();
  H5Id        file;
  PetscFunctionBeginUser;
  // The classification checks the whole file's checksum before HDF5 reads a byte of it: a footer
  // whose checksum does not match is damage, refused here. No footer: a file of another kind or
  // format, which the checks below name, or one of this format whose end was cut or damaged.
  ExistingFile existing;
  std::string  problem = ClassifyExistingFile(path, &existing);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  // What is not a regular file is refused before HDF5 opens it: the open of a FIFO without a writer
  // blocked for good, deaf to SIGTERM (a directory HDF5's open names, as before).
  std::error_code no_throw;
  PetscCheck(existing.kind != ExistingKind::NotRegular || std::filesystem::is_directory(path, no_throw), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN,
             "cannot read the checkpoint '%s': %s", p, NotRegularFileProblem(path).c_str());
  PetscCall(OpenHdf5File(path, H5F_ACC_RDONLY, H5P_DEFAULT, &file));
  PetscCheck(existing.kind != ExistingKind::MsflexResult, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' is an msflex result file, not a checkpoint; restart from the run's checkpoint (by default <output name>.ckpt.h5)", p);
  PetscCheck(existing.kind == ExistingKind::MsflexCheckpoint, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s' is not an msflex checkpoint: it is %s", p,
             ExistingKindName(existing.kind));
  PetscCheck(!existing.legacy, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' has format '%s' without file markers (written by an earlier msflex); this msflex reads '%s' with markers", p, existing.marker.format.c_str(),
             kCheckpointFormat);
  PetscCheck(existing.marker.format == kCheckpointFormat, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s' has format '%s'; this msflex reads '%s'", p,
             existing.marker.format.c_str(), kCheckpointFormat);
  PetscCheck(existing.checksummed, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' has no checksum at its end: it is not a complete checkpoint of format %s (or its end is damaged)", p, kCheckpointFormat);
  PetscCheck(!existing.marker.run.empty() && !existing.marker.model.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' is damaged: its marker has no run or model fingerprint", p);
  std::vector<double> numbers; // of the validated length only
  problem = ReadExactDoubles(file, "/run/numbers", kRunNumbers, &numbers);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
  problem = UnpackNumbers(numbers, run);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
  run->pivoting_lu = false;
  if (H5Lexists(file, "/run/pivoting_lu", H5P_DEFAULT) > 0) { // /run exists: its numbers were read
    problem = ReadExactDoubles(file, "/run/pivoting_lu", 1, &numbers);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
    PetscCheck(numbers[0] == 0.0 || numbers[0] == 1.0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': /run/pivoting_lu is %.6g, not 0 or 1", p, numbers[0]);
    run->pivoting_lu = numbers[0] == 1.0;
  }
  const struct {
    const char  *name;
    size_t       limit;
    std::string *text;
  } texts[] = {{"/run/input_file", kMaxPathBytes, &run->input_file},
               {"/run/input_text", kMaxInputBytes, &run->input_text},
               {"/run/options", kMaxOptionsBytes, &run->options},
               {"/run/output_file", kMaxPathBytes, &run->output_file}};
  for (const auto &text : texts) {
    problem = ReadBoundedText(file, text.name, text.limit, text.text);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
  }
  run->mesh_fingerprint.clear();
  if (H5Lexists(file, "/run/mesh_fingerprint", H5P_DEFAULT) > 0) {
    problem = ReadBoundedText(file, "/run/mesh_fingerprint", kMaxPathBytes, &run->mesh_fingerprint);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
  }
  run->model_fingerprint = existing.marker.model;
  run->run_id            = existing.marker.run;
  PetscCheck(ModelFingerprint(run->input_text, run->options) == run->model_fingerprint, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' is damaged: its stored input and options do not match its fingerprint", p);
  // Last, over what was read as it was read (the numbers as unpacked pack back to themselves).
  problem = ReadExactDoubles(file, "/run/checksum", 1, &numbers);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
  PetscCheck(numbers[0] == RunRecordChecksum(*run), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' is damaged: its run record (/run: time, step, work, texts) does not match its checksum", p);
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Reads rows [first, first + rows) of the 2-D float64 dataset into *block (rows x columns).
PetscErrorCode ReadBlock(const std::string &path, hid_t dataset, hsize_t first, hsize_t rows, hsize_t columns, std::vector<double> *block)
{
  H5Id          file_space, memory_space;
  const hsize_t start[2] = {first, 0}, count[2] = {rows, columns};
  PetscFunctionBeginUser;
  block->resize(rows * columns);
  PetscCallHDF5At(path, file_space = H5Dget_space(dataset));
  PetscCallHDF5At(path, H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start, nullptr, count, nullptr));
  PetscCallHDF5At(path, memory_space = H5Screate_simple(2, count, nullptr));
  PetscCallHDF5At(path, H5Dread(dataset, H5T_NATIVE_DOUBLE, memory_space, file_space, H5P_DEFAULT, block->data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Rank 0's part of CheckpointValidateState.
PetscErrorCode ValidateTables(const std::string &path, const CheckpointRun &run)
{
  const char *p = path.c_str();
  H5Id        file;
  PetscFunctionBeginUser;
  PetscCall(OpenHdf5File(path, H5F_ACC_RDONLY, H5P_DEFAULT, &file));
  const struct {
    const char *name;
    long long   rows;
    int         size; // the record's values; the file has its checksum as well
  } tables[] = {
      {"/nodes", run.num_nodes, kNodeStateSize}, {"/joints", run.num_joints, kJointStateSize}, {"/rigid_bodies", run.num_rigid_bodies, kRigidBodyStateSize}};
  for (const auto &table : tables) {
    const hsize_t     columns = (hsize_t)(table.size + kChecksumColumns);
    const std::string problem = CheckTableShape(file, table.name, (hsize_t)table.rows, columns);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
    H5Id                dataset;
    std::vector<double> block;
    PetscCallHDF5At(path, dataset = H5Dopen2(file, table.name, H5P_DEFAULT));
    for (hsize_t first = 0; first < (hsize_t)table.rows; first += kValidationBlockRows) {
      const hsize_t rows = std::min<hsize_t>(kValidationBlockRows, (hsize_t)table.rows - first);
      PetscCall(ReadBlock(path, dataset, first, rows, columns, &block));
      for (hsize_t r = 0; r < rows; ++r) {
        const double *record = &block[r * columns];
        for (hsize_t c = 0; c < columns; ++c)
          PetscCheck(std::isfinite(record[c]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s row %llu holds a value that is not a finite number", p,
                     table.name, (unsigned long long)(first + r));
        if (table.size == kNodeStateSize) {
          const double norm = std::sqrt(record[3] * record[3] + record[4] * record[4] + record[5] * record[5] + record[6] * record[6]);
          PetscCheck(std::abs(norm - 1.0) <= kUnitQuaternionTolerance, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
                     "'%s': %s row %llu: the rotation is not a unit quaternion (norm %.6f)", p, table.name, (unsigned long long)(first + r), norm);
        }
        PetscCheck(record[table.size] == RowChecksum(record, table.size, (long long)(first + r)), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
                   "'%s': %s row %llu does not match its checksum: the file is damaged", p, table.name, (unsigned long long)(first + r));
      }
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode CheckpointReadRun(MPI_Comm comm, const std::string &path, CheckpointRun *run)
{
  PetscFunctionBeginUser;
  PetscCall(RunOnRoot(comm, [&] { return ReadRunRecord(path, run); }));
  // The record travels as its (validated) numbers and texts.
  std::vector<double> numbers(kRunNumbers);
  PackNumbers(*run, numbers.data());
  PetscCallMPI(MPI_Bcast(numbers.data(), kRunNumbers, MPI_DOUBLE, 0, comm));
  PetscMPIInt rank;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank != 0) {
    const std::string problem = UnpackNumbers(numbers, run);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_PLIB, "the broadcast run record does not validate: %s", problem.c_str());
  }
  for (std::string *text :
       {&run->input_file, &run->input_text, &run->options, &run->output_file, &run->run_id, &run->model_fingerprint, &run->mesh_fingerprint})
    PetscCallMPI(BroadcastString(comm, text));
  int pivoting_lu = run->pivoting_lu ? 1 : 0;
  PetscCallMPI(MPI_Bcast(&pivoting_lu, 1, MPI_INT, 0, comm));
  run->pivoting_lu = pivoting_lu != 0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckpointValidateState(MPI_Comm comm, const std::string &path, const CheckpointRun &run)
{
  PetscFunctionBeginUser;
  PetscCall(RunOnRoot(comm, [&] { return ValidateTables(path, run); }));
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
  const DofMap::GlobalCount &count = map.global_count;
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCall(OpenHdf5File(path, H5F_ACC_RDONLY, H5P_DEFAULT, &file));
    // The shapes once more against this model's counts (CheckpointValidateState checked the
    // values against the record's), so that no row number reads beyond a table.
    const struct {
      const char *name;
      hsize_t     rows, columns;
    } tables[] = {{"/nodes", (hsize_t)count.nodes, kNodeStateSize + kChecksumColumns},
                  {"/joints", (hsize_t)count.joints, kJointStateSize + kChecksumColumns},
                  {"/rigid_bodies", (hsize_t)count.rigid_bodies, kRigidBodyStateSize + kChecksumColumns}};
    for (const auto &table : tables) {
      const std::string problem = CheckTableShape(file, table.name, table.rows, table.columns);
      PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", path.c_str(), problem.c_str());
    }
    // Each table's rows with their checksums, checked and taken off (the beam strains are not
    // in CheckpointValidateState's tables: only a model with damped beams has them).
    const auto read_checked = [&](const char *name, int size, const std::vector<int> &numbers, std::vector<double> *values) -> PetscErrorCode {
      std::vector<double> stored;
      PetscFunctionBeginUser;
      PetscCall(ReadRows(path, file, name, (hsize_t)(size + kChecksumColumns), numbers, &stored));
      const std::string problem = StripChecksums(stored, numbers, size, name, values);
      PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': /%s", path.c_str(), problem.c_str());
      PetscFunctionReturn(PETSC_SUCCESS);
    };
    PetscCall(read_checked("nodes", kNodeStateSize, node_numbers, &nodes));
    PetscCall(read_checked("joints", kJointStateSize, joint_numbers, &joints));
    PetscCall(read_checked("rigid_bodies", kRigidBodyStateSize, body_numbers, &bodies));
    if (damped) {
      const std::string problem = CheckTableShape(file, "/beam_strains", (hsize_t)count.elements, kBeamStrainSize + kChecksumColumns);
      PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s (the model has damped beams)", path.c_str(), problem.c_str());
      PetscCall(read_checked("beam_strains", kBeamStrainSize, element_numbers, &strains));
    }
    for (const std::vector<double> *values : {&nodes, &joints, &bodies, &strains})
      PetscCheck(std::all_of(values->begin(), values->end(), [](double v) { return std::isfinite(v); }), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
                 "'%s': a state record holds a value that is not a finite number", path.c_str());
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCall(ImportState(nodes, joints, bodies, state));
  for (size_t k = 0; k < state->beam_strains.size(); ++k) {
    BeamStrainMotion &motion = state->beam_strains[k];
    const double     *record = &strains[kBeamStrainSize * k];
    for (int gp = 0; gp < 2; ++gp) {
      motion.strain[gp]    = GetMotion(record + 18 * gp);
      motion.curvature[gp] = GetMotion(record + 18 * gp + 9);
      for (int age = 0; age < 2; ++age)
        for (int i = 0; i < 3; ++i) {
          motion.previous_strain[age][gp](i)    = record[36 + 12 * gp + 6 * age + i];
          motion.previous_curvature[age][gp](i) = record[36 + 12 * gp + 6 * age + 3 + i];
        }
    }
    motion.previous_steps[0] = record[60], motion.previous_steps[1] = record[61];
    motion.previous_count = std::clamp((int)record[62], 0, 2);
  }
  StateUpdateSlaves(model, state);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
