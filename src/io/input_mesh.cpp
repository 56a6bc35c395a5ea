// Reading the HDF5 mesh file named by the top-level key `mesh` (docs/input.md, "mesh"): the nodes,
// straight beams and joints of a large network. Beams and joints are expanded by the same code as
// their YAML counterparts (input_beams.cpp, input_joints.cpp). Every failure is an InputFailure at
// the `mesh:` key whose message names the mesh file, the dataset and the (0-based) row.
//
// With several reading ranks (ReadModelFile's communicator) every dataset is read in slices of
// rows, one per rank, and the slices are then exchanged, so that each rank reads 1/P of the file
// and all end with the same mesh. Whether a file opens and whether a read succeeds is agreed on by
// all ranks before anyone goes on, so a failure on one rank cannot leave the others waiting.
#include "io/input_reader_internal.hpp"

#include "core/hdf5_files.hpp"
#include "core/mpi_util.hpp"

#include <hdf5.h>
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace msflex::input_detail {

namespace {

// Node indices and counts are int in the model; a mesh keeps well below that.
constexpr long long kMaxRows = INT_MAX / 4;

// What one generated node and its element take in the reader at least (Node with its name,
// BeamElement with its reference triads, the name's entry in the namespace): a lower bound, so
// that a model refused for its size could never have been read.
constexpr long long kMinBytesPerGeneratedNode = 512;

// The machine's physical memory in bytes, or 0 when unknown.
long long PhysicalMemoryBytes()
{
  const long pages = sysconf(_SC_PHYS_PAGES), page_size = sysconf(_SC_PAGESIZE);
  return pages > 0 && page_size > 0 ? static_cast<long long>(pages) * page_size : 0;
}

// Closes an HDF5 identifier when it goes out of scope.
class Handle {
public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle()
  {
    if (id_ >= 0) close_(id_);
  }
  Handle(Handle &&other) noexcept : id_(other.id_), close_(other.close_) { other.id_ = -1; }
  Handle(const Handle &)            = delete;
  Handle &operator=(const Handle &) = delete;
  Handle &operator=(Handle &&)      = delete;
  hid_t   Get() const { return id_; }
  bool    Valid() const { return id_ >= 0; }

private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

// HDF5 prints its error stack on every failed call unless told not to; missing datasets and the
// like are reported as input errors instead. The previous setting is restored afterwards.
class QuietHdf5Errors {
public:
  QuietHdf5Errors()
  {
    H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, function_, data_); }
  QuietHdf5Errors(const QuietHdf5Errors &)            = delete;
  QuietHdf5Errors &operator=(const QuietHdf5Errors &) = delete;

private:
  H5E_auto2_t function_ = nullptr;
  void       *data_     = nullptr;
};

// The expected shape of a dataset: (rows) when columns == 0, else (rows, columns); rows < 0 means
// any number of rows, written as `symbol` in messages.
struct Shape {
  long long   rows    = -1;
  int         columns = 0;
  const char *symbol  = "n";
};

std::string FormatShape(const std::vector<hsize_t> &dims)
{
  std::string text = "(";
  for (size_t axis = 0; axis < dims.size(); ++axis) text += (axis > 0 ? ", " : "") + std::to_string(dims[axis]);
  return text + (dims.size() == 1 ? ",)" : ")");
}

std::string FormatShape(const Shape &shape)
{
  const std::string rows = shape.rows < 0 ? std::string(shape.symbol) : std::to_string(shape.rows);
  return shape.columns == 0 ? "(" + rows + ",)" : "(" + rows + ", " + std::to_string(shape.columns) + ")";
}

std::string TypeClassName(H5T_class_t type_class)
{
  switch (type_class) {
  case H5T_INTEGER:
    return "integers";
  case H5T_FLOAT:
    return "floating-point numbers";
  case H5T_STRING:
    return "strings";
  default:
    return "HDF5 type class " + std::to_string(static_cast<int>(type_class));
  }
}

std::string Row(long long row) { return " row " + std::to_string(row); }

// The ranks reading the mesh together; a single reader when MPI is not initialised.
class ReaderGroup {
public:
  explicit ReaderGroup(MPI_Comm comm) : comm_(comm) { CommSizeRank(comm, &size_, &rank_); }
  bool Parallel() const { return size_ > 1; }

  // Whether `ok` holds on every rank.
  bool AllOk(bool ok) const
  {
    if (!Parallel()) return ok;
    int mine = ok ? 1 : 0, all = 0;
    MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_LAND, comm_);
    return all != 0;
  }

  // This rank's rows [*first, *last) of `rows`: contiguous, nearly equal slices in rank order.
  void Slice(long long rows, long long *first, long long *last) const
  {
    *first = rows * rank_ / size_;
    *last  = rows * (rank_ + 1) / size_;
  }

  // `buffer` holds rows x row_bytes bytes of which this rank filled its slice: gives every rank
  // every slice (in place).
  void ShareRows(void *buffer, long long rows, size_t row_bytes) const
  {
    if (!Parallel() || rows == 0) return;
    std::vector<int> counts(static_cast<size_t>(size_)), offsets(static_cast<size_t>(size_));
    for (int r = 0; r < size_; ++r) {
      offsets[r] = static_cast<int>(rows * r / size_);
      counts[r]  = static_cast<int>(rows * (r + 1) / size_) - offsets[r];
    }
    MPI_Datatype row_type;
    MPI_Type_contiguous(static_cast<int>(row_bytes), MPI_BYTE, &row_type);
    MPI_Type_commit(&row_type);
    MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, buffer, counts.data(), offsets.data(), row_type, comm_);
    MPI_Type_free(&row_type);
  }

  // `strings` has all rows, of which this rank filled [first, last): gives every rank every row.
  // False when the strings of all ranks together exceed what one exchange can carry (2 GiB).
  bool ShareStrings(std::vector<std::string> *strings, long long first, long long last) const
  {
    if (!Parallel()) return true;
    std::string packed; // the slice's strings, each followed by '\0'
    for (long long row = first; row < last; ++row) packed += (*strings)[static_cast<size_t>(row)] + '\0';
    long long mine = static_cast<long long>(packed.size()), total = 0;
    MPI_Allreduce(&mine, &total, 1, MPI_LONG_LONG, MPI_SUM, comm_);
    if (total > static_cast<long long>(INT_MAX)) return false;
    std::vector<int> counts(static_cast<size_t>(size_)), offsets(static_cast<size_t>(size_));
    const int        count = static_cast<int>(mine);
    MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
    for (int r = 1; r < size_; ++r) offsets[r] = offsets[r - 1] + counts[r - 1];
    std::vector<char> all(static_cast<size_t>(total) + 1);
    MPI_Allgatherv(packed.data(), count, MPI_CHAR, all.data(), counts.data(), offsets.data(), MPI_CHAR, comm_);
    size_t at = 0;
    for (std::string &string : *strings) {
      const size_t end = std::find(all.begin() + static_cast<std::ptrdiff_t>(at), all.end() - 1, '\0') - all.begin();
      string.assign(all.data() + at, end - at);
      at = end + 1;
    }
    return true;
  }

private:
  MPI_Comm comm_ = MPI_COMM_NULL;
  int      size_ = 1, rank_ = 0;
};

// The open mesh file; every message starts with the file as written in the input.
class MeshReader {
public:
  MeshReader(const std::filesystem::path &path, const std::string &label, const SourceMark &mark, MPI_Comm comm) : label_(label), mark_(mark), group_(comm)
  {
    std::error_code error;
    std::string     problem;
    if (!std::filesystem::is_regular_file(path, error)) problem = "cannot open mesh file " + Quote(label_) + " (looked for " + Quote(path.string()) + ")";
    else if (H5Fis_hdf5(path.c_str()) <= 0) problem = "mesh file " + Quote(label_) + " is not an HDF5 file";
    else if ((file_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT)) < 0)
      problem = "cannot open mesh file " + Quote(label_) + " as HDF5 (read-only): " + Hdf5StackReason();
    else if (hsize_t size = 0; H5Fget_filesize(file_, &size) >= 0) file_size_ = size;
    if (!group_.AllOk(problem.empty())) FailAt(mark_, problem.empty() ? "mesh file " + Quote(label_) + " cannot be opened on another rank" : problem);
  }
  ~MeshReader()
  {
    if (file_ >= 0) H5Fclose(file_);
  }
  MeshReader(const MeshReader &)            = delete;
  MeshReader &operator=(const MeshReader &) = delete;

  [[noreturn]] void Fail(const std::string &dataset, const std::string &message) const { FailAt(mark_, label_ + ": " + dataset + ": " + message); }

  // Whether every component of the absolute `path` exists (H5Lexists needs the parents).
  bool Exists(const std::string &path) const
  {
    for (size_t slash = path.find('/', 1);; slash = path.find('/', slash + 1)) {
      const std::string prefix = path.substr(0, slash);
      if (H5Lexists(file_, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
      if (slash == std::string::npos) return true;
    }
  }

  // Numbers (integer or floating-point in the file) as double, row-major.
  std::vector<double> Reals(const std::string &path, const Shape &shape, long long *rows) const
  {
    const Dataset       dataset = Open(path, shape, H5T_FLOAT, "numbers", rows);
    std::vector<double> values(Count(*rows, shape));
    Read(dataset, path, H5T_NATIVE_DOUBLE, values.data(), *rows, std::max(shape.columns, 1));
    for (size_t index = 0; index < values.size(); ++index)
      if (!std::isfinite(values[index])) Fail(path + Row(static_cast<long long>(index) / std::max(shape.columns, 1)), "not a finite number");
    return values;
  }

  std::vector<long long> Integers(const std::string &path, const Shape &shape, long long *rows) const
  {
    const Dataset          dataset = Open(path, shape, H5T_INTEGER, "integers", rows);
    std::vector<long long> values(Count(*rows, shape));
    Read(dataset, path, H5T_NATIVE_LLONG, values.data(), *rows, std::max(shape.columns, 1));
    return values;
  }

  // Fixed-length or variable-length strings.
  std::vector<std::string> Strings(const std::string &path, const Shape &shape) const
  {
    long long                rows    = 0;
    const Dataset            dataset = Open(path, shape, H5T_STRING, "strings", &rows);
    std::vector<std::string> strings(static_cast<size_t>(rows));
    if (rows == 0) return strings;
    const Handle file_type(H5Dget_type(dataset.id.Get()), H5Tclose);
    const Handle memory_type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_cset(memory_type.Get(), H5Tget_cset(file_type.Get()));
    if (H5Tis_variable_str(file_type.Get()) > 0) {
      // Variable-length strings arrive as pointers: each rank reads its slice, keeps the text and
      // the slices of text are then exchanged.
      H5Tset_size(memory_type.Get(), H5T_VARIABLE);
      long long first = 0, last = rows;
      group_.Slice(rows, &first, &last);
      std::vector<char *> pointers(static_cast<size_t>(last - first), nullptr);
      const bool          ok = ReadRows(dataset, memory_type.Get(), pointers.data(), first, last, 1);
      if (ok) {
        for (long long row = first; row < last; ++row)
          if (pointers[static_cast<size_t>(row - first)] != nullptr) strings[static_cast<size_t>(row)] = pointers[static_cast<size_t>(row - first)];
        const hsize_t count = static_cast<hsize_t>(last - first);
        const Handle  space(H5Screate_simple(1, &count, nullptr), H5Sclose);
        if (count > 0) {
#if H5_VERSION_GE(1, 12, 0)
          H5Treclaim(memory_type.Get(), space.Get(), H5P_DEFAULT, pointers.data());
#else
          H5Dvlen_reclaim(memory_type.Get(), space.Get(), H5P_DEFAULT, pointers.data());
#endif
        }
      }
      if (!group_.AllOk(ok)) Fail(path, ok ? "cannot be read on another rank" : "cannot read the dataset");
      if (!group_.ShareStrings(&strings, first, last)) Fail(path, "the names are too long to share between the ranks (more than 2 GiB in all)");
    } else {
      const size_t size = H5Tget_size(file_type.Get());
      H5Tset_size(memory_type.Get(), size);
      H5Tset_strpad(memory_type.Get(), H5T_STR_NULLPAD);
      std::vector<char> buffer(size * strings.size(), '\0');
      Read(dataset, path, memory_type.Get(), buffer.data(), rows, 1);
      for (size_t row = 0; row < strings.size(); ++row) {
        const char *start  = buffer.data() + row * size;
        size_t      length = 0;
        while (length < size && start[length] != '\0') ++length;
        strings[row].assign(start, length);
      }
    }
    return strings;
  }

private:
  struct Dataset {
    Handle id;
  };

  static size_t Count(long long rows, const Shape &shape) { return static_cast<size_t>(rows) * std::max(shape.columns, 1); }

  // Opens `path` and checks its kind (`type_class`; H5T_FLOAT also accepts integers) and shape;
  // *rows is the number of rows found.
  Dataset Open(const std::string &path, const Shape &shape, H5T_class_t type_class, const char *kind, long long *rows) const
  {
    if (!Exists(path)) Fail(path, "missing dataset");
    Dataset dataset{Handle(H5Dopen2(file_, path.c_str(), H5P_DEFAULT), H5Dclose)};
    if (!dataset.id.Valid()) Fail(path, "not a dataset");
    const Handle      type(H5Dget_type(dataset.id.Get()), H5Tclose);
    const H5T_class_t found = H5Tget_class(type.Get());
    if (!(found == type_class || (type_class == H5T_FLOAT && found == H5T_INTEGER)))
      Fail(path, std::string("expected ") + kind + ", found " + TypeClassName(found));
    const Handle         space(H5Dget_space(dataset.id.Get()), H5Sclose);
    const int            rank = H5Sget_simple_extent_ndims(space.Get());
    std::vector<hsize_t> dims(static_cast<size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(space.Get(), dims.data(), nullptr);
    const int  expected_rank = shape.columns == 0 ? 1 : 2;
    const bool shape_ok      = rank == expected_rank && (shape.rows < 0 || dims[0] == static_cast<hsize_t>(shape.rows)) &&
                          (expected_rank == 1 || dims[1] == static_cast<hsize_t>(shape.columns));
    if (!shape_ok) Fail(path, "wrong shape " + (rank <= 0 ? std::string("(scalar)") : FormatShape(dims)) + ", expected " + FormatShape(shape));
    if (dims[0] > static_cast<hsize_t>(kMaxRows)) Fail(path, std::to_string(dims[0]) + " rows are too many (at most " + std::to_string(kMaxRows) + ")");
    // Before anything is allocated for the rows: the file must hold them (a header may claim
    // 4e8 rows in a file of 50 KB).
    if (const std::string problem = DatasetStorageProblem(dataset.id.Get(), file_size_); !problem.empty()) Fail(path, problem);
    *rows = static_cast<long long>(dims[0]);
    return dataset;
  }

  // Rows [first, last) of `dataset`, per_row elements of memory_type each, into `buffer`.
  bool ReadRows(const Dataset &dataset, hid_t memory_type, void *buffer, long long first, long long last, int per_row) const
  {
    const Handle  file_space(H5Dget_space(dataset.id.Get()), H5Sclose);
    const int     rank        = H5Sget_simple_extent_ndims(file_space.Get());
    const hsize_t start[2]    = {static_cast<hsize_t>(first), 0};
    const hsize_t count[2]    = {static_cast<hsize_t>(last - first), static_cast<hsize_t>(per_row)};
    const hsize_t memory_size = std::max<hsize_t>(count[0] * (rank == 2 ? count[1] : 1), 1);
    const Handle  memory_space(H5Screate_simple(1, &memory_size, nullptr), H5Sclose);
    if (!file_space.Valid() || !memory_space.Valid()) return false;
    if (last == first) {
      H5Sselect_none(file_space.Get());
      H5Sselect_none(memory_space.Get());
    } else if (H5Sselect_hyperslab(file_space.Get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0) return false;
    char dummy[64];
    return H5Dread(dataset.id.Get(), memory_type, memory_space.Get(), file_space.Get(), H5P_DEFAULT, last > first ? buffer : dummy) >= 0;
  }

  // Every row of `dataset` (rows x per_row elements of memory_type) into `buffer`: each rank reads
  // its slice and the slices are exchanged.
  void Read(const Dataset &dataset, const std::string &path, hid_t memory_type, void *buffer, long long rows, int per_row) const
  {
    if (rows == 0) return;
    const size_t row_bytes = H5Tget_size(memory_type) * static_cast<size_t>(per_row);
    long long    first = 0, last = rows;
    group_.Slice(rows, &first, &last);
    const bool ok = ReadRows(dataset, memory_type, static_cast<char *>(buffer) + static_cast<size_t>(first) * row_bytes, first, last, per_row);
    if (!group_.AllOk(ok)) Fail(path, ok ? "cannot be read on another rank" : "cannot read the dataset");
    group_.ShareRows(buffer, rows, row_bytes);
  }

  std::string        label_;
  SourceMark         mark_;
  ReaderGroup        group_;
  hid_t              file_      = -1;
  unsigned long long file_size_ = 0;
};

std::vector<Vec3> ToVec3(const std::vector<double> &values)
{
  std::vector<Vec3> vectors(values.size() / 3);
  for (size_t row = 0; row < vectors.size(); ++row) vectors[row] = Vec3(values[3 * row], values[3 * row + 1], values[3 * row + 2]);
  return vectors;
}

[[noreturn]] void FailRow(const MeshData &mesh, const std::string &dataset, long long row, const std::string &message)
{
  FailAt(mesh.mark, mesh.label + ": " + dataset + Row(row) + ": " + message);
}

// A mesh node index is valid in [minimum, n).
void CheckNodeIndex(const MeshData &mesh, const std::string &dataset, long long row, long long index, long long minimum)
{
  const long long n = static_cast<long long>(mesh.coordinates.size());
  if (index < minimum || index >= n)
    FailRow(mesh, dataset, row,
            "node index " + std::to_string(index) + " out of range (" + (minimum < 0 ? "-1 = ground, " : "") + "n = " + std::to_string(n) + ")");
}

// Who already uses `name`, for messages.
std::string UserOf(const ReaderContext &context, const std::string &name)
{
  const NamedObject &object = context.names.at(name);
  if (const int row = object.kind == NameKind::Node ? MeshNodeRow(context, object.index) : -1; row >= 0) return "node" + Row(row) + " of /nodes";
  return std::string(object.kind == NameKind::Node   ? "the node"
                     : object.kind == NameKind::Beam ? "the beam"
                                                     : "the set") +
         " at line " + std::to_string(object.line);
}

// Registers a node or beam name from the mesh.
void RegisterMeshName(const MeshData &mesh, const std::string &dataset, long long row, const std::string &name, NameKind kind, int index,
                      ReaderContext &context)
{
  const char *what = kind == NameKind::Node ? "node" : "beam";
  if (name.empty()) FailRow(mesh, dataset, row, std::string("empty ") + what + " name");
  if (name == kAllNodes)
    FailRow(mesh, dataset, row, std::string("a ") + what + " cannot be called " + Quote(kAllNodes) + ": in 'nodes' lists it means every node");
  if (context.names.count(name) > 0)
    FailRow(mesh, dataset, row,
            std::string(what) + " name " + Quote(name) + " is already used by " + UserOf(context, name) + " (nodes, beams and sets share one namespace)");
  context.RegisterName(name, kind, index, mesh.mark);
}

} // namespace

MeshData ReadMeshFile(const YAML::Node &value, const YAML::Mark &key_mark, const ReaderContext &context)
{
  MeshData mesh;
  mesh.label = ReadString(value, "mesh");
  mesh.mark  = context.MarkOf(key_mark);
  std::filesystem::path path(mesh.label);
  if (path.is_relative()) path = std::filesystem::path(context.model.input_file).parent_path() / path;
  mesh.path = path.string();
  const QuietHdf5Errors quiet;
  const MeshReader      file(path, mesh.label, mesh.mark, context.comm);

  long long n      = 0;
  mesh.coordinates = ToVec3(file.Reals("/nodes/coordinates", Shape{-1, 3, "n"}, &n));
  if (n == 0) file.Fail("/nodes/coordinates", "the mesh has no nodes");
  if (file.Exists("/nodes/names")) mesh.node_names = file.Strings("/nodes/names", Shape{n, 0});

  long long m = 0, rows = 0;
  if (file.Exists("/beams")) {
    const std::vector<long long> ends = file.Integers("/beams/nodes", Shape{-1, 2, "m"}, &m);
    mesh.beam_nodes.resize(static_cast<size_t>(m));
    for (size_t row = 0; row < mesh.beam_nodes.size(); ++row) mesh.beam_nodes[row] = {ends[2 * row], ends[2 * row + 1]};
    mesh.beam_section  = file.Integers("/beams/section", Shape{m, 0}, &rows);
    mesh.beam_elements = file.Integers("/beams/elements", Shape{m, 0}, &rows);
    mesh.beam_order    = file.Integers("/beams/order", Shape{m, 0}, &rows);
    if (file.Exists("/beams/orientation")) mesh.beam_orientation = ToVec3(file.Reals("/beams/orientation", Shape{m, 3}, &rows));
    if (file.Exists("/beams/names")) mesh.beam_names = file.Strings("/beams/names", Shape{m, 0});
  }

  long long k = 0;
  if (file.Exists("/joints")) {
    mesh.joint_type   = file.Strings("/joints/type", Shape{-1, 0, "k"});
    k                 = static_cast<long long>(mesh.joint_type.size());
    mesh.joint_master = file.Integers("/joints/master", Shape{k, 0}, &rows);
    mesh.joint_slave  = file.Integers("/joints/slave", Shape{k, 0}, &rows);
    mesh.joint_axis   = ToVec3(file.Reals("/joints/axis", Shape{k, 3}, &rows));
    if (file.Exists("/joints/second_axis")) mesh.joint_second_axis = ToVec3(file.Reals("/joints/second_axis", Shape{k, 3}, &rows));
    mesh.joint_parameter = file.Reals("/joints/parameter", Shape{k, 0}, &rows);
    if (file.Exists("/joints/names")) mesh.joint_names = file.Strings("/joints/names", Shape{k, 0});
  }
  return mesh;
}

void AddMeshNodes(const MeshData &mesh, ReaderContext &context)
{
  Model &model            = context.model;
  context.mesh_label      = mesh.label;
  context.mesh_first_node = static_cast<int>(model.nodes.size());
  context.mesh_node_count = static_cast<int>(mesh.coordinates.size());
  model.nodes.reserve(model.nodes.size() + mesh.coordinates.size());
  context.names.reserve(context.names.size() + mesh.coordinates.size());
  for (size_t row = 0; row < mesh.coordinates.size(); ++row) {
    const int         index = static_cast<int>(model.nodes.size());
    const std::string name  = mesh.node_names.empty() ? "n" + std::to_string(row) : mesh.node_names[row];
    if (const std::string problem = PositionProblem(mesh.coordinates[row]); !problem.empty())
      FailRow(mesh, "/nodes/coordinates", static_cast<long long>(row), problem);
    RegisterMeshName(mesh, "/nodes/names", static_cast<long long>(row), name, NameKind::Node, index, context);
    model.nodes.push_back(Node{name, mesh.coordinates[row], mesh.mark});
  }
}

void AddMeshBeams(const MeshData &mesh, ReaderContext &context)
{
  Model          &model    = context.model;
  const long long sections = static_cast<long long>(model.sections.size());
  // Every beam adds elements * order - 1 nodes; the total must stay a valid int index.
  long long generated = 0;
  for (size_t index = 0; index < mesh.beam_nodes.size(); ++index) {
    const long long row      = static_cast<long long>(index);
    const long long elements = mesh.beam_elements[index], order = mesh.beam_order[index];
    if (elements < 1 || elements > kMaxElementsPerBeam)
      FailRow(mesh, "/beams/elements", row,
              "the number of elements must be between 1 and " + std::to_string(kMaxElementsPerBeam) + ", got " + std::to_string(elements));
    if (order != 1 && order != 2) FailRow(mesh, "/beams/order", row, "the order must be 1 or 2, got " + std::to_string(order));
    generated += elements * order - 1;
  }
  if (static_cast<long long>(model.nodes.size()) + generated > kMaxRows)
    FailAt(mesh.mark, mesh.label + ": /beams/elements: the beams would generate " + std::to_string(generated) + " nodes, too many (at most " +
                          std::to_string(kMaxRows) + " in all)");
  // A small file may describe a model far larger than memory: refused here, with its location,
  // rather than by an allocation failure later.
  if (const long long memory = PhysicalMemoryBytes(); memory > 0 && generated > memory / kMinBytesPerGeneratedNode)
    FailAt(mesh.mark, mesh.label + ": /beams/elements: the beams would generate " + std::to_string(generated) +
                          " nodes and as many elements, which need more than the " + std::to_string(memory >> 20) + " MiB of memory this machine has");
  model.nodes.reserve(model.nodes.size() + static_cast<size_t>(generated));
  context.names.reserve(context.names.size() + static_cast<size_t>(generated) + mesh.beam_nodes.size());

  const bool named = !mesh.beam_names.empty();
  for (size_t index = 0; index < mesh.beam_nodes.size(); ++index) {
    const long long row = static_cast<long long>(index);
    for (const long long node : mesh.beam_nodes[index]) CheckNodeIndex(mesh, "/beams/nodes", row, node, 0);
    const int from = context.mesh_first_node + static_cast<int>(mesh.beam_nodes[index][0]);
    const int to   = context.mesh_first_node + static_cast<int>(mesh.beam_nodes[index][1]);
    if (from == to) FailRow(mesh, "/beams/nodes", row, "both ends are node " + Quote(model.nodes[from].name) + "; a beam needs two nodes");
    const Vec3 start = model.nodes[from].position, end = model.nodes[to].position;
    if (BeamHasZeroLength(start, end))
      FailRow(mesh, "/beams/nodes", row,
              "zero length: nodes " + Quote(model.nodes[from].name) + " and " + Quote(model.nodes[to].name) + " are at the same position");
    const long long section = mesh.beam_section[index];
    if (section < 0 || section >= sections)
      FailRow(mesh, "/beams/section", row, "section index " + std::to_string(section) + " out of range ('sections' lists " + std::to_string(sections) + ")");
    Vec3 orientation = DefaultBeamOrientation(start, end);
    if (!mesh.beam_orientation.empty() && mesh.beam_orientation[index] != Vec3::Zero()) {
      orientation = mesh.beam_orientation[index];
      if (OrientationAlongAxis(orientation, start, end))
        FailRow(mesh, "/beams/orientation", row, "orientation " + FormatVec3(orientation) + " is parallel to the beam's axis; it must point across the beam");
    }
    Beam beam;
    beam.name    = named ? mesh.beam_names[index] : "b" + std::to_string(index);
    beam.section = static_cast<int>(section);
    beam.mark    = mesh.mark;
    RegisterMeshName(mesh, named ? "/beams/names" : "/beams/nodes", row, beam.name, NameKind::Beam, static_cast<int>(model.beams.size()), context);
    BeamLayout layout;
    layout.elements = static_cast<int>(mesh.beam_elements[index]);
    layout.order    = static_cast<int>(mesh.beam_order[index]);
    try {
      AppendStraightBeam(std::move(beam), from, to, orientation, layout, context);
    } catch (InputFailure &failure) { // e.g. a generated node name that is already taken
      failure.message = mesh.label + ": /beams/nodes" + Row(row) + ": " + failure.message;
      throw;
    }
  }
}

void AddMeshJoints(const MeshData &mesh, ReaderContext &context)
{
  const Model &model = context.model;
  for (size_t index = 0; index < mesh.joint_type.size(); ++index) {
    const long long row = static_cast<long long>(index);
    Joint           joint;
    joint.name = mesh.joint_names.empty() ? "j" + std::to_string(index) : mesh.joint_names[index];
    joint.mark = mesh.mark;
    if (joint.name.empty()) FailRow(mesh, "/joints/names", row, "empty joint name");
    if (const std::string problem = JointNameProblem(joint.name); !problem.empty()) FailRow(mesh, "/joints/names", row, problem);
    if (const auto other = context.joint_names.find(joint.name); other != context.joint_names.end())
      FailRow(mesh, mesh.joint_names.empty() ? "/joints/type" : "/joints/names", row,
              "duplicate joint name " + Quote(joint.name) + " (first defined at line " + std::to_string(model.joints[other->second].mark.line) + ")");
    const std::string   &type = mesh.joint_type[index];
    const JointKindInfo *info = JointKindFind(type);
    if (!info) {
      std::string names;
      int         count;
      for (const JointKindInfo *k = JointKinds(&count), *end = k + count; k != end; ++k)
        if (k->parameter != JointParameter::Release && k->parameter != JointParameter::Profile) names += (names.empty() ? "" : ", ") + std::string(k->name);
      FailRow(mesh, "/joints/type", row, "unknown joint type " + Quote(type) + "; expected one of " + names);
    }
    if (info->parameter == JointParameter::Release || info->parameter == JointParameter::Profile)
      FailRow(mesh, "/joints/type", row,
              "a " + type + " joint needs '" + (info->parameter == JointParameter::Release ? "release" : "profile") +
                  "', which a mesh file cannot give; list it under 'joints' in the YAML file");
    const double parameter = mesh.joint_parameter[index];
    if (const std::string problem = JointParameterProblem(info->kind, parameter); !problem.empty())
      FailRow(mesh, "/joints/parameter", row,
              std::string(info->parameter == JointParameter::Pitch ? "the pitch" : "the radius") + " of a " + type + " joint " + problem + ", got " +
                  FormatNumber(parameter));
    ApplyJointKind(*info, parameter, joint);
    CheckNodeIndex(mesh, "/joints/master", row, mesh.joint_master[index], -1);
    CheckNodeIndex(mesh, "/joints/slave", row, mesh.joint_slave[index], 0);
    joint.master = mesh.joint_master[index] < 0 ? -1 : context.mesh_first_node + static_cast<int>(mesh.joint_master[index]);
    joint.slave  = context.mesh_first_node + static_cast<int>(mesh.joint_slave[index]);
    if (joint.master == joint.slave)
      FailRow(mesh, "/joints/slave", row, "the slave is the master, node " + Quote(model.nodes[joint.slave].name) + "; a joint needs two different nodes");
    const Vec3 &axis = mesh.joint_axis[index];
    if (const std::string problem = JointAxisProblem(axis); !problem.empty()) FailRow(mesh, "/joints/axis", row, "the axis " + problem);
    const Vec3 *second_axis = nullptr;
    if (!mesh.joint_second_axis.empty() && mesh.joint_second_axis[index] != Vec3::Zero()) {
      second_axis = &mesh.joint_second_axis[index];
      if (const std::string problem = JointSecondAxisProblem(axis, *second_axis); !problem.empty())
        FailRow(mesh, "/joints/second_axis", row, "the second axis " + FormatVec3(*second_axis) + " " + problem);
    }
    joint.axes    = JointAxesFrom(axis, second_axis);
    bool at_slave = false;
    if (const std::string problem = JointTreeProblem(joint, context, &at_slave); !problem.empty())
      FailRow(mesh, at_slave ? "/joints/slave" : "/joints/master", row, problem);
    AppendJoint(std::move(joint), context);
  }
}

int MeshNodeRow(const ReaderContext &context, int node)
{
  if (node < context.mesh_first_node || node >= context.mesh_first_node + context.mesh_node_count) return -1;
  return node - context.mesh_first_node;
}

std::string MeshNodePrefix(const ReaderContext &context, int node)
{
  const int row = MeshNodeRow(context, node);
  return row < 0 ? "" : context.mesh_label + ": /nodes" + Row(row) + ": ";
}

} // namespace msflex::input_detail
