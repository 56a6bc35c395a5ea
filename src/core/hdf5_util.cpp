#include "core/hdf5_util.hpp"

#include <cerrno>

#include <algorithm>
#include <numeric>

namespace msflex {

namespace {

// Selects `rows` (sorted by `order`) of a 2-D dataspace of `columns` as a union of hyperslabs, one
// per run of consecutive rows.
PetscErrorCode SelectRows(const std::string &label, hid_t space, hsize_t columns, const std::vector<int> &rows, const std::vector<size_t> &order)
{
  PetscFunctionBeginUser;
  if (rows.empty()) PetscCallHDF5At(label, H5Sselect_none(space));
  for (size_t k = 0; k < rows.size();) {
    size_t end = k + 1;
    while (end < rows.size() && rows[order[end]] == rows[order[end - 1]] + 1) ++end;
    const hsize_t start[2] = {(hsize_t)rows[order[k]], 0}, block[2] = {end - k, columns};
    PetscCallHDF5At(label, H5Sselect_hyperslab(space, k == 0 ? H5S_SELECT_SET : H5S_SELECT_OR, start, nullptr, block, nullptr));
    k = end;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

std::vector<size_t> FileOrder(const std::vector<int> &rows)
{
  std::vector<size_t> order(rows.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return rows[a] < rows[b]; });
  return order;
}

// Set when the file system refused data this process wrote (WriteRefused).
bool write_refused = false;

} // namespace

std::string Hdf5CallProblem(const std::string &label, const char *call)
{
  // The called function: the first "H5..." name followed by '(' in the call's text.
  std::string text = call, function;
  for (size_t at = text.find("H5"); at != std::string::npos; at = text.find("H5", at + 2)) {
    const size_t open = text.find('(', at);
    if (open != std::string::npos && text.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_", at) == open) {
      function = text.substr(at, open - at);
      break;
    }
  }
  std::string reason = Hdf5StackReason();
  if (reason.empty()) reason = "HDF5 gave no reason";
  for (int error : {EFBIG, ENOSPC, EDQUOT, EIO})
    if (reason == ErrnoText(error)) NoteWriteRefused(error);
  return "HDF5 error on '" + label + "': " + reason + (function.empty() ? "" : " (in " + function + ")");
}

void NoteWriteRefused(int error)
{
  if (error == EFBIG || error == ENOSPC || error == EDQUOT || error == EIO) write_refused = true;
}

bool WriteRefused() { return write_refused; }

std::string MpiIoPath(const std::string &path) { return path.empty() || path[0] == '/' || path.rfind("./", 0) == 0 ? path : "./" + path; }

PetscErrorCode OpenFileCollective(MPI_Comm comm, const std::string &path, H5Id *file)
{
  H5Id        access;
  std::string problem;
  PetscFunctionBeginUser;
  Hdf5SilenceErrorStack();
  PetscCallHDF5At(path, access = H5Pcreate(H5P_FILE_ACCESS));
  PetscCallHDF5At(path, H5Pset_fapl_mpio(access, comm, MPI_INFO_NULL));
  *file = Hdf5OpenFile(MpiIoPath(path), H5F_ACC_RDWR, access, &problem);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CheckRunFilesCollective(MPI_Comm comm, const RunFiles &files)
{
  PetscFunctionBeginUser;
  PetscCall(RunOnRoot(comm, [&]() -> PetscErrorCode {
    PetscFunctionBeginUser;
    const std::string problem = CheckRunFiles(files);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
    PetscFunctionReturn(PETSC_SUCCESS);
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OpenHdf5File(const std::string &path, unsigned flags, hid_t access, H5Id *file)
{
  std::string problem;
  PetscFunctionBeginUser;
  *file = Hdf5OpenFile(path, flags, access, &problem);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CreateHdf5Temporary(const std::string &target, TemporaryFile *temporary, H5Id *file, hid_t access, hid_t creation)
{
  std::string problem;
  PetscFunctionBeginUser;
  problem = temporary->Create(target);
  if (problem.empty()) problem = temporary->Close(); // HDF5 writes it by name
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  // Truncating the empty file this process has just created (and nothing else: CheckStillOurs
  // is verified before the rename).
  *file = Hdf5CreateFile(temporary->Path(), H5F_ACC_TRUNC, access, &problem, creation);
  if (!problem.empty()) temporary->Discard();
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CommitHdf5Temporary(TemporaryFile *temporary, Durability durability)
{
  PetscFunctionBeginUser;
  const std::string problem = temporary->Commit(durability);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s", problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WriteFileAtomicallyChecked(const std::string &target, const std::string &contents, Durability durability)
{
  PetscFunctionBeginUser;
  const std::string problem = WriteFileAtomically(target, contents, durability);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s", problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WriteFileMarkerChecked(const std::string &label, hid_t file, const FileMarker &marker)
{
  PetscFunctionBeginUser;
  const std::string problem = WriteFileMarker(file, marker);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "cannot write the msflex marker into '%s': %s", label.c_str(), problem.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode CreateCollectiveTransfer(const std::string &label, hid_t object, H5Id *transfer)
{
  H5Id file, access;
  PetscFunctionBeginUser;
  PetscCallHDF5At(label, file = H5Iget_file_id(object));
  PetscCallHDF5At(label, access = H5Fget_access_plist(file));
  const hid_t driver = H5Pget_driver(access);
  PetscCallHDF5At(label, driver);
  PetscCallHDF5At(label, *transfer = H5Pcreate(H5P_DATASET_XFER));
  if (driver == H5FD_MPIO) PetscCallHDF5At(label, H5Pset_dxpl_mpio(*transfer, H5FD_MPIO_COLLECTIVE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WriteRowsCollective(const std::string &label, hid_t parent, const char *name, hsize_t n_rows, hsize_t columns, const std::vector<int> &rows,
                                   const std::vector<double> &data, hid_t transfer, H5Id *dataset_out)
{
  const hsize_t             dims[2] = {n_rows, columns};
  const hsize_t             count   = rows.size();
  const std::vector<size_t> order   = FileOrder(rows);
  std::vector<double>       sorted(count * columns);
  H5Id                      space, dataset, memory_space, own_transfer;
  double                    dummy = 0;

  PetscFunctionBeginUser;
  PetscCallHDF5At(label, space = H5Screate_simple(2, dims, nullptr));
  PetscCallHDF5At(label, dataset = H5Dcreate2(parent, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (n_rows * columns > 0) { // the same on every rank
    for (size_t k = 0; k < count; ++k) std::copy_n(&data[order[k] * columns], columns, &sorted[k * columns]);
    PetscCall(SelectRows(label, space, columns, rows, order));
    const hsize_t memory_size = count > 0 ? count * columns : 1;
    PetscCallHDF5At(label, memory_space = H5Screate_simple(1, &memory_size, nullptr));
    if (count == 0) PetscCallHDF5At(label, H5Sselect_none(memory_space));
    if (transfer < 0) {
      PetscCall(CreateCollectiveTransfer(label, dataset, &own_transfer));
      transfer = own_transfer;
    }
    PetscCallHDF5At(label, H5Dwrite(dataset, H5T_NATIVE_DOUBLE, memory_space, space, transfer, count > 0 ? sorted.data() : &dummy));
  }
  if (dataset_out) *dataset_out = dataset.Release();
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode ReadRows(const std::string &label, hid_t parent, const char *name, hsize_t columns, const std::vector<int> &rows, std::vector<double> *data)
{
  const hsize_t             count = rows.size();
  const std::vector<size_t> order = FileOrder(rows);
  std::vector<double>       sorted(count * columns);
  H5Id                      dataset, space, memory_space;
  hsize_t                   dims[2] = {0, 0};

  PetscFunctionBeginUser;
  data->assign(count * columns, 0.0);
  PetscCallHDF5At(label, dataset = H5Dopen2(parent, name, H5P_DEFAULT));
  PetscCallHDF5At(label, space = H5Dget_space(dataset));
  PetscCheck(H5Sget_simple_extent_ndims(space) == 2, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': dataset %s is not a table", label.c_str(), name);
  PetscCallHDF5At(label, H5Sget_simple_extent_dims(space, dims, nullptr));
  PetscCheck(dims[1] == columns, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': dataset %s has %llu columns, expected %llu", label.c_str(), name,
             (unsigned long long)dims[1], (unsigned long long)columns);
  for (const int row : rows)
    PetscCheck(row >= 0 && (hsize_t)row < dims[0], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': dataset %s has %llu rows, row %d asked for",
               label.c_str(), name, (unsigned long long)dims[0], row);
  if (count == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(SelectRows(label, space, columns, rows, order));
  const hsize_t memory_size = count * columns;
  PetscCallHDF5At(label, memory_space = H5Screate_simple(1, &memory_size, nullptr));
  PetscCallHDF5At(label, H5Dread(dataset, H5T_NATIVE_DOUBLE, memory_space, space, H5P_DEFAULT, sorted.data()));
  for (size_t k = 0; k < count; ++k) std::copy_n(&sorted[k * columns], columns, &(*data)[order[k] * columns]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
