// File safety (core/file_safety.hpp, core/hdf5_files.hpp): path resolution and aliases, safe
// temporary files, one-line errors, the SHA-256 model fingerprint, msflex's file markers and the
// run's file policy, and the size checks of validated HDF5 reads. Each test works in its own
// scratch directory and checks that files it did not mean to change keep their bytes.
#include "core/file_safety.hpp"
#include "core/hdf5_files.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sched.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using namespace msflex;

namespace {

std::string ReadAll(const std::string &path)
{
  std::ifstream     in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteText(const std::string &path, const std::string &text)
{
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

bool IsSymlink(const std::string &path)
{
  struct stat info;
  return ::lstat(path.c_str(), &info) == 0 && S_ISLNK(info.st_mode);
}

// Every entry of a directory.
std::set<std::string> Entries(const std::string &directory)
{
  std::set<std::string> names;
  for (const auto &entry : std::filesystem::directory_iterator(directory)) names.insert(entry.path().filename().string());
  return names;
}

bool HasPrefix(const std::string &text, const std::string &prefix) { return text.compare(0, prefix.size(), prefix) == 0; }

// A scratch directory per test, removed afterwards; the test runs inside it (relative paths).
class FileSafety : public ::testing::Test {
protected:
  void SetUp() override
  {
    char pattern[] = "/tmp/msflex-file-safety-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    ASSERT_NE(::getcwd(previous_, sizeof previous_), nullptr);
    ASSERT_EQ(::chdir(dir_.c_str()), 0);
  }
  void TearDown() override
  {
    ASSERT_EQ(::chdir(previous_), 0);
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  std::string Abs(const std::string &name) const { return dir_ + "/" + name; }

  std::string dir_;
  char        previous_[4096];
};

// --- one-line messages ---

TEST_F(FileSafety, ErrnoMessagesAreOneLineWithPathAndReason)
{
  EXPECT_EQ(ErrnoText(ENOENT), "No such file or directory");
  EXPECT_EQ(FileProblem("create", "x/y.h5", ENOENT), "cannot create 'x/y.h5': No such file or directory");
  EXPECT_EQ(FileProblem("open", "a.h5", EACCES), "cannot open 'a.h5': Permission denied");
}

// --- ResolvePath ---

TEST_F(FileSafety, ResolvesDotsAndRelativePaths)
{
  ASSERT_EQ(::mkdir("sub", 0755), 0);
  WriteText("in.yaml", "x");
  ResolvedPath a, b, c;
  ASSERT_EQ(ResolvePath("in.yaml", &a), "");
  ASSERT_EQ(ResolvePath("./sub/../in.yaml", &b), "");
  ASSERT_EQ(ResolvePath(dir_ + "//sub/./..//in.yaml", &c), "");
  const std::string real_dir = std::filesystem::canonical(dir_).string();
  EXPECT_EQ(a.canonical, real_dir + "/in.yaml");
  EXPECT_EQ(b.canonical, a.canonical);
  EXPECT_EQ(c.canonical, a.canonical);
  EXPECT_TRUE(a.exists && a.is_regular && !a.is_symlink);
  EXPECT_TRUE(SameFile(a, b));
}

TEST_F(FileSafety, ResolvesMissingFileInExistingDirectory)
{
  ResolvedPath missing;
  ASSERT_EQ(ResolvePath("./new.h5", &missing), "");
  EXPECT_FALSE(missing.exists);
  EXPECT_EQ(missing.canonical, std::filesystem::canonical(dir_).string() + "/new.h5");
}

TEST_F(FileSafety, ResolvesSymlinksInDirectoriesAndLastComponent)
{
  ASSERT_EQ(::mkdir("real", 0755), 0);
  WriteText("real/model.yaml", "x");
  ASSERT_EQ(::symlink("real", "linkdir"), 0);
  ASSERT_EQ(::symlink("real/model.yaml", "alias.h5"), 0);
  ASSERT_EQ(::symlink("real/not-yet.h5", "dangling.h5"), 0);
  ResolvedPath model, through_dir, through_link, dangling, target;
  ASSERT_EQ(ResolvePath("real/model.yaml", &model), "");
  ASSERT_EQ(ResolvePath("linkdir/model.yaml", &through_dir), "");
  ASSERT_EQ(ResolvePath("alias.h5", &through_link), "");
  ASSERT_EQ(ResolvePath("dangling.h5", &dangling), "");
  ASSERT_EQ(ResolvePath("real/not-yet.h5", &target), "");
  EXPECT_EQ(through_dir.canonical, model.canonical);
  EXPECT_EQ(through_link.canonical, model.canonical);
  EXPECT_TRUE(through_link.is_symlink);
  // A dangling link resolves to where a file created through it would appear.
  EXPECT_TRUE(dangling.is_symlink);
  EXPECT_FALSE(dangling.exists);
  EXPECT_EQ(dangling.canonical, target.canonical);
  EXPECT_TRUE(SameFile(dangling, target));
}

TEST_F(FileSafety, ResolveReportsMissingParentsLoopsAndEmptyNames)
{
  ResolvedPath resolved;
  EXPECT_EQ(ResolvePath("no/such/dir/out.h5", &resolved), "cannot resolve 'no/such/dir/out.h5': No such file or directory");
  WriteText("file", "x");
  EXPECT_EQ(ResolvePath("file/out.h5", &resolved), "cannot resolve 'file/out.h5': Not a directory");
  ASSERT_EQ(::symlink("loop-b", "loop-a"), 0);
  ASSERT_EQ(::symlink("loop-a", "loop-b"), 0);
  EXPECT_EQ(ResolvePath("loop-a", &resolved), "cannot resolve 'loop-a': Too many levels of symbolic links");
  EXPECT_EQ(ResolvePath("", &resolved), "cannot resolve '': the file name is empty");
  ASSERT_EQ(ResolvePath("./", &resolved), "");
  EXPECT_TRUE(resolved.is_directory);
}

TEST_F(FileSafety, HardLinksAreTheSameFile)
{
  WriteText("in.yaml", "x");
  ASSERT_EQ(::link("in.yaml", "out.h5"), 0);
  ResolvedPath a, b;
  ASSERT_EQ(ResolvePath("in.yaml", &a), "");
  ASSERT_EQ(ResolvePath("out.h5", &b), "");
  EXPECT_NE(a.canonical, b.canonical);
  EXPECT_TRUE(SameFile(a, b));
}

// --- CheckWritableTarget and CheckRunPaths ---

TEST_F(FileSafety, WritableTargetRefusesDirectoriesMissingParentsSpecialFilesAndEmptyNames)
{
  ASSERT_EQ(::mkdir("results", 0755), 0);
  EXPECT_EQ(CheckWritableTarget("output file", "results"), "cannot create output file 'results': Is a directory");
  EXPECT_EQ(CheckWritableTarget("output file", "results/"), "cannot create output file 'results/': Is a directory");
  EXPECT_EQ(CheckWritableTarget("output file", "missing/out.h5"), "cannot create output file 'missing/out.h5': No such file or directory");
  EXPECT_EQ(CheckWritableTarget("checkpoint file", ""), "the checkpoint file name is empty");
  EXPECT_EQ(CheckWritableTarget("output file", "/dev/null"), "cannot create output file '/dev/null': it exists and is not a regular file");
  ASSERT_EQ(::mkfifo("fifo.h5", 0644), 0);
  EXPECT_EQ(CheckWritableTarget("output file", "fifo.h5"), "cannot create output file 'fifo.h5': it exists and is not a regular file");
  EXPECT_EQ(CheckWritableTarget("output file", "results/out.h5"), "");
  WriteText("existing.h5", "x");
  EXPECT_EQ(CheckWritableTarget("output file", "existing.h5"), ""); // whether it may be replaced is the caller's policy
}

TEST_F(FileSafety, RunPathsRefuseEveryAlias)
{
  ASSERT_EQ(::mkdir("sub", 0755), 0);
  WriteText("model.yaml", "x");
  WriteText("mesh.h5", "x");
  ASSERT_EQ(::symlink("model.yaml", "link.h5"), 0);
  const auto check = [](const std::string &output, const std::string &checkpoint) {
    return CheckRunPaths({{"input file", "model.yaml", false},
                          {"mesh file", "mesh.h5", false},
                          {"output file", output, true},
                          {"XDMF sidecar", SidecarPath(output), true},
                          {"checkpoint file", checkpoint, true}});
  };
  EXPECT_EQ(check("out.h5", "out.ckpt.h5"), "");
  EXPECT_EQ(check("out.h5", "./out.h5"),
            "the checkpoint file './out.h5' is the same file as the output file 'out.h5'; msflex never writes over another file of the run");
  EXPECT_EQ(check("out.h5", "sub/../model.yaml"),
            "the checkpoint file 'sub/../model.yaml' is the same file as the input file 'model.yaml'; msflex never writes over another file of the run");
  EXPECT_EQ(check("out.h5", dir_ + "/sub/../mesh.h5"),
            "the checkpoint file '" + dir_ + "/sub/../mesh.h5' is the same file as the mesh file 'mesh.h5'; msflex never writes over another file of the run");
  EXPECT_EQ(check("link.h5", "c.h5"),
            "the output file 'link.h5' is the same file as the input file 'model.yaml'; msflex never writes over another file of the run");
  EXPECT_EQ(check("mesh.h5", "c.h5"),
            "the output file 'mesh.h5' is the same file as the mesh file 'mesh.h5'; msflex never writes over another file of the run");
  // An output named .xmf is its own sidecar.
  EXPECT_EQ(check("out.xmf", "c.h5"),
            "the XDMF sidecar 'out.xmf' is the same file as the output file 'out.xmf'; msflex never writes over another file of the run");
  EXPECT_EQ(check("out.h5", "out.xmf"),
            "the checkpoint file 'out.xmf' is the same file as the XDMF sidecar 'out.xmf'; msflex never writes over another file of the run");
  // Hard link to the input.
  ASSERT_EQ(::link("model.yaml", "hard.h5"), 0);
  EXPECT_EQ(check("hard.h5", "c.h5"),
            "the output file 'hard.h5' is the same file as the input file 'model.yaml'; msflex never writes over another file of the run");
  // A restart may write its checkpoints where it read one.
  EXPECT_EQ(CheckRunPaths({{"restart checkpoint", "c.h5", false}, {"checkpoint file", "./c.h5", true}}, {{"restart checkpoint", "checkpoint file"}}), "");
  EXPECT_NE(CheckRunPaths({{"restart checkpoint", "c.h5", false}, {"checkpoint file", "./c.h5", true}}), "");
  // Missing directory, directory, empty name.
  EXPECT_EQ(check("out.h5", "nowhere/c.h5"), "cannot create checkpoint file 'nowhere/c.h5': No such file or directory");
  EXPECT_EQ(check("out.h5", "sub"), "cannot create checkpoint file 'sub': Is a directory");
  EXPECT_EQ(check("out.h5", ""), "the checkpoint file name is empty");
}

// --- TemporaryFile ---

TEST_F(FileSafety, AtomicWriteReplacesTargetAndLeavesNoTemporary)
{
  WriteText("out.xmf", "old");
  ASSERT_EQ(WriteFileAtomically("out.xmf", "new contents", Durability::Synced), "");
  EXPECT_EQ(ReadAll("out.xmf"), "new contents");
  EXPECT_EQ(Entries("."), std::set<std::string>{"out.xmf"});
  struct stat info;
  ASSERT_EQ(::stat("out.xmf", &info), 0);
  const mode_t mask = ::umask(0);
  ::umask(mask);
  EXPECT_EQ(info.st_mode & 0777, 0666 & ~mask); // not mkstemp's 0600
}

TEST_F(FileSafety, SyncFileNamesTheFileItCannotSync)
{
  WriteText("out.h5", "result");
  EXPECT_EQ(SyncFile("out.h5"), "");
  EXPECT_EQ(ReadAll("out.h5"), "result");
  EXPECT_EQ(SyncFile("missing.xmf"), "cannot open 'missing.xmf': No such file or directory");
}

TEST_F(FileSafety, SymlinkAtOldFixedTemporaryNameIsNeverFollowed)
{
  // The finding: out.xmf.tmp (or NAME.ckpt.h5.tmp) as a link to someone's file was written through.
  WriteText("victim", "precious");
  ASSERT_EQ(::symlink("victim", "out.xmf.tmp"), 0);
  ASSERT_EQ(::symlink("victim", "out.ckpt.h5.tmp"), 0);
  ASSERT_EQ(WriteFileAtomically("out.xmf", "sidecar", Durability::Unsynced), "");
  ASSERT_EQ(WriteFileAtomically("out.ckpt.h5", "checkpoint", Durability::Synced), "");
  EXPECT_EQ(ReadAll("victim"), "precious");
  EXPECT_TRUE(IsSymlink("out.xmf.tmp"));
  EXPECT_TRUE(IsSymlink("out.ckpt.h5.tmp"));
  EXPECT_EQ(ReadAll("out.xmf"), "sidecar");
  EXPECT_EQ(Entries("."), (std::set<std::string>{"victim", "out.xmf.tmp", "out.ckpt.h5.tmp", "out.xmf", "out.ckpt.h5"}));
}

TEST_F(FileSafety, TargetSymlinkIsReplacedNotWrittenThrough)
{
  WriteText("victim", "precious");
  ASSERT_EQ(::symlink("victim", "out.xmf"), 0);
  ASSERT_EQ(::symlink("nowhere/at/all", "dangling.xmf"), 0);
  ASSERT_EQ(WriteFileAtomically("out.xmf", "sidecar", Durability::Unsynced), "");
  ASSERT_EQ(WriteFileAtomically("dangling.xmf", "sidecar", Durability::Synced), "");
  EXPECT_EQ(ReadAll("victim"), "precious");
  EXPECT_FALSE(IsSymlink("out.xmf"));
  EXPECT_FALSE(IsSymlink("dangling.xmf"));
  EXPECT_EQ(ReadAll("out.xmf"), "sidecar");
}

TEST_F(FileSafety, TemporaryCreationNeverReusesAnExistingName)
{
  // Many temporaries beside one target: all distinct, each a new regular file.
  std::vector<std::unique_ptr<TemporaryFile>> files;
  std::set<std::string>                       names;
  for (int k = 0; k < 50; ++k) {
    files.push_back(std::make_unique<TemporaryFile>());
    ASSERT_EQ(files.back()->Create("out.h5"), "");
    EXPECT_TRUE(HasPrefix(files.back()->Path(), "out.h5.tmp.")) << files.back()->Path();
    names.insert(files.back()->Path());
  }
  EXPECT_EQ(names.size(), 50u);
  files.clear(); // uncommitted: removed
  EXPECT_TRUE(Entries(".").empty());
}

TEST_F(FileSafety, TemporaryCreationFailsInMissingOrNonDirectoryPlaces)
{
  TemporaryFile     file;
  const std::string problem = file.Create("missing/out.h5");
  EXPECT_TRUE(HasPrefix(problem, "cannot create 'missing/out.h5.tmp.")) << problem;
  EXPECT_NE(problem.find("': No such file or directory"), std::string::npos) << problem;
  WriteText("plain", "x");
  const std::string not_directory = file.Create("plain/out.h5");
  EXPECT_NE(not_directory.find("': Not a directory"), std::string::npos) << not_directory;
  EXPECT_EQ(file.Create(""), "cannot create a temporary file for '': the file name is empty");
}

TEST_F(FileSafety, CommitOntoADirectoryFailsAndRemovesTheTemporary)
{
  ASSERT_EQ(::mkdir("out.xmf", 0755), 0);
  for (const Durability durability : {Durability::Synced, Durability::Unsynced}) {
    const std::string problem = WriteFileAtomically("out.xmf", "x", durability);
    EXPECT_TRUE(HasPrefix(problem, "cannot rename 'out.xmf.tmp.")) << problem;
    EXPECT_NE(problem.find("to 'out.xmf': Is a directory"), std::string::npos) << problem;
    EXPECT_EQ(Entries("."), std::set<std::string>{"out.xmf"});
  }
}

TEST_F(FileSafety, ReplacedTemporaryIsDetectedAndTheTargetKept)
{
  WriteText("out.h5", "old result");
  WriteText("victim", "precious");
  for (const Durability durability : {Durability::Synced, Durability::Unsynced}) {
    TemporaryFile file;
    ASSERT_EQ(file.Create("out.h5"), "");
    ASSERT_EQ(file.Close(), "");
    // Another process swaps the temporary for a link while a library writes it by name.
    ASSERT_EQ(::unlink(file.Path().c_str()), 0);
    ASSERT_EQ(::symlink("victim", file.Path().c_str()), 0);
    EXPECT_NE(file.CheckStillOurs(), "");
    const std::string problem = file.Commit(durability);
    EXPECT_NE(problem.find("was replaced by another process"), std::string::npos) << problem;
    EXPECT_EQ(ReadAll("out.h5"), "old result");
    EXPECT_EQ(ReadAll("victim"), "precious");
  }
}

// Runs `checks` in a child process that sees a read-only tmpfs at `place` (its own mount
// namespace, private propagation: nothing changes outside it). Root ignores permission bits, so
// a read-only file system is the one way to test "cannot write here" under root. Returns the
// child's report, "skip: ..." when it could not set the place up.
std::string InReadOnlyPlace(const std::string &place, std::string (*checks)(const std::string &))
{
  int channel[2];
  if (::pipe(channel) != 0) return "skip: no pipe";
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(channel[0]);
    std::string report;
    if (::unshare(CLONE_NEWNS) != 0) report = std::string("skip: cannot make a mount namespace: ") + std::strerror(errno);
    else if (::mount("none", "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) report = std::string("skip: ") + std::strerror(errno);
    else if (::mount("none", place.c_str(), "tmpfs", MS_RDONLY, "size=64k") != 0)
      report = std::string("skip: cannot mount a read-only tmpfs: ") + std::strerror(errno);
    else report = checks(place);
    if (::write(channel[1], report.data(), report.size()) < 0) _exit(2);
    _exit(0);
  }
  ::close(channel[1]);
  std::string report;
  char        buffer[512];
  for (ssize_t got; (got = ::read(channel[0], buffer, sizeof buffer)) > 0;) report.append(buffer, static_cast<size_t>(got));
  ::close(channel[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  return report;
}

TEST_F(FileSafety, UnwritablePlaceIsOneLine)
{
  ASSERT_EQ(::mkdir("readonly", 0755), 0);
  std::string report;
  if (::geteuid() != 0) {
    ASSERT_EQ(::chmod("readonly", 0555), 0);
    report = CheckWritableTarget("output file", "readonly/out.h5") + "|" + WriteFileAtomically("readonly/out.xmf", "x", Durability::Synced);
    ::chmod("readonly", 0755);
    EXPECT_EQ(report, "cannot create output file 'readonly/out.h5': Permission denied|" + report.substr(report.find('|') + 1));
    EXPECT_NE(report.find("|cannot create 'readonly/out.xmf.tmp."), std::string::npos) << report;
    return;
  }
  report = InReadOnlyPlace(Abs("readonly"), [](const std::string &place) {
    return CheckWritableTarget("output file", place + "/out.h5") + "|" + WriteFileAtomically(place + "/out.xmf", "x", Durability::Unsynced);
  });
  if (HasPrefix(report, "skip:")) GTEST_SKIP() << "running as root without a read-only place to test: " << report;
  EXPECT_EQ(report.substr(0, report.find('|')), "cannot create output file '" + Abs("readonly") + "/out.h5': Read-only file system");
  EXPECT_NE(report.find("|cannot create '" + Abs("readonly") + "/out.xmf.tmp."), std::string::npos) << report;
  EXPECT_NE(report.find("': Read-only file system"), std::string::npos) << report;
}

// --- Heads, sizes ---

TEST_F(FileSafety, ReadFileHeadAndSize)
{
  WriteText("a.txt", "0123456789");
  std::string head, problem;
  ASSERT_EQ(ReadFileHead("a.txt", 4, &head), "");
  EXPECT_EQ(head, "0123");
  EXPECT_EQ(FileSize("a.txt", &problem), 10);
  EXPECT_EQ(FileSize("missing", &problem), -1);
  EXPECT_EQ(problem, "cannot open 'missing': No such file or directory");
  ASSERT_EQ(::mkfifo("fifo", 0644), 0);
  EXPECT_EQ(ReadFileHead("fifo", 4, &head), "cannot read 'fifo': not a regular file"); // and does not block
  ASSERT_EQ(::mkdir("d", 0755), 0);
  EXPECT_EQ(ReadFileHead("d", 4, &head), "cannot read 'd': Is a directory");
}

// --- SHA-256, fingerprints, run identities ---

std::string Sha256Hex(const std::string &text)
{
  Sha256 hash;
  hash.Update(text);
  return Sha256::Hex(hash.Finish());
}

TEST(Sha256Test, KnownAnswers)
{
  // FIPS 180-4 examples and the usual one-million-'a' vector.
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"), "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  // 55, 56, 63, 64 and 65 bytes: the padding boundaries.
  EXPECT_EQ(Sha256Hex(std::string(55, 'a')), "9f4390f8d30c2dd92ec9f095b65e2b9ae9b0a925a5258e241c9f1e910f734318");
  EXPECT_EQ(Sha256Hex(std::string(56, 'a')), "b35439a4ac6f0948b6d6f9e3c6af0f5f590ce20f1bde7090ef7970686ec6738a");
  EXPECT_EQ(Sha256Hex(std::string(64, 'a')), "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb");
}

TEST(Sha256Test, PiecewiseEqualsWhole)
{
  std::string text;
  for (int k = 0; k < 1000; ++k) text += static_cast<char>(k * 37 + 11);
  for (const size_t piece : {1u, 7u, 63u, 64u, 65u, 999u}) {
    Sha256 hash;
    for (size_t at = 0; at < text.size(); at += piece) hash.Update(text.data() + at, std::min(piece, text.size() - at));
    EXPECT_EQ(Sha256::Hex(hash.Finish()), Sha256Hex(text)) << piece;
  }
}

TEST(FingerprintTest, DependsOnBothFieldsAndTheirBoundary)
{
  const std::string a = ModelFingerprint("nodes: {}", "-output_every 2");
  EXPECT_TRUE(HasPrefix(a, "sha256:"));
  EXPECT_EQ(a.size(), 7u + 64u);
  EXPECT_EQ(a, ModelFingerprint("nodes: {}", "-output_every 2"));
  EXPECT_NE(a, ModelFingerprint("nodes: {} ", "-output_every 2"));
  EXPECT_NE(a, ModelFingerprint("nodes: {}", "-output_every 3"));
  EXPECT_NE(ModelFingerprint("ab", "c"), ModelFingerprint("a", "bc"));
}

TEST(RunIdTest, RandomHex)
{
  const std::string a = NewRunId(), b = NewRunId();
  ASSERT_EQ(a.size(), 32u);
  EXPECT_EQ(a.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_NE(a, b);
}

TEST(SidecarTest, RecognisesMsflexSidecars)
{
  EXPECT_TRUE(IsMsflexSidecar(std::string("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    ") + kSidecarMarker));
  EXPECT_TRUE(IsMsflexSidecar("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    <Grid Name=\"msflex\" GridType=\"Collection\" "));
  EXPECT_TRUE(
      IsMsflexSidecar("<?xml version=\"1.0\" ?>\n<!-- msflex results (layout: docs/output.md). Each temporal collection of the Domain takes its grids"));
  EXPECT_FALSE(IsMsflexSidecar("<?xml version=\"1.0\" ?>\n<Xdmf><Domain><Grid Name=\"other\"/>"));
  EXPECT_FALSE(IsMsflexSidecar("sections:\n  - {name: steel}\n"));
  EXPECT_EQ(SidecarPath("dir/out.h5"), "dir/out.xmf");
  EXPECT_EQ(SidecarPath("out"), "out.xmf");
}

// --- HDF5: quiet failures, markers, classification ---

// An HDF5 file with `build` run on it.
template <class Build> void MakeHdf5(const std::string &path, Build &&build)
{
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  build(file);
  ASSERT_GE(H5Fclose(file), 0);
}

void MakeGroup(hid_t file, const char *name) { H5Gclose(H5Gcreate2(file, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT)); }

void MakeDoubles(hid_t parent, const char *name, std::vector<hsize_t> dims, const std::vector<double> &values, hid_t create = H5P_DEFAULT)
{
  const hid_t space   = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t dataset = H5Dcreate2(parent, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, create, H5P_DEFAULT);
  if (!values.empty()) H5Dwrite(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  H5Dclose(dataset);
  H5Sclose(space);
}

void MakeText(hid_t parent, const char *name, const std::string &text)
{
  const hsize_t size    = text.size();
  const hid_t   space   = H5Screate_simple(1, &size, nullptr);
  const hid_t   dataset = H5Dcreate2(parent, name, H5T_NATIVE_CHAR, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (size > 0) H5Dwrite(dataset, H5T_NATIVE_CHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data());
  H5Dclose(dataset);
  H5Sclose(space);
}

// A chunked dataset that claims `rows` x columns but whose chunks were never written.
void MakeHollow(hid_t parent, const char *name, hsize_t rows, hsize_t columns, hid_t type = H5T_IEEE_F64LE)
{
  const hsize_t dims[2] = {rows, columns}, chunk[2] = {std::min<hsize_t>(rows, 1024), columns};
  const int     rank   = columns == 0 ? 1 : 2;
  const hid_t   space  = H5Screate_simple(rank, dims, nullptr);
  const hid_t   create = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(create, rank, chunk);
  H5Dclose(H5Dcreate2(parent, name, type, space, H5P_DEFAULT, create, H5P_DEFAULT));
  H5Pclose(create);
  H5Sclose(space);
}

TEST_F(FileSafety, Hdf5FailuresAreOneLineAndPrintNothing)
{
  Hdf5SilenceErrorStack();
  WriteText("text.h5", "not hdf5 at all");
  ASSERT_EQ(::mkdir("dir.h5", 0755), 0);
  MakeHdf5("existing.h5", [](hid_t) {});
  testing::internal::CaptureStderr();
  std::string missing, foreign, directory, empty, nowhere, exclusive;
  EXPECT_LT(Hdf5OpenFile("missing.h5", H5F_ACC_RDONLY, H5P_DEFAULT, &missing), 0);
  EXPECT_LT(Hdf5OpenFile("text.h5", H5F_ACC_RDONLY, H5P_DEFAULT, &foreign), 0);
  EXPECT_LT(Hdf5OpenFile("dir.h5", H5F_ACC_RDONLY, H5P_DEFAULT, &directory), 0);
  EXPECT_LT(Hdf5OpenFile("", H5F_ACC_RDONLY, H5P_DEFAULT, &empty), 0);
  EXPECT_LT(Hdf5CreateFile("nowhere/out.h5", H5F_ACC_EXCL, H5P_DEFAULT, &nowhere), 0);
  EXPECT_LT(Hdf5CreateFile("existing.h5", H5F_ACC_EXCL, H5P_DEFAULT, &exclusive), 0);
  const std::string printed = testing::internal::GetCapturedStderr();
  EXPECT_EQ(printed, "");
  EXPECT_EQ(missing, "cannot open 'missing.h5': No such file or directory");
  EXPECT_EQ(foreign, "cannot open 'text.h5': not an HDF5 file");
  EXPECT_EQ(directory, "cannot open 'dir.h5': Is a directory");
  EXPECT_EQ(empty, "cannot open '': the file name is empty");
  EXPECT_EQ(nowhere, "cannot create 'nowhere/out.h5': No such file or directory");
  EXPECT_EQ(exclusive, "cannot create 'existing.h5': File exists");
}

TEST_F(FileSafety, MarkersRoundTripAndClassifyFiles)
{
  const FileMarker result{kResultFormat, ModelFingerprint("text", "options"), NewRunId()};
  MakeHdf5("result.h5", [&](hid_t file) { ASSERT_EQ(WriteFileMarker(file, result), ""); });
  MakeHdf5("checkpoint.h5", [&](hid_t file) { ASSERT_EQ(WriteFileMarker(file, {kCheckpointFormat, result.model, result.run}), ""); });
  MakeHdf5("legacy.h5", [](hid_t file) {
    MakeText(file, "input", "x");
    MakeGroup(file, "mesh");
    MakeDoubles(file, "mesh/node_coordinates", {1, 3}, {0, 0, 0});
    for (const char *group : {"frames", "history", "probes"}) MakeGroup(file, group);
  });
  MakeHdf5("legacy.ckpt.h5", [](hid_t file) {
    MakeGroup(file, "run");
    MakeText(file, "run/format", "msflex checkpoint 1");
  });
  MakeHdf5("other.h5", [](hid_t file) { MakeDoubles(file, "data", {2}, {1, 2}); });
  WriteText("mesh.yaml", "nodes: {}\n");
  WriteText("out.xmf", std::string("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    ") + kSidecarMarker + "\n");
  ASSERT_EQ(::mkdir("dir.h5", 0755), 0);

  ExistingFile file;
  ASSERT_EQ(ClassifyExistingFile("result.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::MsflexResult);
  EXPECT_EQ(file.marker.model, result.model);
  EXPECT_EQ(file.marker.run, result.run);
  EXPECT_FALSE(file.legacy);
  ASSERT_EQ(ClassifyExistingFile("checkpoint.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::MsflexCheckpoint);
  ASSERT_EQ(ClassifyExistingFile("legacy.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::MsflexResult);
  EXPECT_TRUE(file.legacy);
  ASSERT_EQ(ClassifyExistingFile("legacy.ckpt.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::MsflexCheckpoint);
  EXPECT_TRUE(file.legacy);
  ASSERT_EQ(ClassifyExistingFile("other.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::Foreign);
  ASSERT_EQ(ClassifyExistingFile("mesh.yaml", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::Foreign);
  ASSERT_EQ(ClassifyExistingFile("out.xmf", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::MsflexSidecar);
  ASSERT_EQ(ClassifyExistingFile("dir.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::NotRegular);
  ASSERT_EQ(ClassifyExistingFile("none.h5", &file), "");
  EXPECT_EQ(file.kind, ExistingKind::Missing);
}

// The run-file policy, on the findings of issue 16. Every file present before a check keeps its bytes.
class RunFilePolicy : public FileSafety {
protected:
  void SetUp() override
  {
    FileSafety::SetUp();
    WriteText("model.yaml", "sections: []\n");
    MakeHdf5("mesh.h5", [](hid_t file) { MakeDoubles(file, "x", {1}, {1}); });
    run_ = NewRunId();
    MakeHdf5("old.h5", [&](hid_t file) { ASSERT_EQ(WriteFileMarker(file, {kResultFormat, "sha256:0", run_}), ""); });
    MakeHdf5("old.ckpt.h5", [&](hid_t file) { ASSERT_EQ(WriteFileMarker(file, {kCheckpointFormat, "sha256:0", run_}), ""); });
    WriteText("notes.txt", "keep me");
    for (const auto &entry : Entries(".")) before_[entry] = ReadAll(entry);
  }
  void TearDown() override
  {
    for (const auto &[name, bytes] : before_) EXPECT_EQ(ReadAll(name), bytes) << name << " changed";
    FileSafety::TearDown();
  }
  RunFiles Fresh(const std::string &output, const std::string &checkpoint, bool overwrite = false) const
  {
    RunFiles files;
    files.input      = "model.yaml";
    files.mesh       = "mesh.h5";
    files.output     = output;
    files.checkpoint = checkpoint;
    files.overwrite  = overwrite;
    return files;
  }

  std::string                        run_;
  std::map<std::string, std::string> before_;
};

TEST_F(RunFilePolicy, FreshRunsWriteOnlyNewOrTheirOwnFiles)
{
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "out.ckpt.h5")), "");
  // -checkpoint_file naming the input, an unrelated file, or the output.
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "model.yaml")),
            "the checkpoint file 'model.yaml' is the same file as the input file 'model.yaml'; msflex never writes over another file of the run");
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "notes.txt")),
            "refusing to replace the checkpoint file 'notes.txt': it is a file that msflex did not write; msflex replaces only its own checkpoints");
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "./out.h5")),
            "the checkpoint file './out.h5' is the same file as the output file 'out.h5'; msflex never writes over another file of the run");
  // -output_file naming the input or the mesh, with -output_overwrite.
  EXPECT_EQ(CheckRunFiles(Fresh("model.yaml", "c.h5", true)),
            "the output file 'model.yaml' is the same file as the input file 'model.yaml'; msflex never writes over another file of the run");
  EXPECT_EQ(CheckRunFiles(Fresh("mesh.h5", "c.h5", true)),
            "the output file 'mesh.h5' is the same file as the mesh file 'mesh.h5'; msflex never writes over another file of the run");
  // Overwrite replaces msflex results only.
  EXPECT_EQ(CheckRunFiles(Fresh("old.h5", "c.h5")), "output file 'old.h5' exists; pass -output_overwrite to replace it");
  EXPECT_EQ(CheckRunFiles(Fresh("old.h5", "c.h5", true)), "");
  EXPECT_EQ(CheckRunFiles(Fresh("notes.txt", "c.h5", true)),
            "refusing to replace the output file 'notes.txt': it is a file that msflex did not write; -output_overwrite replaces only msflex result files");
  // A stale checkpoint of another run.
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "old.ckpt.h5")),
            "checkpoint file 'old.ckpt.h5' exists (from another run); pass -output_overwrite to replace it, or continue it with --restart");
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "old.ckpt.h5", true)), "");
  EXPECT_EQ(CheckRunFiles(Fresh("out.h5", "old.h5", true)),
            "refusing to replace the checkpoint file 'old.h5': it is an msflex result file; msflex replaces only its own checkpoints");
}

TEST_F(RunFilePolicy, SidecarsAreReplacedOnlyWhenMsflexWroteThem)
{
  WriteText("new.xmf", std::string("<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    ") + kSidecarMarker + "\n");
  WriteText("mine.xmf", "<my own notes/>");
  before_["new.xmf"]  = ReadAll("new.xmf");
  before_["mine.xmf"] = ReadAll("mine.xmf");
  EXPECT_EQ(CheckRunFiles(Fresh("new.h5", "c.h5")), "XDMF sidecar 'new.xmf' exists; pass -output_overwrite to replace it");
  EXPECT_EQ(CheckRunFiles(Fresh("new.h5", "c.h5", true)), "");
  EXPECT_EQ(CheckRunFiles(Fresh("mine.h5", "c.h5", true)),
            "refusing to replace the XDMF sidecar 'mine.xmf': it is a file that msflex did not write; msflex replaces only the sidecars it wrote");
}

TEST_F(RunFilePolicy, RestartsContinueOnlyTheirOwnResult)
{
  RunFiles files;
  files.restart         = "old.ckpt.h5";
  files.output          = "old.h5";
  files.checkpoint      = "old.ckpt.h5";
  files.continue_output = true;
  files.run             = run_;
  EXPECT_EQ(CheckRunFiles(files), "");
  files.run = NewRunId(); // the checkpoint of another run
  EXPECT_EQ(CheckRunFiles(files),
            "the output file 'old.h5' belongs to another run than the checkpoint 'old.ckpt.h5'; continue into a new file with -output_file NEW.h5");
  files.output = "notes.txt";
  EXPECT_EQ(CheckRunFiles(files),
            "refusing to replace the output file 'notes.txt': it is a file that msflex did not write; a restart continues only an msflex result file");
}

// --- Validated reads ---

TEST_F(FileSafety, StorageCheckRefusesHollowDatasetsBeforeAllocating)
{
  MakeHdf5("mesh.h5", [](hid_t file) {
    MakeHollow(file, "hollow", 400000000, 3);
    MakeDoubles(file, "real", {1000, 3}, std::vector<double>(3000, 1.5));
    // Compressed zeros: about 1000:1, still plausible.
    const hid_t   create   = H5Pcreate(H5P_DATASET_CREATE);
    const hsize_t chunk[2] = {10000, 3};
    H5Pset_chunk(create, 2, chunk);
    H5Pset_deflate(create, 9);
    MakeDoubles(file, "zeros", {100000, 3}, std::vector<double>(300000, 0.0), create);
    H5Pclose(create);
  });
  std::string problem;
  const hid_t file = Hdf5OpenFile("mesh.h5", H5F_ACC_RDONLY, H5P_DEFAULT, &problem);
  ASSERT_GE(file, 0) << problem;
  const unsigned long long size  = static_cast<unsigned long long>(FileSize("mesh.h5", &problem));
  const auto               check = [&](const char *name) {
    const hid_t       dataset = H5Dopen2(file, name, H5P_DEFAULT);
    const std::string found   = DatasetStorageProblem(dataset, size);
    H5Dclose(dataset);
    return found;
  };
  const std::string hollow = check("hollow");
  EXPECT_TRUE(HasPrefix(hollow, "claims 1200000000 entries (9600000000 bytes) but the file holds only 0 bytes of them")) << hollow;
  EXPECT_EQ(check("real"), "");
  EXPECT_EQ(check("zeros"), "");
  H5Fclose(file);
}

TEST_F(FileSafety, ValidatedReadsCheckShapesLengthsAndValues)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  MakeHdf5("c.h5", [&](hid_t file) {
    MakeGroup(file, "run");
    MakeDoubles(file, "run/numbers", {11}, std::vector<double>(11, 1.0));
    MakeDoubles(file, "run/long", {100000}, std::vector<double>(100000, 1.0));
    std::vector<double> with_nan(11, 1.0);
    with_nan[1] = nan;
    MakeDoubles(file, "run/nan", {11}, with_nan);
    MakeText(file, "run/input_text", "sections: []");
    MakeHollow(file, "run/huge_text", 1ull << 40, 0, H5T_NATIVE_CHAR);
    MakeDoubles(file, "nodes", {4, 19}, std::vector<double>(76, 0.5));
  });
  std::string problem;
  const hid_t file = Hdf5OpenFile("c.h5", H5F_ACC_RDONLY, H5P_DEFAULT, &problem);
  ASSERT_GE(file, 0);
  std::vector<double> values;
  std::string         text;
  EXPECT_EQ(ReadExactDoubles(file, "/run/numbers", 11, &values), "");
  EXPECT_EQ(values.size(), 11u);
  EXPECT_EQ(ReadExactDoubles(file, "/run/long", 11, &values), "/run/long has 100000 entries, expected 11");
  EXPECT_TRUE(values.empty());
  EXPECT_EQ(ReadExactDoubles(file, "/run/nan", 11, &values), "/run/nan entry 1 is not a finite number");
  EXPECT_EQ(ReadExactDoubles(file, "/run/missing", 11, &values), "no dataset /run/missing");
  EXPECT_EQ(ReadExactDoubles(file, "/run", 11, &values), "/run is not a dataset");
  EXPECT_EQ(ReadBoundedText(file, "/run/input_text", 1 << 20, &text), "");
  EXPECT_EQ(text, "sections: []");
  const std::string huge = ReadBoundedText(file, "/run/huge_text", 1 << 20, &text);
  EXPECT_TRUE(HasPrefix(huge, "/run/huge_text claims 1099511627776 entries")) << huge;
  EXPECT_EQ(ReadBoundedText(file, "/run/input_text", 5, &text), "/run/input_text claims 12 bytes, more than the 5 allowed");
  EXPECT_EQ(CheckTableShape(file, "/nodes", 4, 19), "");
  EXPECT_EQ(CheckTableShape(file, "/nodes", 5, 19), "/nodes has shape (4, 19), expected (5, 19)");
  std::vector<hsize_t> dims;
  EXPECT_EQ(DatasetDims(file, "/nodes", &dims), "");
  EXPECT_EQ(dims, (std::vector<hsize_t>{4, 19}));
  H5Fclose(file);
}

} // namespace
