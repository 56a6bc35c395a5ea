// File safety: what msflex may write and how (docs/options.md, "Files msflex writes").
//
// Rules the functions here let the writers keep:
//  - a run writes only to paths that are none of its other files (input, mesh, the checkpoint it
//    restarts from, its other outputs), compared after resolving symbolic links, `.` and `..`,
//    and by device and inode for files that exist (hard links, bind mounts);
//  - a file is written under a new, unique temporary name in its target directory, created with
//    O_CREAT | O_EXCL | O_NOFOLLOW (a symbolic link or a file already at that name is never
//    followed, truncated or reused), then renamed over the target in one step (rename(2)), so a
//    reader sees the old file or the new one, never a half-written one, and a link at the target
//    is replaced instead of written through;
//  - every file-system failure is one line naming the path and the reason:
//    "cannot create 'x/y.h5': No such file or directory".
//
// Plain POSIX and C++17: no PETSc, no MPI, no HDF5, so that every function is unit tested alone
// (tests/unit/test_file_safety.cpp). Functions report problems as a returned string, empty on
// success; the PETSc-idiom wrappers live with the writers.
#pragma once

#include <sys/types.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace msflex {

// FNV-1a, 64 bit: `hash` carried on over `count` bytes (start from kFnv1aStart). The checksums of
// checkpoints (state rows, run record, the whole file) and the comparison of the ranks' command
// lines; a fingerprint that must resist more than bit flips is ModelFingerprint's SHA-256.
inline constexpr uint64_t kFnv1aStart = 14695981039346656037ull;
inline uint64_t           Fnv1a(const void *data, size_t count, uint64_t hash = kFnv1aStart)
{
  const unsigned char *bytes = static_cast<const unsigned char *>(data);
  for (size_t i = 0; i < count; ++i) hash = (hash ^ bytes[i]) * 1099511628211ull;
  return hash;
}

// strerror(error_number) as a std::string, e.g. "No such file or directory".
std::string ErrnoText(int error_number);

// "cannot <action> '<path>': <strerror(error_number)>", the one line of every file-system error.
std::string FileProblem(const std::string &action, const std::string &path, int error_number);
// "" when `path` is a regular file (or a link to one) or does not exist, else that it is not one:
// a FIFO without a writer blocks an open for good (deaf to SIGTERM), and /dev/zero reads forever.
std::string NotRegularFileProblem(const std::string &path);

// A path resolved the way the kernel would resolve it for an open(2) that creates it: every
// directory component and, when present, a symbolic link in the last component are followed.
struct ResolvedPath {
  std::string given;                // as given
  std::string canonical;            // absolute, without symbolic links, `.`, `..` or repeated '/'
  bool        exists       = false; // something is at `canonical`
  bool        is_symlink   = false; // the last component of `given` is a symbolic link (perhaps dangling)
  bool        is_regular   = false;
  bool        is_directory = false;
  dev_t       device       = 0; // of the existing file
  ino_t       inode        = 0;
};

// Resolves `path` (relative to the working directory), which need not exist: its directory must.
// Returns "" or the problem as one line: an empty path, a missing or non-directory parent
// ("cannot resolve 'a/b/c.h5': No such file or directory"), a loop of symbolic links, a path too
// long. A path naming a directory resolves (is_directory tells); CheckWritableTarget refuses it.
std::string ResolvePath(const std::string &path, ResolvedPath *resolved);

// The same file: equal canonical paths, or the same device and inode when both exist.
bool SameFile(const ResolvedPath &a, const ResolvedPath &b);

// "" when a file may be created or replaced at `path` (role, e.g. "output file", names it in the
// message): the path resolves, does not name a directory ("... is a directory"), is not a special
// file (device, FIFO, socket: "... is not a regular file") and its directory is writable
// (access(W_OK), "cannot create '...': Permission denied" / "Read-only file system"). A file that
// exists is not refused here: whether it may be replaced is the caller's policy (its kind).
std::string CheckWritableTarget(const std::string &role, const std::string &path, ResolvedPath *resolved = nullptr);

// One file of a run, for CheckRunPaths.
struct RunPath {
  std::string role;    // "input file", "mesh file", "output file", "XDMF sidecar", "checkpoint file", ...
  std::string path;    // as given; empty: the run has no such file (skipped)
  bool        written; // the run creates or replaces it
};

// "" when no written path of the run is the same file as any other path of the run, else the
// one-line problem, e.g. "the checkpoint file './out.h5' is the output file 'out.h5'"; also every
// written path must pass CheckWritableTarget. `allowed_pairs` lists pairs of roles that may be the
// same file (a restart writes its new checkpoints where it read the old one).
std::string CheckRunPaths(const std::vector<RunPath> &paths, const std::vector<std::array<std::string, 2>> &allowed_pairs = {});

// Whether a committed file must survive a crash of the machine (power loss, kernel panic), not
// only of the process. Synced costs an fsync of the file and of its directory (0.2-0.5 ms each on
// a local disk, more on a parallel file system): checkpoints, whose purpose is to outlive a
// failure, are synced; the result file as created at the start of a run (the model, no results
// yet) and the XDMF sidecar are not (both are synced before each checkpoint instead:
// OutputFile::SyncToDevice). The rename is atomic either way, so a killed process leaves the old
// file or the new one, never half of one.
enum class Durability { Synced, Unsynced };

// Removes what a killed process left of TemporaryFile's files for `target` (`<target>.tmp.XXXXXX`,
// regular files of this user's): a run that owns `target` (CheckRunFiles passed) calls it, since
// no other run may write there. Returns how many it removed.
int RemoveStaleTemporaries(const std::string &target);

// A new file beside `target`, written and then renamed over it (see the header comment).
// Not copyable; an uncommitted temporary is removed by the destructor.
class TemporaryFile {
public:
  TemporaryFile() = default;
  ~TemporaryFile();
  TemporaryFile(const TemporaryFile &)            = delete;
  TemporaryFile &operator=(const TemporaryFile &) = delete;

  // Creates "<target>.tmp.<6 random characters>" in the target's directory with
  // O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC and mode 0666 & ~umask, retrying other names on
  // EEXIST. Returns "" or the problem ("cannot create 'dir/out.h5.tmp.Xa3k9Q': Permission denied").
  std::string Create(const std::string &target);
  // Writes all of `size` bytes (partial writes and EINTR are continued).
  std::string Write(const void *data, size_t size);
  // Closes the descriptor; the file stays, under its temporary name, e.g. for a library that
  // writes it by name (HDF5).
  std::string Close();
  // "" when the temporary name still holds the file this object created (same device and
  // inode, not a symbolic link): after a library has written it by name.
  std::string CheckStillOurs() const;
  // Closes if open, renames the temporary over the target (atomically); Synced first flushes the
  // file to the device and afterwards the directory. Afterwards the object holds nothing.
  std::string Commit(Durability durability);
  // Removes the temporary (if any) without touching the target.
  void Discard();

  const std::string &Path() const { return path_; }
  const std::string &Target() const { return target_; }
  int                Descriptor() const { return fd_; }

private:
  std::string target_, path_;
  int         fd_     = -1;
  dev_t       device_ = 0;
  ino_t       inode_  = 0;
};

// Flushes the file at `path` to the device (fsync through a descriptor of its own); "" or the
// problem ("cannot write 'out.h5': Input/output error").
std::string SyncFile(const std::string &path);

// Replaces `target` by `contents` through a TemporaryFile (the XDMF sidecar).
std::string WriteFileAtomically(const std::string &target, const std::string &contents, Durability durability);

// Reads at most `max_bytes` from the start of the file at `path` (a marker check); "" or problem.
std::string ReadFileHead(const std::string &path, size_t max_bytes, std::string *head);

// The size in bytes of the file at `path`, or -1 with *problem set.
long long FileSize(const std::string &path, std::string *problem);

// --- Identity of a model and of a run ---

// SHA-256 (FIPS 180-4), incremental.
class Sha256 {
public:
  Sha256();
  void                    Update(const void *data, size_t size);
  void                    Update(const std::string &text) { Update(text.data(), text.size()); }
  std::array<uint8_t, 32> Finish(); // the digest; the object is then reset
  static std::string      Hex(const std::array<uint8_t, 32> &digest);

private:
  void                    Block(const uint8_t *block);
  std::array<uint32_t, 8> state_;
  uint8_t                 buffer_[64];
  size_t                  buffered_ = 0;
  uint64_t                length_   = 0; // bytes so far
};

// "sha256:<64 hex digits>" of the input text and the options database a run was started with:
// the model fingerprint stored in result files and checkpoints (attribute msflex_model). Each
// field enters with its length, so no two different (text, options) pairs hash the same input.
std::string ModelFingerprint(const std::string &input_text, const std::string &options);
// "sha256:<64 hex digits>" of a file's bytes (the mesh file a run read), or "" with *problem set
// when it cannot be read.
std::string FileFingerprint(const std::string &path, std::string *problem);

// 32 random hexadecimal digits (getrandom / /dev/urandom): the identity of one result file and of
// the checkpoints of the run that writes it (attribute msflex_run). Empty when no randomness can
// be had (then a caller must not rely on it).
std::string NewRunId();

// --- Markers of msflex's own files (specified in docs/output.md, "Files msflex recognises") ---

// Root-group string attributes of the result file and of checkpoints.
inline constexpr const char *kFormatAttribute  = "msflex_format"; // kResultFormat or kCheckpointFormat
inline constexpr const char *kModelAttribute   = "msflex_model";  // ModelFingerprint(...)
inline constexpr const char *kRunAttribute     = "msflex_run";    // NewRunId() of the result file
inline constexpr const char *kResultFormat     = "msflex result 3";
inline constexpr const char *kCheckpointFormat = "msflex checkpoint 7"; // 7: the run record holds the last step's length
// The XDMF sidecar carries this element right after <Domain>; a sidecar without it is still
// recognised by the collection grid msflex names "msflex" or the comment opening the incremental
// layout (files written before the marker).
inline constexpr const char *kSidecarMarker = "<Information Name=\"msflex_format\" Value=\"msflex result 3\"/>";
// Whether `head` (the first bytes of a file, ReadFileHead) is an XDMF sidecar written by msflex.
bool IsMsflexSidecar(const std::string &head);

} // namespace msflex
