#include "core/file_safety.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <filesystem>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

namespace msflex {

namespace {

// Symbolic links followed in the last component before giving up, as the kernel's MAXSYMLINKS.
constexpr int kMaxLinks = 40;

std::string Quoted(const std::string &path) { return "'" + path + "'"; }

// "a/b/c" -> ("a/b", "c"); "c" -> (".", "c"); "/c" -> ("/", "c"); "a/b/" -> ("a/b", "").
void SplitLast(const std::string &path, std::string *directory, std::string *name)
{
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) {
    *directory = ".";
    *name      = path;
    return;
  }
  *name      = path.substr(slash + 1);
  size_t end = slash;
  while (end > 0 && path[end - 1] == '/') --end; // "a//b" -> "a"
  *directory = end == 0 ? "/" : path.substr(0, end);
}

std::string JoinPath(const std::string &directory, const std::string &name) { return directory == "/" ? "/" + name : directory + "/" + name; }

// realpath(3) into a std::string; errno on failure.
int RealPath(const std::string &path, std::string *resolved)
{
  char buffer[PATH_MAX];
  if (::realpath(path.c_str(), buffer) == nullptr) return errno;
  *resolved = buffer;
  return 0;
}

void SetStat(const struct stat &info, ResolvedPath *resolved)
{
  resolved->exists       = true;
  resolved->is_regular   = S_ISREG(info.st_mode);
  resolved->is_directory = S_ISDIR(info.st_mode);
  resolved->device       = info.st_dev;
  resolved->inode        = info.st_ino;
}

// ResolvePath's work; returns 0 or an errno value.
int Resolve(const std::string &path, ResolvedPath *resolved)
{
  *resolved       = ResolvedPath{};
  resolved->given = path;
  if (path.empty()) return ENOENT;
  std::string current = path;
  for (int links = 0; links <= kMaxLinks; ++links) {
    std::string directory, name;
    SplitLast(current, &directory, &name);
    if (name.empty() || name == "." || name == "..") {
      // "dir/", "dir/." and "dir/..": a directory that must exist.
      std::string canonical;
      if (const int error = RealPath(current, &canonical); error != 0) return error;
      struct stat info;
      if (::stat(canonical.c_str(), &info) != 0) return errno;
      resolved->canonical = canonical;
      SetStat(info, resolved);
      return 0;
    }
    std::string real_directory;
    if (const int error = RealPath(directory, &real_directory); error != 0) return error;
    struct stat directory_info;
    if (::stat(real_directory.c_str(), &directory_info) != 0) return errno;
    if (!S_ISDIR(directory_info.st_mode)) return ENOTDIR;
    const std::string candidate = JoinPath(real_directory, name);
    struct stat       info;
    if (::lstat(candidate.c_str(), &info) != 0) {
      if (errno != ENOENT) return errno;
      resolved->canonical = candidate; // nothing there yet
      return 0;
    }
    if (!S_ISLNK(info.st_mode)) {
      resolved->canonical = candidate;
      SetStat(info, resolved);
      return 0;
    }
    // A symbolic link in the last component: follow it by hand, so that a dangling one still
    // resolves to where a file created through it would appear.
    resolved->is_symlink = true;
    std::string   target(PATH_MAX, '\0');
    const ssize_t length = ::readlink(candidate.c_str(), target.data(), target.size());
    if (length < 0) return errno;
    if (static_cast<size_t>(length) >= target.size()) return ENAMETOOLONG;
    target.resize(static_cast<size_t>(length));
    current = !target.empty() && target[0] == '/' ? target : JoinPath(real_directory, target);
  }
  return ELOOP;
}

std::string RandomSuffix()
{
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
  unsigned char     bytes[6];
  if (::getrandom(bytes, sizeof bytes, 0) != static_cast<ssize_t>(sizeof bytes)) {
    std::random_device device;
    for (unsigned char &byte : bytes) byte = static_cast<unsigned char>(device());
  }
  std::string suffix;
  for (const unsigned char byte : bytes) suffix += kAlphabet[byte % (sizeof kAlphabet - 1)];
  return suffix;
}

// Flushes a directory's entries (the rename) to the device; a file system that cannot is fine.
void SyncDirectory(const std::string &file)
{
  std::string directory, name;
  SplitLast(file, &directory, &name);
  const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

} // namespace

std::string ErrnoText(int error_number)
{
  char        buffer[256];
  const char *text = ::strerror_r(error_number, buffer, sizeof buffer); // the GNU strerror_r
  return text != nullptr ? text : "error " + std::to_string(error_number);
}

std::string NotRegularFileProblem(const std::string &path)
{
  std::error_code                  status_error;
  const std::filesystem::file_type type = std::filesystem::status(path, status_error).type();
  if (status_error || type == std::filesystem::file_type::not_found || type == std::filesystem::file_type::regular) return "";
  return "not a regular file (a directory, FIFO, socket or device)";
}

std::string FileProblem(const std::string &action, const std::string &path, int error_number)
{
  return "cannot " + action + " " + Quoted(path) + ": " + ErrnoText(error_number);
}

std::string ResolvePath(const std::string &path, ResolvedPath *resolved)
{
  if (path.empty()) return "cannot resolve '': the file name is empty";
  const int error = Resolve(path, resolved);
  return error == 0 ? "" : FileProblem("resolve", path, error);
}

bool SameFile(const ResolvedPath &a, const ResolvedPath &b)
{
  if (a.canonical == b.canonical) return true;
  return a.exists && b.exists && a.device == b.device && a.inode == b.inode;
}

std::string CheckWritableTarget(const std::string &role, const std::string &path, ResolvedPath *resolved_out)
{
  ResolvedPath resolved;
  if (path.empty()) return "the " + role + " name is empty";
  const std::string action = "create " + role;
  if (const int error = Resolve(path, &resolved); error != 0) return FileProblem(action, path, error);
  if (resolved.is_directory) return FileProblem(action, path, EISDIR);
  if (resolved.exists && !resolved.is_regular) return "cannot create " + role + " " + Quoted(path) + ": it exists and is not a regular file";
  // The file itself is replaced by a rename: what matters is the directory the link (or the file)
  // is in, which is where the temporary goes.
  std::string directory, name;
  SplitLast(path, &directory, &name);
  if (::access(directory.c_str(), W_OK | X_OK) != 0) return FileProblem(action, path, errno);
  if (resolved_out != nullptr) *resolved_out = resolved;
  return "";
}

std::string CheckRunPaths(const std::vector<RunPath> &paths, const std::vector<std::array<std::string, 2>> &allowed_pairs)
{
  std::vector<ResolvedPath> resolved(paths.size());
  std::vector<bool>         known(paths.size(), false);
  for (size_t i = 0; i < paths.size(); ++i) {
    if (paths[i].path.empty() && !paths[i].written) continue;
    if (paths[i].written) {
      if (std::string problem = CheckWritableTarget(paths[i].role, paths[i].path, &resolved[i]); !problem.empty()) return problem;
      known[i] = true;
    } else {
      // A file that is only read and cannot be resolved is reported by its reader.
      known[i] = Resolve(paths[i].path, &resolved[i]) == 0;
    }
  }
  const auto allowed = [&](const std::string &a, const std::string &b) {
    for (const auto &pair : allowed_pairs)
      if ((pair[0] == a && pair[1] == b) || (pair[0] == b && pair[1] == a)) return true;
    return false;
  };
  for (size_t j = 0; j < paths.size(); ++j)
    for (size_t i = 0; i < j; ++i) {
      if (!known[i] || !known[j] || !(paths[i].written || paths[j].written)) continue;
      if (!SameFile(resolved[i], resolved[j]) || allowed(paths[i].role, paths[j].role)) continue;
      // The written one first: it is the one that would destroy the other.
      const size_t first = paths[j].written ? j : i, second = first == j ? i : j;
      return "the " + paths[first].role + " " + Quoted(paths[first].path) + " is the same file as the " + paths[second].role + " " +
             Quoted(paths[second].path) + "; msflex never writes over another file of the run";
    }
  return "";
}

int RemoveStaleTemporaries(const std::string &target)
{
  const size_t      slash     = target.rfind('/');
  const std::string directory = slash == std::string::npos ? "." : slash == 0 ? "/" : target.substr(0, slash);
  const std::string prefix    = (slash == std::string::npos ? target : target.substr(slash + 1)) + ".tmp.";
  DIR              *listing   = ::opendir(directory.c_str());
  if (!listing) return 0;
  int removed = 0;
  for (const dirent *entry = ::readdir(listing); entry; entry = ::readdir(listing)) {
    const std::string name = entry->d_name;
    // TemporaryFile's names only: the target's name, ".tmp." and six letters or digits.
    if (name.size() != prefix.size() + 6 || name.compare(0, prefix.size(), prefix) != 0) continue;
    if (!std::all_of(name.begin() + (long)prefix.size(), name.end(), [](char c) { return std::isalnum((unsigned char)c) != 0; })) continue;
    const std::string path = directory + "/" + name;
    struct stat       info;
    // A regular file of this user's, never through a link.
    if (::lstat(path.c_str(), &info) != 0 || !S_ISREG(info.st_mode) || info.st_uid != ::geteuid()) continue;
    if (::unlink(path.c_str()) == 0) ++removed;
  }
  ::closedir(listing);
  return removed;
}

TemporaryFile::~TemporaryFile() { Discard(); }

std::string TemporaryFile::Create(const std::string &target)
{
  Discard();
  if (target.empty()) return "cannot create a temporary file for '': the file name is empty";
  for (int attempt = 0; attempt < 100; ++attempt) {
    const std::string candidate = target + ".tmp." + RandomSuffix();
    // O_EXCL: fails on anything already at the name, a symbolic link included (never followed).
    const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) {
      if (errno == EEXIST) continue;
      return FileProblem("create", candidate, errno);
    }
    struct stat info;
    if (::fstat(fd, &info) != 0) {
      const int error = errno;
      ::close(fd);
      ::unlink(candidate.c_str());
      return FileProblem("create", candidate, error);
    }
    target_ = target;
    path_   = candidate;
    fd_     = fd;
    device_ = info.st_dev;
    inode_  = info.st_ino;
    return "";
  }
  return FileProblem("create a temporary file beside", target, EEXIST);
}

std::string TemporaryFile::Write(const void *data, size_t size)
{
  if (fd_ < 0) return "cannot write " + Quoted(path_) + ": the temporary file is not open";
  const char *bytes = static_cast<const char *>(data);
  while (size > 0) {
    const ssize_t written = ::write(fd_, bytes, size);
    if (written < 0) {
      if (errno == EINTR) continue;
      return FileProblem("write", path_, errno);
    }
    bytes += written;
    size -= static_cast<size_t>(written);
  }
  return "";
}

std::string TemporaryFile::Close()
{
  if (fd_ < 0) return "";
  const int fd = fd_;
  fd_          = -1;
  if (::close(fd) != 0) return FileProblem("write", path_, errno);
  return "";
}

std::string TemporaryFile::CheckStillOurs() const
{
  if (path_.empty()) return "no temporary file";
  struct stat info;
  if (::lstat(path_.c_str(), &info) != 0) return FileProblem("find the temporary file", path_, errno);
  if (S_ISLNK(info.st_mode) || info.st_dev != device_ || info.st_ino != inode_)
    return "the temporary file " + Quoted(path_) + " was replaced by another process while msflex wrote it";
  return "";
}

std::string TemporaryFile::Commit(Durability durability)
{
  if (path_.empty()) return "cannot commit: no temporary file";
  // What this object or a library (by name) wrote reaches the device before the name switches:
  // through the descriptor when it is still open, else by reopening the name once it is known to
  // hold the file this object created.
  const bool  synced_before_close = durability == Durability::Synced && fd_ >= 0;
  std::string problem;
  if (synced_before_close && ::fsync(fd_) != 0 && errno != EINVAL) problem = FileProblem("write", path_, errno);
  if (const std::string closing = Close(); problem.empty()) problem = closing;
  if (problem.empty()) problem = CheckStillOurs();
  if (problem.empty() && durability == Durability::Synced && !synced_before_close) {
    // Opened first and identified by its descriptor, so that a file swapped in after the check
    // above is not the one synced.
    const int   fd = ::open(path_.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    struct stat info;
    if (fd < 0) problem = FileProblem("open", path_, errno);
    else if (::fstat(fd, &info) != 0) problem = FileProblem("open", path_, errno);
    else if (info.st_dev != device_ || info.st_ino != inode_)
      problem = "the temporary file " + Quoted(path_) + " was replaced by another process while msflex wrote it";
    else if (::fsync(fd) != 0 && errno != EINVAL) problem = FileProblem("write", path_, errno);
    if (fd >= 0) ::close(fd);
  }
  if (problem.empty() && ::rename(path_.c_str(), target_.c_str()) != 0)
    problem = "cannot rename " + Quoted(path_) + " to " + Quoted(target_) + ": " + ErrnoText(errno);
  if (!problem.empty()) {
    Discard();
    return problem;
  }
  if (durability == Durability::Synced) SyncDirectory(target_);
  path_.clear();
  target_.clear();
  return "";
}

void TemporaryFile::Discard()
{
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!path_.empty()) ::unlink(path_.c_str());
  path_.clear();
  target_.clear();
}

std::string SyncFile(const std::string &path)
{
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return FileProblem("open", path, errno);
  std::string problem;
  if (::fsync(fd) != 0 && errno != EINVAL) problem = FileProblem("write", path, errno);
  ::close(fd);
  return problem;
}

std::string WriteFileAtomically(const std::string &target, const std::string &contents, Durability durability)
{
  TemporaryFile file;
  std::string   problem = file.Create(target);
  if (problem.empty()) problem = file.Write(contents.data(), contents.size());
  if (problem.empty()) problem = file.Commit(durability);
  return problem;
}

std::string ReadFileHead(const std::string &path, size_t max_bytes, std::string *head)
{
  head->clear();
  // O_NONBLOCK: a FIFO must not block the run; it is refused below anyway.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return FileProblem("open", path, errno);
  struct stat info;
  if (::fstat(fd, &info) != 0) {
    const int error = errno;
    ::close(fd);
    return FileProblem("read", path, error);
  }
  if (!S_ISREG(info.st_mode)) {
    ::close(fd);
    return S_ISDIR(info.st_mode) ? FileProblem("read", path, EISDIR) : "cannot read " + Quoted(path) + ": not a regular file";
  }
  head->resize(max_bytes);
  size_t filled = 0;
  while (filled < max_bytes) {
    const ssize_t got = ::read(fd, head->data() + filled, max_bytes - filled);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int error = errno;
      ::close(fd);
      head->clear();
      return FileProblem("read", path, error);
    }
    if (got == 0) break;
    filled += static_cast<size_t>(got);
  }
  ::close(fd);
  head->resize(filled);
  return "";
}

long long FileSize(const std::string &path, std::string *problem)
{
  struct stat info;
  if (::stat(path.c_str(), &info) != 0) {
    *problem = FileProblem("open", path, errno);
    return -1;
  }
  problem->clear();
  return static_cast<long long>(info.st_size);
}

// --- SHA-256 (FIPS 180-4, section 6.2) ---

namespace {

constexpr uint32_t kRoundConstants[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74,
    0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d,
    0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e,
    0x92722c85, 0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5,
    0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};
constexpr std::array<uint32_t, 8> kInitialState = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};

uint32_t RotateRight(uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

} // namespace

Sha256::Sha256() : state_(kInitialState) {}

void Sha256::Block(const uint8_t *block)
{
  uint32_t w[64];
  for (int t = 0; t < 16; ++t)
    w[t] = (uint32_t)block[4 * t] << 24 | (uint32_t)block[4 * t + 1] << 16 | (uint32_t)block[4 * t + 2] << 8 | (uint32_t)block[4 * t + 3];
  for (int t = 16; t < 64; ++t) {
    const uint32_t s0 = RotateRight(w[t - 15], 7) ^ RotateRight(w[t - 15], 18) ^ (w[t - 15] >> 3);
    const uint32_t s1 = RotateRight(w[t - 2], 17) ^ RotateRight(w[t - 2], 19) ^ (w[t - 2] >> 10);
    w[t]              = w[t - 16] + s0 + w[t - 7] + s1;
  }
  uint32_t a = state_[0], b = state_[1], c = state_[2], d = state_[3], e = state_[4], f = state_[5], g = state_[6], h = state_[7];
  for (int t = 0; t < 64; ++t) {
    const uint32_t t1 = h + (RotateRight(e, 6) ^ RotateRight(e, 11) ^ RotateRight(e, 25)) + ((e & f) ^ (~e & g)) + kRoundConstants[t] + w[t];
    const uint32_t t2 = (RotateRight(a, 2) ^ RotateRight(a, 13) ^ RotateRight(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
    h                 = g;
    g                 = f;
    f                 = e;
    e                 = d + t1;
    d                 = c;
    c                 = b;
    b                 = a;
    a                 = t1 + t2;
  }
  state_[0] += a, state_[1] += b, state_[2] += c, state_[3] += d, state_[4] += e, state_[5] += f, state_[6] += g, state_[7] += h;
}

void Sha256::Update(const void *data, size_t size)
{
  const uint8_t *bytes = static_cast<const uint8_t *>(data);
  length_ += size;
  while (size > 0) {
    const size_t take = std::min(size, sizeof buffer_ - buffered_);
    std::memcpy(buffer_ + buffered_, bytes, take);
    buffered_ += take, bytes += take, size -= take;
    if (buffered_ == sizeof buffer_) {
      Block(buffer_);
      buffered_ = 0;
    }
  }
}

std::array<uint8_t, 32> Sha256::Finish()
{
  // Padding: 0x80, zeros to 56 mod 64, then the length in bits, big endian.
  const uint64_t bits     = length_ * 8;
  const uint8_t  one      = 0x80;
  const uint8_t  zero[64] = {0};
  Update(&one, 1);
  Update(zero, (buffered_ <= 56 ? 56 - buffered_ : 120 - buffered_));
  uint8_t length_bytes[8];
  for (int k = 0; k < 8; ++k) length_bytes[k] = static_cast<uint8_t>(bits >> (56 - 8 * k));
  Update(length_bytes, 8);
  std::array<uint8_t, 32> digest;
  for (int k = 0; k < 8; ++k)
    for (int byte = 0; byte < 4; ++byte) digest[4 * k + byte] = static_cast<uint8_t>(state_[k] >> (24 - 8 * byte));
  state_    = kInitialState;
  buffered_ = 0;
  length_   = 0;
  return digest;
}

std::string Sha256::Hex(const std::array<uint8_t, 32> &digest)
{
  static const char kDigits[] = "0123456789abcdef";
  std::string       hex;
  for (const uint8_t byte : digest) hex += {kDigits[byte >> 4], kDigits[byte & 15]};
  return hex;
}

std::string ModelFingerprint(const std::string &input_text, const std::string &options)
{
  Sha256 hash;
  hash.Update(std::string("msflex model 1\n"));
  for (const std::string *field : {&input_text, &options}) {
    uint8_t length[8];
    for (int k = 0; k < 8; ++k) length[k] = static_cast<uint8_t>(static_cast<uint64_t>(field->size()) >> (8 * k));
    hash.Update(length, sizeof length);
    hash.Update(*field);
  }
  return "sha256:" + Sha256::Hex(hash.Finish());
}

std::string FileFingerprint(const std::string &path, std::string *problem)
{
  problem->clear();
  std::FILE *file = std::fopen(path.c_str(), "rb");
  if (!file) {
    *problem = "cannot read '" + path + "': " + std::strerror(errno);
    return "";
  }
  Sha256               hash;
  std::vector<uint8_t> block(1 << 20);
  size_t               got;
  while ((got = std::fread(block.data(), 1, block.size(), file)) > 0) hash.Update(block.data(), got);
  const bool failed = std::ferror(file) != 0;
  std::fclose(file);
  if (failed) {
    *problem = "cannot read '" + path + "'";
    return "";
  }
  return "sha256:" + Sha256::Hex(hash.Finish());
}

std::string NewRunId()
{
  unsigned char bytes[16];
  size_t        filled = 0;
  while (filled < sizeof bytes) {
    const ssize_t got = ::getrandom(bytes + filled, sizeof bytes - filled, 0);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    filled += static_cast<size_t>(got);
  }
  if (filled < sizeof bytes) {
    const int fd = ::open("/dev/urandom", O_RDONLY | O_CLOEXEC);
    if (fd < 0) return "";
    const ssize_t got = ::read(fd, bytes, sizeof bytes);
    ::close(fd);
    if (got != static_cast<ssize_t>(sizeof bytes)) return "";
  }
  static const char kDigits[] = "0123456789abcdef";
  std::string       id;
  for (const unsigned char byte : bytes) id += {kDigits[byte >> 4], kDigits[byte & 15]};
  return id;
}

bool IsMsflexSidecar(const std::string &head)
{
  if (head.compare(0, 5, "<?xml") != 0) return false;
  // The marker of any version of the layout; or, written before it, the single temporal collection named msflex, or the comment
  // that opens the incremental layout's head.
  return head.find("<Information Name=\"msflex_format\" Value=\"msflex result ") != std::string::npos ||
         head.find("<Grid Name=\"msflex\" GridType=\"Collection\"") != std::string::npos ||
         head.find("<!-- msflex results (layout: docs/output.md)") != std::string::npos;
}

} // namespace msflex
