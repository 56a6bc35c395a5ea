#include "core/hdf5_files.hpp"

#include "core/file_safety.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

namespace msflex {

namespace {

// Closes an HDF5 identifier of any kind at the end of a scope.
class Id {
public:
  explicit Id(hid_t id = H5I_INVALID_HID) : id_(id) {}
  ~Id()
  {
    if (id_ >= 0) H5Idec_ref(id_);
  }
  Id(const Id &)            = delete;
  Id &operator=(const Id &) = delete;
  Id &operator=(hid_t id)
  {
    if (id_ >= 0) H5Idec_ref(id_);
    id_ = id;
    return *this;
  }
       operator hid_t() const { return id_; }
  bool Valid() const { return id_ >= 0; }

private:
  hid_t id_;
};

struct StackEntries {
  std::vector<std::string> descriptions; // innermost first
};

herr_t CollectEntry(unsigned, const H5E_error2_t *entry, void *data)
{
  auto *entries = static_cast<StackEntries *>(data);
  entries->descriptions.push_back(entry->desc != nullptr ? entry->desc : "");
  if (entry->min_num > 0) {
    char message[256] = "";
    if (H5Eget_msg(entry->min_num, nullptr, message, sizeof message) > 0) entries->descriptions.back() += std::string(" [") + message + "]";
  }
  return 0;
}

bool Contains(const std::string &text, const char *part) { return text.find(part) != std::string::npos; }

// Whether every component of the relative or absolute HDF5 path `name` exists under `parent`.
bool LinkExists(hid_t parent, const std::string &name)
{
  for (size_t slash = name.find('/', name[0] == '/' ? 1 : 0);; slash = name.find('/', slash + 1)) {
    const std::string prefix = name.substr(0, slash);
    if (!prefix.empty() && prefix != "/" && H5Lexists(parent, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
    if (slash == std::string::npos) return true;
  }
}

// The watchdog of a variable-length string read (SetVariableStringReadTimeout): what the handler
// writes, prepared before the read (a signal handler may only write and exit).
double variable_string_read_timeout = 30.0;
char   watchdog_message[4096];
size_t watchdog_message_length = 0;

extern "C" void VariableStringReadExpired(int)
{
  if (write(STDERR_FILENO, watchdog_message, watchdog_message_length) < 0) _exit(1);
  _exit(1);
}

// H5Aread of a variable-length string under the watchdog; its result.
herr_t ReadVariableStringBounded(hid_t attribute, hid_t memory_type, char **text)
{
  char     path[2048] = "";
  const Id file(H5Iget_file_id(attribute));
  if (file.Valid() && H5Fget_name(file, path, sizeof path) < 0) path[0] = '\0';
  const int length         = std::snprintf(watchdog_message, sizeof watchdog_message,
                                           "msflex: error: reading '%s' did not end within %g s: HDF5 loops on a damaged part of it (the heap of its "
                                                   "variable-length strings); the file is damaged, move it away (-file_read_timeout sets the limit)\n",
                                           path, variable_string_read_timeout);
  watchdog_message_length  = length > 0 ? std::min((size_t)length, sizeof watchdog_message - 1) : 0;
  struct sigaction expired = {}, previous = {};
  expired.sa_handler = VariableStringReadExpired;
  sigemptyset(&expired.sa_mask);
  sigaction(SIGALRM, &expired, &previous);
  struct itimerval limit = {}, before = {};
  limit.it_value.tv_sec  = (time_t)variable_string_read_timeout;
  limit.it_value.tv_usec = (suseconds_t)((variable_string_read_timeout - std::floor(variable_string_read_timeout)) * 1e6);
  if (limit.it_value.tv_sec == 0 && limit.it_value.tv_usec == 0) limit.it_value.tv_usec = 1;
  setitimer(ITIMER_REAL, &limit, &before);
  const herr_t           status = H5Aread(attribute, memory_type, text);
  const struct itimerval off    = {};
  setitimer(ITIMER_REAL, &off, nullptr);
  sigaction(SIGALRM, &previous, nullptr);
  return status;
}

// Reads the string attribute `name` of `object` (variable or fixed length, at most 1 MiB).
std::string ReadStringAttribute(hid_t object, const char *name, std::string *value)
{
  value->clear();
  if (H5Aexists(object, name) <= 0) return "";
  const Id attribute(H5Aopen(object, name, H5P_DEFAULT));
  const Id type(attribute.Valid() ? H5Aget_type(attribute) : H5I_INVALID_HID);
  const Id space(attribute.Valid() ? H5Aget_space(attribute) : H5I_INVALID_HID);
  if (!type.Valid() || !space.Valid()) return std::string("attribute ") + name + " cannot be read";
  if (H5Tget_class(type) != H5T_STRING || H5Sget_simple_extent_npoints(space) != 1) return std::string("attribute ") + name + " is not a string";
  const Id memory_type(H5Tcopy(H5T_C_S1));
  H5Tset_cset(memory_type, H5Tget_cset(type)); // HDF5 does not convert between character sets
  if (H5Tis_variable_str(type) > 0) {
    H5Tset_size(memory_type, H5T_VARIABLE);
    char *text = nullptr;
    if (ReadVariableStringBounded(attribute, memory_type, &text) < 0) return std::string("attribute ") + name + " cannot be read";
    if (text != nullptr) {
      *value = text;
      H5free_memory(text);
    }
    return "";
  }
  const size_t size = H5Tget_size(type);
  if (size == 0 || size > (1u << 20)) return std::string("attribute ") + name + " is not a short string";
  // One byte more than the file's: HDF5 converts into a null-terminated string of the memory
  // size, so a null-padded string filling the file's size would lose its last character.
  H5Tset_size(memory_type, size + 1);
  std::string buffer(size + 1, '\0');
  if (H5Aread(attribute, memory_type, buffer.data()) < 0) return std::string("attribute ") + name + " cannot be read";
  value->assign(buffer.c_str());
  return "";
}

// A scalar fixed-length UTF-8 string attribute (the markers: WriteFileMarker says why).
std::string WriteFixedStringAttribute(hid_t object, const char *name, const std::string &value)
{
  const Id type(H5Tcopy(H5T_C_S1));
  if (!type.Valid() || H5Tset_size(type, std::max<size_t>(value.size(), 1)) < 0 || H5Tset_strpad(type, H5T_STR_NULLPAD) < 0 ||
      H5Tset_cset(type, H5T_CSET_UTF8) < 0)
    return "cannot make a string type";
  const Id space(H5Screate(H5S_SCALAR));
  if (H5Aexists(object, name) > 0 && H5Adelete(object, name) < 0) return std::string("cannot replace attribute ") + name;
  const Id          attribute(H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT));
  const std::string padded = value.empty() ? std::string(1, '\0') : value;
  if (!attribute.Valid() || H5Awrite(attribute, type, padded.data()) < 0) return std::string("cannot write attribute ") + name + ": " + Hdf5StackReason();
  return "";
}

unsigned long long FileSizeOf(hid_t object)
{
  const Id file(H5Iget_file_id(object));
  hsize_t  size = 0;
  if (!file.Valid() || H5Fget_filesize(file, &size) < 0) return 0;
  return size;
}

// Opens dataset `name` under `parent` with its space; "" or the problem.
std::string OpenDataset(hid_t parent, const std::string &name, Id *dataset, Id *space)
{
  if (!LinkExists(parent, name)) return "no dataset " + name;
  H5O_info_t info;
#if H5_VERSION_GE(1, 12, 0)
  if (H5Oget_info_by_name3(parent, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 || info.type != H5O_TYPE_DATASET)
#else
  if (H5Oget_info_by_name2(parent, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0 || info.type != H5O_TYPE_DATASET)
#endif
    return name + " is not a dataset";
  *dataset = H5Dopen2(parent, name.c_str(), H5P_DEFAULT);
  if (!dataset->Valid()) return name + " cannot be opened: " + Hdf5StackReason();
  *space = H5Dget_space(*dataset);
  if (!space->Valid()) return name + " cannot be read: " + Hdf5StackReason();
  return "";
}

// Opens a dataset of the given rank and checks its storage against the file.
std::string OpenChecked(hid_t parent, const std::string &name, int rank, Id *dataset, std::vector<hsize_t> *dims)
{
  Id space;
  if (std::string problem = OpenDataset(parent, name, dataset, &space); !problem.empty()) return problem;
  const int found = H5Sget_simple_extent_ndims(space);
  if (found != rank) return name + " has " + std::to_string(std::max(found, 0)) + " dimensions, expected " + std::to_string(rank);
  dims->assign(static_cast<size_t>(rank), 0);
  H5Sget_simple_extent_dims(space, dims->data(), nullptr);
  if (std::string problem = DatasetStorageProblem(*dataset, FileSizeOf(parent)); !problem.empty()) return name + " " + problem;
  return "";
}

} // namespace

std::string ReadTextAttribute(hid_t object, const char *name, std::string *value) { return ReadStringAttribute(object, name, value); }

void Hdf5SilenceErrorStack() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

Hdf5QuietScope::Hdf5QuietScope()
{
  H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

Hdf5QuietScope::~Hdf5QuietScope() { H5Eset_auto2(H5E_DEFAULT, function_, data_); }

std::string Hdf5StackReason()
{
  StackEntries entries;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, CollectEntry, &entries);
  H5Eclear2(H5E_DEFAULT);
  if (entries.descriptions.empty()) return "";
  // A lock held by another process comes with errno EAGAIN ("Resource temporarily unavailable"),
  // which would not say what is wrong.
  for (const std::string &description : entries.descriptions)
    if (Contains(description, "unable to lock file"))
      return "the file is in use: another process has it open (a running msflex, or a reader such as h5py or ParaView)";
  for (const std::string &description : entries.descriptions) {
    // The POSIX-style drivers record "..., errno = 13, error message = 'Permission denied', ...".
    const size_t at = description.find("errno = ");
    if (at != std::string::npos) {
      const int error = std::atoi(description.c_str() + at + 8);
      if (error > 0) return ErrnoText(error);
    }
  }
  for (const std::string &description : entries.descriptions) {
    if (Contains(description, "file signature not found") || Contains(description, "not an HDF5 file")) return "not an HDF5 file";
    if (Contains(description, "file is already open")) return "the file is already open in this process";
    if (Contains(description, "truncated file")) return "the file is truncated (incomplete or damaged)";
  }
  return entries.descriptions.front();
}

std::string Hdf5FileProblem(const std::string &action, const std::string &path)
{
  std::string reason = Hdf5StackReason();
  // MPI-IO and some failures carry no errno: ask the file system.
  if (reason.empty() || Contains(reason, "MPI") || Contains(reason, "unable to open file") || Contains(reason, "unable to create file")) {
    struct stat info;
    if (path.empty()) reason = "the file name is empty";
    else if (::stat(path.c_str(), &info) != 0) reason = ErrnoText(errno);
    else if (S_ISDIR(info.st_mode)) reason = ErrnoText(EISDIR);
    else if (action.rfind("open", 0) == 0) {
      const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
      if (fd < 0) reason = ErrnoText(errno);
      else {
        ::close(fd);
        if (H5Fis_hdf5(path.c_str()) <= 0) reason = "not an HDF5 file";
        H5Eclear2(H5E_DEFAULT);
      }
    }
    if (reason.empty()) reason = "HDF5 gave no reason";
  }
  return "cannot " + action + " '" + path + "': " + reason;
}

hid_t Hdf5OpenFile(const std::string &path, unsigned flags, hid_t access, std::string *problem)
{
  const Hdf5QuietScope quiet;
  H5Eclear2(H5E_DEFAULT);
  problem->clear();
  if (path.empty()) {
    *problem = "cannot open '': the file name is empty";
    return H5I_INVALID_HID;
  }
  const hid_t file = H5Fopen(path.c_str(), flags, access);
  if (file < 0) *problem = Hdf5FileProblem("open", path);
  return file;
}

hid_t Hdf5CreateFile(const std::string &path, unsigned flags, hid_t access, std::string *problem, hid_t creation)
{
  const Hdf5QuietScope quiet;
  H5Eclear2(H5E_DEFAULT);
  problem->clear();
  if (path.empty()) {
    *problem = "cannot create '': the file name is empty";
    return H5I_INVALID_HID;
  }
  const hid_t file = H5Fcreate(path.c_str(), flags, creation, access);
  if (file < 0) *problem = Hdf5FileProblem("create", path);
  return file;
}

std::string WriteFileMarker(hid_t file, const FileMarker &marker)
{
  const Hdf5QuietScope quiet;
  const Id             root(H5Gopen2(file, "/", H5P_DEFAULT));
  if (!root.Valid()) return "cannot open the root group: " + Hdf5StackReason();
  for (const auto &[name, value] :
       {std::pair<const char *, const std::string *>{kFormatAttribute, &marker.format}, {kModelAttribute, &marker.model}, {kRunAttribute, &marker.run}})
    if (std::string problem = WriteFixedStringAttribute(root, name, *value); !problem.empty()) return problem;
  return "";
}

void SetVariableStringReadTimeout(double seconds)
{
  // At most a day: the watchdog counts it in whole seconds of time_t.
  if (seconds > 0 && std::isfinite(seconds)) variable_string_read_timeout = std::min(seconds, 86400.0);
}

std::string ReadFileMarker(hid_t file, FileMarker *marker)
{
  const Hdf5QuietScope quiet;
  *marker = FileMarker{};
  const Id root(H5Gopen2(file, "/", H5P_DEFAULT));
  if (!root.Valid()) return "cannot open the root group: " + Hdf5StackReason();
  for (const auto &[name, value] :
       {std::pair<const char *, std::string *>{kFormatAttribute, &marker->format}, {kModelAttribute, &marker->model}, {kRunAttribute, &marker->run}})
    if (std::string problem = ReadStringAttribute(root, name, value); !problem.empty()) return problem;
  return "";
}

const char *ExistingKindName(ExistingKind kind)
{
  switch (kind) {
  case ExistingKind::Missing:
    return "no file";
  case ExistingKind::MsflexResult:
    return "an msflex result file";
  case ExistingKind::MsflexCheckpoint:
    return "an msflex checkpoint";
  case ExistingKind::MsflexSidecar:
    return "an msflex XDMF sidecar";
  case ExistingKind::Foreign:
    return "a file that msflex did not write";
  case ExistingKind::NotRegular:
    return "not a regular file";
  }
  return "unknown";
}

// The whole file's checksum, appended after HDF5 has closed it (HDF5 reads files with bytes past
// their end of address space): 8 bytes kFooterMagic, then FNV-1a 64 of every byte before the
// footer. Checked before HDF5 opens the file at all: a bit flipped in its metadata made HDF5 read
// out of range and crash in H5Dopen (a trial's sweep of single-bit flips), or loop for ever.
static constexpr char   kFooterMagic[9] = "MSFLXSUM";
static constexpr size_t kFooterSize     = 16;

// FNV-1a 64 of the file's first `size` bytes; false when they cannot be read.
static bool FileChecksum(std::FILE *file, unsigned long long size, uint64_t *hash)
{
  std::vector<unsigned char> buffer(1 << 20);
  *hash = kFnv1aStart;
  if (std::fseek(file, 0, SEEK_SET) != 0) return false;
  for (unsigned long long done = 0; done < size;) {
    const size_t chunk = (size_t)std::min<unsigned long long>(buffer.size(), size - done);
    if (std::fread(buffer.data(), 1, chunk, file) != chunk) return false;
    *hash = Fnv1a(buffer.data(), chunk, *hash);
    done += chunk;
  }
  return true;
}

std::string AppendCheckpointFooter(const std::string &path)
{
  std::FILE *file = std::fopen(path.c_str(), "r+b");
  if (!file) return "cannot reopen '" + path + "' for its checksum: " + ErrnoText(errno);
  uint64_t   hash = 0;
  bool       ok   = std::fseek(file, 0, SEEK_END) == 0;
  const long size = ok ? std::ftell(file) : -1;
  ok              = ok && size >= 0 && FileChecksum(file, (unsigned long long)size, &hash) && std::fseek(file, 0, SEEK_END) == 0;
  ok              = ok && std::fwrite(kFooterMagic, 1, 8, file) == 8 && std::fwrite(&hash, 1, 8, file) == 8;
  const int error = errno;
  ok              = (std::fclose(file) == 0) && ok;
  return ok ? "" : "cannot write the checksum of '" + path + "': " + ErrnoText(error);
}

std::string CheckpointFooterProblem(const std::string &path, bool *has_footer)
{
  *has_footer     = false;
  std::FILE *file = std::fopen(path.c_str(), "rb");
  if (!file) return "cannot open '" + path + "': " + ErrnoText(errno);
  std::string problem;
  char        footer[kFooterSize];
  const long  size = std::fseek(file, 0, SEEK_END) == 0 ? std::ftell(file) : -1;
  if (size < (long)kFooterSize || std::fseek(file, size - (long)kFooterSize, SEEK_SET) != 0 || std::fread(footer, 1, kFooterSize, file) != kFooterSize)
    problem = "'" + path + "' has no checksum at its end: it is not a complete checkpoint of format " + kCheckpointFormat;
  else if (std::memcmp(footer, kFooterMagic, 8) != 0)
    problem = "'" + path + "' has no checksum at its end: it is not a complete checkpoint of format " + kCheckpointFormat + " (or its end is damaged)";
  else {
    *has_footer = true;
    uint64_t stored, hash;
    std::memcpy(&stored, footer + 8, 8);
    if (!FileChecksum(file, (unsigned long long)size - kFooterSize, &hash)) problem = "cannot read '" + path + "'";
    else if (hash != stored) problem = "'" + path + "' is damaged: its bytes do not match the checksum at its end";
  }
  std::fclose(file);
  return problem;
}

std::string ClassifyExistingFile(const std::string &path, ExistingFile *file)
{
  *file = ExistingFile{};
  ResolvedPath resolved;
  if (std::string problem = ResolvePath(path, &resolved); !problem.empty()) return problem;
  if (!resolved.exists) return "";
  if (!resolved.is_regular) {
    file->kind = ExistingKind::NotRegular;
    return "";
  }
  std::string head;
  if (std::string problem = ReadFileHead(resolved.canonical, 4096, &head); !problem.empty()) return problem;
  file->kind = ExistingKind::Foreign;
  // A checkpoint whose bytes do not match its checksum is not given to HDF5 (which crashed or
  // looped on some damaged metadata).
  bool has_footer = false;
  if (std::string damage = CheckpointFooterProblem(resolved.canonical, &has_footer); has_footer && !damage.empty()) {
    file->damaged = true;
    return damage;
  }
  file->checksummed = has_footer;
  const Hdf5QuietScope quiet;
  if (H5Fis_hdf5(resolved.canonical.c_str()) <= 0) {
    H5Eclear2(H5E_DEFAULT);
    if (IsMsflexSidecar(head)) file->kind = ExistingKind::MsflexSidecar;
    return "";
  }
  std::string problem;
  const Id    hdf5(Hdf5OpenFile(resolved.canonical, H5F_ACC_RDONLY, H5P_DEFAULT, &problem));
  if (!hdf5.Valid()) return problem;
  if (std::string marker_problem = ReadFileMarker(hdf5, &file->marker); !marker_problem.empty()) return "cannot read '" + path + "': " + marker_problem;
  if (file->marker.format.rfind("msflex result ", 0) == 0) file->kind = ExistingKind::MsflexResult;
  else if (file->marker.format.rfind("msflex checkpoint ", 0) == 0) file->kind = ExistingKind::MsflexCheckpoint;
  else if (file->marker.format.empty()) {
    // Written before the marker existed: recognised by layout.
    if (LinkExists(hdf5, "/input") && LinkExists(hdf5, "/mesh/node_coordinates") && LinkExists(hdf5, "/frames") && LinkExists(hdf5, "/history")) {
      file->kind   = ExistingKind::MsflexResult;
      file->legacy = true;
    } else if (LinkExists(hdf5, "/run/format")) {
      std::string format;
      // Formats 1 to 3 were written without the markers (a later one that lost them is refused
      // the same way): the format goes into the marker.
      if (ReadBoundedText(hdf5, "/run/format", 64, &format).empty() && format.rfind("msflex checkpoint ", 0) == 0) {
        file->kind          = ExistingKind::MsflexCheckpoint;
        file->legacy        = true;
        file->marker.format = format;
      }
    }
  }
  H5Eclear2(H5E_DEFAULT);
  return "";
}

std::string SidecarPath(const std::string &result_path) { return std::filesystem::path(result_path).replace_extension(".xmf").string(); }

std::string CheckRunFiles(const RunFiles &files)
{
  const std::string          sidecar = files.output.empty() ? "" : SidecarPath(files.output);
  const std::vector<RunPath> paths   = {{"input file", files.input, false},  {"mesh file", files.mesh, false}, {"restart checkpoint", files.restart, false},
                                        {"output file", files.output, true}, {"XDMF sidecar", sidecar, true},  {"checkpoint file", files.checkpoint, true}};
  if (std::string problem = CheckRunPaths(paths, {{"restart checkpoint", "checkpoint file"}}); !problem.empty()) return problem;
  const auto quoted = [](const std::string &path) { return "'" + path + "'"; };
  const auto refuse = [&](const std::string &role, const std::string &path, const ExistingFile &existing, const char *rule) {
    return "refusing to replace the " + role + " " + quoted(path) + ": it is " + ExistingKindName(existing.kind) + "; " + rule;
  };

  ExistingFile output;
  if (std::string problem = ClassifyExistingFile(files.output, &output); !problem.empty()) return problem;
  if (output.kind != ExistingKind::Missing) {
    if (files.continue_output) {
      if (output.kind != ExistingKind::MsflexResult) return refuse("output file", files.output, output, "a restart continues only an msflex result file");
      if (!files.run.empty() && !output.marker.run.empty() && files.run != output.marker.run)
        return "the output file " + quoted(files.output) + " belongs to another run than the checkpoint " + quoted(files.restart) +
               "; continue into a new file with -output_file NEW.h5";
    } else if (!files.overwrite) {
      return "output file " + quoted(files.output) + " exists; pass -output_overwrite to replace it";
    } else if (output.kind != ExistingKind::MsflexResult) {
      return refuse("output file", files.output, output, "-output_overwrite replaces only msflex result files");
    }
  }

  ExistingFile existing_sidecar;
  if (std::string problem = ClassifyExistingFile(sidecar, &existing_sidecar); !problem.empty()) return problem;
  if (existing_sidecar.kind != ExistingKind::Missing) {
    if (existing_sidecar.kind != ExistingKind::MsflexSidecar)
      return refuse("XDMF sidecar", sidecar, existing_sidecar, "msflex replaces only the sidecars it wrote");
    if (!files.continue_output && !files.overwrite) return "XDMF sidecar " + quoted(sidecar) + " exists; pass -output_overwrite to replace it";
  }

  ResolvedPath checkpoint_path, restart_path;
  const bool   is_restart_file = !files.restart.empty() && ResolvePath(files.checkpoint, &checkpoint_path).empty() &&
                               ResolvePath(files.restart, &restart_path).empty() && SameFile(checkpoint_path, restart_path);
  if (!is_restart_file) {
    ExistingFile checkpoint;
    // A damaged checkpoint in the way of this run's: the user's to move (one given to --restart is
    // refused by its reader in the same words, without the advice).
    if (std::string problem = ClassifyExistingFile(files.checkpoint, &checkpoint); !problem.empty())
      return checkpoint.damaged ? problem + "; move it away" : problem;
    if (checkpoint.kind != ExistingKind::Missing) {
      if (checkpoint.kind != ExistingKind::MsflexCheckpoint)
        return refuse("checkpoint file", files.checkpoint, checkpoint, "msflex replaces only its own checkpoints");
      const bool same_run = !files.run.empty() && checkpoint.marker.run == files.run;
      if (!same_run && !files.overwrite)
        return "checkpoint file " + quoted(files.checkpoint) +
               " exists (from another run); pass -output_overwrite to replace it, or continue it with --restart";
    }
  }
  return "";
}

std::string DatasetStorageProblem(hid_t dataset, unsigned long long file_size)
{
  const Hdf5QuietScope quiet;
  const Id             space(H5Dget_space(dataset)), type(H5Dget_type(dataset)), properties(H5Dget_create_plist(dataset));
  if (!space.Valid() || !type.Valid() || !properties.Valid()) return "cannot be inspected: " + Hdf5StackReason();
  const H5D_layout_t layout = H5Pget_layout(properties);
  if (layout == H5D_VIRTUAL) return "is a virtual dataset (its data are in other files), which msflex does not read";
  if (H5Pget_external_count(properties) > 0) return "keeps its data in external files, which msflex does not read";
  const hssize_t points = H5Sget_simple_extent_npoints(space);
  const size_t   size   = H5Tget_size(type);
  if (points < 0 || size == 0) return "has an unreadable size";
  const long double claimed = static_cast<long double>(points) * static_cast<long double>(size);
  const hsize_t     stored  = H5Dget_storage_size(dataset);
  const bool        filters = H5Pget_nfilters(properties) > 0;
  const long double needed  = filters ? claimed / kMaxCompressionRatio : claimed;
  const std::string sizes   = "claims " + std::to_string(points) + " entries (" + std::to_string(static_cast<unsigned long long>(claimed)) + " bytes)";
  if (file_size > 0 && stored > file_size)
    return sizes + " stored in " + std::to_string(stored) + " bytes, more than the file's " + std::to_string(file_size) + " bytes";
  if (static_cast<long double>(stored) + 0.5L < needed)
    return sizes + " but the file holds only " + std::to_string(stored) + " bytes of them (file size " + std::to_string(file_size) + " bytes)";
  return "";
}

std::string DatasetDims(hid_t parent, const std::string &name, std::vector<hsize_t> *dims)
{
  const Hdf5QuietScope quiet;
  Id                   dataset, space;
  if (std::string problem = OpenDataset(parent, name, &dataset, &space); !problem.empty()) return problem;
  const int rank = H5Sget_simple_extent_ndims(space);
  dims->assign(static_cast<size_t>(std::max(rank, 0)), 0);
  if (rank > 0) H5Sget_simple_extent_dims(space, dims->data(), nullptr);
  return "";
}

std::string ReadExactDoubles(hid_t parent, const std::string &name, size_t count, std::vector<double> *values)
{
  const Hdf5QuietScope quiet;
  values->clear();
  Id                   dataset;
  std::vector<hsize_t> dims;
  if (std::string problem = OpenChecked(parent, name, 1, &dataset, &dims); !problem.empty()) return problem;
  if (dims[0] != count) return name + " has " + std::to_string(dims[0]) + " entries, expected " + std::to_string(count);
  const Id type(H5Dget_type(dataset));
  if (H5Tget_class(type) != H5T_FLOAT && H5Tget_class(type) != H5T_INTEGER) return name + " does not hold numbers";
  values->assign(count, 0.0);
  if (count > 0 && H5Dread(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values->data()) < 0) {
    values->clear();
    return name + " cannot be read: " + Hdf5StackReason();
  }
  for (size_t k = 0; k < count; ++k)
    if (!std::isfinite((*values)[k])) return name + " entry " + std::to_string(k) + " is not a finite number";
  return "";
}

std::string ReadFixedStrings(hid_t parent, const std::string &name, std::vector<std::string> *strings)
{
  const Hdf5QuietScope quiet;
  strings->clear();
  Id                   dataset;
  std::vector<hsize_t> dims;
  if (std::string problem = OpenChecked(parent, name, 1, &dataset, &dims); !problem.empty()) return problem;
  const Id type(H5Dget_type(dataset));
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) != 0) return name + " is not a list of fixed-length strings";
  const size_t      length = H5Tget_size(type);
  std::vector<char> packed(static_cast<size_t>(dims[0]) * length);
  if (!packed.empty() && H5Dread(dataset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, packed.data()) < 0) return name + " cannot be read: " + Hdf5StackReason();
  for (hsize_t k = 0; k < dims[0]; ++k) {
    const char *first = packed.data() + k * length;
    strings->emplace_back(first, std::find(first, first + length, '\0'));
  }
  return "";
}

std::string ReadBoundedText(hid_t parent, const std::string &name, size_t max_bytes, std::string *text)
{
  const Hdf5QuietScope quiet;
  text->clear();
  Id                   dataset;
  std::vector<hsize_t> dims;
  if (std::string problem = OpenChecked(parent, name, 1, &dataset, &dims); !problem.empty()) return problem;
  if (dims[0] > max_bytes) return name + " claims " + std::to_string(dims[0]) + " bytes, more than the " + std::to_string(max_bytes) + " allowed";
  const Id type(H5Dget_type(dataset));
  if (H5Tget_class(type) != H5T_INTEGER || H5Tget_size(type) != 1) return name + " is not text (bytes)";
  text->assign(static_cast<size_t>(dims[0]), '\0');
  if (dims[0] > 0 && H5Dread(dataset, H5T_NATIVE_CHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text->data()) < 0) {
    text->clear();
    return name + " cannot be read: " + Hdf5StackReason();
  }
  return "";
}

std::string CheckTableShape(hid_t parent, const std::string &name, hsize_t rows, hsize_t columns)
{
  const Hdf5QuietScope quiet;
  Id                   dataset;
  std::vector<hsize_t> dims;
  if (std::string problem = OpenChecked(parent, name, 2, &dataset, &dims); !problem.empty()) return problem;
  if (dims[0] != rows || dims[1] != columns)
    return name + " has shape (" + std::to_string(dims[0]) + ", " + std::to_string(dims[1]) + "), expected (" + std::to_string(rows) + ", " +
           std::to_string(columns) + ")";
  const Id type(H5Dget_type(dataset));
  if (H5Tget_class(type) != H5T_FLOAT) return name + " does not hold floating-point numbers";
  return "";
}

} // namespace msflex
