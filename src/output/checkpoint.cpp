#include "output/checkpoint.hpp"

#include "core/mpi_util.hpp"
#include "output/hdf5_util.hpp"

#include <cstdio>

namespace msflex {

namespace {

constexpr const char *kFormat     = "msflex checkpoint 1";
constexpr int         kRunNumbers = 11;

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
                                      0.0};
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

} // namespace

PetscErrorCode CheckpointWrite(MPI_Comm comm, const std::string &path, const CheckpointRun &run, const Assembler &assembler)
{
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
  Assembler::StateRecords nodes, joints, bodies;
  assembler.ExportState(&nodes, &joints, &bodies);
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCall(OpenFileCollective(comm, temporary, &file));
    PetscCall(WriteRowsCollective(temporary, file, "nodes", (hsize_t)run.num_nodes, Assembler::kNodeStateSize, nodes.numbers, nodes.values));
    PetscCall(WriteRowsCollective(temporary, file, "joints", (hsize_t)run.num_joints, Assembler::kJointStateSize, joints.numbers, joints.values));
    PetscCall(
        WriteRowsCollective(temporary, file, "rigid_bodies", (hsize_t)run.num_rigid_bodies, Assembler::kRigidBodyStateSize, bodies.numbers, bodies.values));
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

PetscErrorCode CheckpointReadState(MPI_Comm comm, const std::string &path, Assembler *assembler)
{
  std::vector<int>    node_numbers, joint_numbers, body_numbers;
  std::vector<double> nodes, joints, bodies;
  PetscFunctionBeginUser;
  assembler->StateNumbers(&node_numbers, &joint_numbers, &body_numbers);
  PetscCall(RunCollective(comm, [&]() -> PetscErrorCode {
    H5Id file;
    PetscFunctionBeginUser;
    PetscCallHDF5At(path, file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    PetscCall(ReadRows(path, file, "nodes", Assembler::kNodeStateSize, node_numbers, &nodes));
    PetscCall(ReadRows(path, file, "joints", Assembler::kJointStateSize, joint_numbers, &joints));
    PetscCall(ReadRows(path, file, "rigid_bodies", Assembler::kRigidBodyStateSize, body_numbers, &bodies));
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscCall(assembler->ImportState(nodes, joints, bodies));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
