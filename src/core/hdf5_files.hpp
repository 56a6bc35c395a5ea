// HDF5 files without HDF5's own error reports: every failure becomes one line naming the file and
// the reason ("cannot open 'x.h5': No such file or directory", "cannot open 'y.h5': not an HDF5
// file"), and msflex's own files are told apart from everything else by a marker (the root-group
// attributes of core/file_safety.hpp, specified in docs/output.md).
//
// HDF5 prints its error stack to stderr on every failed call unless told not to: msflex turns
// that off for the whole process (Hdf5SilenceErrorStack, first thing after start-up) and reads the
// stack itself (Hdf5StackReason). Plain HDF5 + POSIX: no PETSc, no MPI calls, unit tested in
// tests/unit/test_file_safety.cpp; the PETSc-idiom checks on top are in output/hdf5_util.hpp.
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

namespace msflex {

// Turns off HDF5's automatic error printing for the process (H5Eset_auto2 with no function).
void Hdf5SilenceErrorStack();

// Turns it off for a scope and restores the previous setting (library code, tests).
class Hdf5QuietScope {
public:
  Hdf5QuietScope();
  ~Hdf5QuietScope();
  Hdf5QuietScope(const Hdf5QuietScope &)            = delete;
  Hdf5QuietScope &operator=(const Hdf5QuietScope &) = delete;

private:
  H5E_auto2_t function_ = nullptr;
  void       *data_     = nullptr;
};

// Why the last HDF5 call failed, from the default error stack, which is then cleared: the
// operating system's reason when a file driver recorded an errno ("Permission denied"), "not an
// HDF5 file", "the file is in use: another process has it open ...", or HDF5's innermost message. Empty when
// the stack is empty.
std::string Hdf5StackReason();

// One line for a failed H5Fopen/H5Fcreate of `path`: "cannot <action> '<path>': <reason>", the
// reason from the error stack or, when that has none, from the file system (stat, open).
std::string Hdf5FileProblem(const std::string &action, const std::string &path);

// H5Fopen / H5Fcreate that print nothing: a negative id and *problem (one line) on failure.
hid_t Hdf5OpenFile(const std::string &path, unsigned flags, hid_t access, std::string *problem);
hid_t Hdf5CreateFile(const std::string &path, unsigned flags, hid_t access, std::string *problem, hid_t creation = H5P_DEFAULT);

// --- Markers ---

// The root-group attributes msflex writes into its result files and checkpoints.
struct FileMarker {
  std::string format; // kResultFormat, kCheckpointFormat
  std::string model;  // ModelFingerprint(input text, options)
  std::string run;    // NewRunId() of the result file (a checkpoint: of the result file it belongs to)
};

// Writes the marker as fixed-length UTF-8 string attributes of "/"; "" or the problem. Fixed
// length: a variable-length string lives in the file's global heap, and HDF5 loops for ever on
// some damaged heaps (a flipped bit in one of its sizes), so a damaged file would hang every run
// that only wanted to know whose file it is.
std::string WriteFileMarker(hid_t file, const FileMarker &marker);
// Reads the marker attributes of "/" (absent ones stay empty; fixed or variable length, the
// latter as files of earlier msflex versions and other programs have them, under the read
// timeout below); "" or the problem.
std::string ReadFileMarker(hid_t file, FileMarker *marker);
// The string attribute `name` of `object` (variable or fixed length, at most 1 MiB; "" when absent);
// a problem in words, or "".
std::string ReadTextAttribute(hid_t object, const char *name, std::string *value);

// The longest a read of a variable-length string attribute may take (seconds, > 0): past it the
// process writes one line naming the file and exits with status 1 (the read cannot be
// interrupted otherwise). Default 30 s; -file_read_timeout.
void SetVariableStringReadTimeout(double seconds);

// The checkpoints' whole-file checksum: appended after HDF5 has closed the file (HDF5 reads files
// with bytes past their end of address space), 8 bytes "MSFLXSUM" then FNV-1a 64 of every byte
// before them, and checked before HDF5 opens the file at all: a bit flipped in its metadata made
// HDF5 read out of range and crash in H5Dopen, or loop for ever (a trial's sweep of single-bit
// flips). Append: "" or the problem. Problem: *has_footer says whether the file ends with the
// magic; "" when its checksum matches, else the one-line problem.
std::string AppendCheckpointFooter(const std::string &path);
std::string CheckpointFooterProblem(const std::string &path, bool *has_footer);

// What is at a path that msflex is about to write.
enum class ExistingKind {
  Missing,          // nothing
  MsflexResult,     // an msflex result file (marker, or the layout of files written before it)
  MsflexCheckpoint, // an msflex checkpoint (marker, or /run/format "msflex checkpoint N": 1 to 3 had no marker)
  MsflexSidecar,    // an XDMF sidecar written by msflex
  Foreign,          // any other file, including HDF5 files of other programs
  NotRegular,       // a directory, device, FIFO or socket
};
struct ExistingFile {
  ExistingKind kind = ExistingKind::Missing;
  FileMarker   marker;              // for msflex HDF5 files; empty fields for files written before the marker
  bool         legacy      = false; // recognised by layout, without a marker
  bool         checksummed = false; // ends with a checkpoint footer whose checksum matches (a damaged one is a problem)
  bool         damaged     = false; // its footer's checksum does not match (the problem says so)
};
const char *ExistingKindName(ExistingKind kind); // "an msflex result file", "a file that msflex did not write", ...
// Classifies the file at `path` (following symbolic links); "" or the problem (one line).
std::string ClassifyExistingFile(const std::string &path, ExistingFile *file);

// The XDMF sidecar of a result file: the path with its extension replaced by .xmf (as the writer
// names it).
std::string SidecarPath(const std::string &result_path);

// The files of one run, for CheckRunFiles.
struct RunFiles {
  std::string input;                   // the input file read (empty on a restart: the input is in the checkpoint)
  std::string mesh;                    // the mesh file the input names, as the reader opened it (empty: none)
  std::string restart;                 // the checkpoint a restart reads (empty: not a restart)
  std::string output;                  // the result file; its sidecar is SidecarPath(output)
  std::string checkpoint;              // the checkpoint file the run writes (on schedule, signal or failure)
  bool        overwrite       = false; // -output_overwrite
  bool        continue_output = false; // a restart that appends to the existing `output`
  std::string run;                     // a restart: the checkpoint's msflex_run, which `output` must carry
};

// The file-safety policy of a run, checked on one rank before anything is created or read for
// writing; "" or the one-line problem. (1) No file the run writes (output, sidecar, checkpoint) is
// the same file as another file of the run (CheckRunPaths; a restart may write its checkpoints
// where it read one), and each is a writable place (CheckWritableTarget). (2) An existing output
// file is replaced only with -output_overwrite and only when it is an msflex result file; a
// restart continues only an msflex result of the checkpoint's run. (3) An existing sidecar is
// replaced only when msflex wrote it, and only with -output_overwrite or when continuing. (4) An
// existing checkpoint file (other than the one restarted from) is replaced only when it is an
// msflex checkpoint, of this run or with -output_overwrite.
std::string CheckRunFiles(const RunFiles &files);

// --- Validated reading (checkpoints, mesh files): sizes are checked before anything is allocated ---

// "" when the dataset's size is plausible for the file that holds it, else why not: its data
// must be stored in the file itself (no external files, no virtual datasets), and the bytes its
// elements take (elements x size of the file type) must be stored — all of them for a dataset
// without filters, at least 1/kMaxCompressionRatio of them for a compressed one (deflate cannot do
// better than about 1030:1) — and the storage must fit in the file (`file_size` bytes). A header
// that claims 4e8 rows in a 50 KB file fails here instead of in the allocation.
inline constexpr double kMaxCompressionRatio = 1100.0;
std::string             DatasetStorageProblem(hid_t dataset, unsigned long long file_size);

// The dimensions of dataset `name` under `parent`; "" or the problem ("no dataset /run/numbers",
// "... is not a dataset").
std::string DatasetDims(hid_t parent, const std::string &name, std::vector<hsize_t> *dims);

// Reads the 1-D float64 dataset `name` holding exactly `count` finite numbers; "" or the problem,
// e.g. "/run/numbers has 100000 entries, expected 11", "/run/numbers entry 1 is not finite".
std::string ReadExactDoubles(hid_t parent, const std::string &name, size_t count, std::vector<double> *values);

// Reads the 1-D dataset `name` of fixed-length strings (NUL-padded; the storage checked as by
// DatasetStorageProblem) into `strings`; "" or the problem, e.g. "/history/names is not a list
// of fixed-length strings".
std::string ReadFixedStrings(hid_t parent, const std::string &name, std::vector<std::string> *strings);

// Reads the 1-D byte dataset `name` as text of at most `max_bytes` (and no more than its storage
// and the file hold); "" or the problem, e.g. "/run/input_text claims 1099511627776 bytes".
std::string ReadBoundedText(hid_t parent, const std::string &name, size_t max_bytes, std::string *text);

// "" when `name` is a 2-D float64 table of `rows` x `columns` whose storage the file holds.
std::string CheckTableShape(hid_t parent, const std::string &name, hsize_t rows, hsize_t columns);

} // namespace msflex
