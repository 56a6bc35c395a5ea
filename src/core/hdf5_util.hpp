// Small HDF5 + MPI helpers shared by the result file and the checkpoints: an owning handle,
// collective error agreement, and row-wise parallel writes and reads of float64 tables whose rows
// are spread over the ranks.
#pragma once

#include "core/file_safety.hpp"
#include "core/hdf5_files.hpp"

#include <hdf5.h>
#include <petscsys.h>

#include <string>
#include <vector>

// Checks the result of an HDF5 call (negative means failure); `label` names the file in the
// one-line message, which gives the reason from HDF5's error stack (Hdf5CallProblem). HDF5's own
// printing of the stack is off (Hdf5SilenceErrorStack, called by main and by OpenFileCollective).
#define PetscCallHDF5At(label, call) PetscCheck((call) >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s", msflex::Hdf5CallProblem((label), #call).c_str())

namespace msflex {

// "HDF5 error on '<label>': <reason> (in H5Dcreate2)" for the failed call whose text is `call`;
// clears the error stack.
std::string Hdf5CallProblem(const std::string &label, const char *call);
// Whether the file system refused data this process wrote (a full disk or quota, a file-size
// limit, an I/O error: NoteWriteRefused with the errno, which HDF5 calls' failures note
// themselves). HDF5 then cannot close the result file's datasets: its own clean-up at
// MPI_Finalize crashed on them (main ends such a run without it).
// The path MPI-IO opens: a relative path starts with ./ (Open MPI's MPI_File_open failed with
// MPI_ERR_OTHER on any one-character name, `-output_file b` under mpirun, after the old file had
// been replaced).
std::string MpiIoPath(const std::string &path);
void        NoteWriteRefused(int error);
bool        WriteRefused();

// Owns one HDF5 identifier of any kind (file, group, dataset, dataspace, type, property list):
// H5Idec_ref closes whatever it refers to, so early returns on errors leak nothing.
class H5Id {
public:
  H5Id()                        = default;
  H5Id(const H5Id &)            = delete;
  H5Id &operator=(const H5Id &) = delete;
  ~H5Id() { Reset(); }

  H5Id &operator=(hid_t id)
  {
    Reset();
    id_ = id;
    return *this;
  }
  operator hid_t() const { return id_; }
  // Gives up ownership, for a close whose result must be checked (H5Fclose).
  hid_t Release()
  {
    const hid_t id = id_;
    id_            = H5I_INVALID_HID;
    return id;
  }

private:
  void Reset()
  {
    if (id_ >= 0) H5Idec_ref(id_);
    id_ = H5I_INVALID_HID;
  }
  hid_t id_ = H5I_INVALID_HID;
};

// Runs `root_work` (returning PetscErrorCode) on rank 0 only and makes its outcome collective:
// rank 0 broadcasts its error code and message, and every rank raises the same error, so no rank
// is left waiting in a later collective call. Rank 0's handler is silenced meanwhile so that the
// message is reported once, by the collective PetscCheck.
template <class RootWork> PetscErrorCode RunOnRoot(MPI_Comm comm, RootWork &&root_work)
{
  PetscMPIInt    rank;
  PetscErrorCode status = PETSC_SUCCESS;
  char           message[1024]; // set only when a rank fails (filling 1 kB per call costs a small frame)

  PetscFunctionBeginUser;
  message[0] = '\0';
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
    status = root_work();
    PetscCall(PetscPopErrorHandler());
    if (status != PETSC_SUCCESS) {
      char *specific;
      PetscCall(PetscErrorMessage(status, nullptr, &specific));
      PetscCall(PetscStrncpy(message, specific, sizeof message));
    }
  }
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  // One rank: nothing to agree on (a frame or history row of a small model calls this several
  // times, and each broadcast costs as much as the work).
  if (size > 1) {
    PetscCallMPI(MPI_Bcast(&status, 1, MPI_INT, 0, comm));
    if (status != PETSC_SUCCESS) PetscCallMPI(MPI_Bcast(message, sizeof message, MPI_CHAR, 0, comm));
  }
  PetscCheck(status == PETSC_SUCCESS, comm, status, "%s", message);
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Runs `work` on every rank and makes the outcome collective: when any rank fails, the lowest
// failing rank broadcasts its error code and message and every rank raises that same error.
template <class Work> PetscErrorCode RunCollective(MPI_Comm comm, Work &&work)
{
  PetscMPIInt    rank, size, first;
  PetscErrorCode status = PETSC_SUCCESS;
  char           message[1024]; // set only when a rank fails (filling 1 kB per call costs a small frame)

  PetscFunctionBeginUser;
  message[0] = '\0';
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  status = work();
  PetscCall(PetscPopErrorHandler());
  if (status != PETSC_SUCCESS) {
    char *specific;
    PetscCall(PetscErrorMessage(status, nullptr, &specific));
    PetscCall(PetscStrncpy(message, specific, sizeof message));
  }
  const PetscMPIInt mine = status != PETSC_SUCCESS ? rank : size;
  if (size == 1) first = mine; // one rank: nothing to agree on
  else PetscCallMPI(MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm));
  if (first < size) {
    PetscCallMPI(MPI_Bcast(&status, 1, MPI_INT, first, comm));
    PetscCallMPI(MPI_Bcast(message, sizeof message, MPI_CHAR, first, comm));
    PetscCheck(false, comm, status, "%s", message);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Opens the existing file `path` for reading and writing on every rank of `comm` through MPI-IO.
// Collective. A failure is one line ("cannot open 'x.h5': Permission denied"), PETSC_ERR_FILE_OPEN.
PetscErrorCode OpenFileCollective(MPI_Comm comm, const std::string &path, H5Id *file);

// --- File safety in the PETSc idiom (core/file_safety.hpp, core/hdf5_files.hpp) ---
// Each raises PETSC_ERR_FILE_OPEN / _WRITE with the one-line message on PETSC_COMM_SELF; called
// on rank 0 inside RunOnRoot (or on every rank inside RunCollective) they become collective.

// The file-safety policy of a run (CheckRunFiles), checked on rank 0 and agreed by every rank of
// `comm` before anything is created. Collective.
PetscErrorCode CheckRunFilesCollective(MPI_Comm comm, const RunFiles &files);

// Opens an existing HDF5 file (H5Fopen) without HDF5's printing; one line on failure.
PetscErrorCode OpenHdf5File(const std::string &path, unsigned flags, hid_t access, H5Id *file);

// Creates a new HDF5 file that will replace `target`: a TemporaryFile beside it (O_EXCL,
// O_NOFOLLOW, unique name), which HDF5 then fills by name. Write it through *file, close it
// (H5Fclose), then CommitHdf5Temporary renames it over `target`; until then `target` is untouched,
// and a failure (or a destroyed TemporaryFile) removes the temporary. `access`, `creation`: the
// file access and creation property lists HDF5 creates it with (format version bounds, B-tree sizes).
PetscErrorCode CreateHdf5Temporary(const std::string &target, TemporaryFile *temporary, H5Id *file, hid_t access = H5P_DEFAULT, hid_t creation = H5P_DEFAULT);
// Checks that the temporary still holds the file created for it and renames it over its target
// (flushed to the device first when `durability` is Synced: see Durability).
PetscErrorCode CommitHdf5Temporary(TemporaryFile *temporary, Durability durability);

// Replaces `target` by `contents` atomically through a TemporaryFile (the XDMF sidecar).
PetscErrorCode WriteFileAtomicallyChecked(const std::string &target, const std::string &contents, Durability durability);

// Writes the marker attributes (format, model fingerprint, run id) into the root group of `file`.
PetscErrorCode WriteFileMarkerChecked(const std::string &label, hid_t file, const FileMarker &marker);

// A dataset transfer property list for collective MPI-IO transfers to the file holding `object`,
// or the default list when that file is not open through MPI-IO (one rank: the POSIX driver).
PetscErrorCode CreateCollectiveTransfer(const std::string &label, hid_t object, H5Id *transfer);

// Creates the float64 dataset `name` (n_rows x columns) under `parent` collectively; each rank
// writes `data` (rows.size() x columns, any order) to its `rows`; every row is written by at most
// one rank. `label` names the file in messages. `transfer`: a list from CreateCollectiveTransfer
// made once for many writes (default: one made here); `dataset`, when given, receives the open
// dataset (for its attributes, without looking it up again).
PetscErrorCode WriteRowsCollective(const std::string &label, hid_t parent, const char *name, hsize_t n_rows, hsize_t columns, const std::vector<int> &rows,
                                   const std::vector<double> &data, hid_t transfer = H5I_INVALID_HID, H5Id *dataset = nullptr);

// Reads `rows` (any order, each at most once) of the float64 dataset `name` (n x columns) under
// `parent` into *data (rows.size() x columns, in the order of `rows`). Independent (not collective).
PetscErrorCode ReadRows(const std::string &label, hid_t parent, const char *name, hsize_t columns, const std::vector<int> &rows, std::vector<double> *data);

} // namespace msflex
