#include "output/output_file.hpp"

#include "core/hdf5_util.hpp"
#include "core/mpi_util.hpp"

#include <hdf5.h>

#ifndef H5_HAVE_PARALLEL
#error "msflex writes its results through MPI-IO: it needs the MPI build of HDF5 (Debian: libhdf5-openmpi-dev)"
#endif

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <sstream>

// Checks the result of an HDF5 call (negative means failure) inside an OutputFile::Impl member,
// whose `path` names the file in the one-line message, with HDF5's reason (Hdf5CallProblem).
#define PetscCallHDF5(call) PetscCheck((call) >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s", Hdf5CallProblem(path, #call).c_str())

namespace msflex {

namespace {

// Rows per chunk of the extensible history and probe datasets: appending a row touches one chunk.
constexpr hsize_t kHistoryChunkRows = 256;

// Broadcasts a list of strings from rank 0.
PetscErrorCode BcastStrings(MPI_Comm comm, std::vector<std::string> *strings)
{
  PetscMPIInt rank;
  std::string packed; // every string followed by '\0'
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0)
    for (const std::string &s : *strings) packed += s + '\0';
  PetscCallMPI(BroadcastString(comm, &packed));
  if (rank != 0) {
    strings->clear();
    for (size_t start = 0; start < packed.size();) {
      const size_t end = packed.find('\0', start);
      strings->push_back(packed.substr(start, end - start));
      start = end + 1;
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Escapes the characters that may not appear literally in XML text or attribute values.
std::string XmlEscape(const std::string &text)
{
  std::string escaped;
  for (const char c : text) {
    switch (c) {
    case '&':
      escaped += "&amp;";
      break;
    case '<':
      escaped += "&lt;";
      break;
    case '>':
      escaped += "&gt;";
      break;
    case '"':
      escaped += "&quot;";
      break;
    default:
      escaped += c;
    }
  }
  return escaped;
}

// The shortest decimal text that reads back as exactly `value` (0.1, not 0.10000000000000001).
std::string ShortestDecimal(double value)
{
  char text[32];
  return std::string(text, std::to_chars(text, text + sizeof text, value).ptr);
}

// The probe names of a history row, in order.
std::vector<std::string> ProbeNames(const std::vector<ProbeSample> &probes)
{
  std::vector<std::string> names;
  for (const ProbeSample &probe : probes) names.push_back(probe.name);
  return names;
}

std::string FrameGroupName(int step)
{
  char name[32];
  std::snprintf(name, sizeof name, "/frames/%06d", step);
  return name;
}

} // namespace

// One rank's side of the output file: the open HDF5 file and what the XDMF sidecar must list.
// Parallel HDF5: rank 0 creates the file and writes /input and /mesh (Create, then closes it);
// every rank then holds the file open through MPI-IO (OpenParallel) and the frame, history and
// close members run on every rank, with identical metadata calls. Serial HDF5: only rank 0 holds
// a file; on the other ranks an Impl exists (so every rank agrees the file is open) but is idle.
// The members return PETSc error codes raised on PETSC_COMM_SELF; RunOnRoot (rank-0 work) and
// RunCollective (work on every rank) make them collective.
struct OutputFile::Impl {
  struct FrameEntry {
    int    step;
    double time;
    bool   has_velocities;
    bool   has_section_triads = false; // segment_e1, segment_e2, segment_e3 (distributed frames)
  };

  explicit Impl(const std::string &h5_path) : path(h5_path), xdmf_path(SidecarPath(h5_path)), h5_file_name(std::filesystem::path(h5_path).filename().string())
  {
  }

  PetscErrorCode Create(bool overwrite, const std::string &input_file, const std::string &input_text, const OutputMesh &mesh, const FileMarker &marker);
  PetscErrorCode WriteMesh(const OutputMesh &mesh);
  PetscErrorCode CheckHistory(const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<ProbeSample> &probes);
  PetscErrorCode WriteHistory(const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<std::string> &sample_names,
                              const std::vector<ProbeSample> &probes);
  PetscErrorCode WriteXdmf() const;
  // A frame's step must be non-negative and not written before.
  PetscErrorCode CheckNewStep(int step) const;
  // Parallel build: opens the file created by rank 0 on every rank through MPI-IO.
  PetscErrorCode OpenParallel();
  // Checks this rank's part of a frame (`node_rows`, `element_rows`: the rows it writes).
  PetscErrorCode CheckFrame(const OutputFrame &frame, int step, bool has_velocities, const std::vector<int> &node_rows, const std::vector<int> &element_rows,
                            hsize_t total_node_rows, hsize_t total_element_rows) const;
  // Writes a frame collectively, each rank its rows.
  PetscErrorCode WriteFrameRows(const OutputFrame &frame, int step, double time, bool has_velocities, const std::vector<int> &node_rows,
                                const std::vector<int> &element_rows);
  // Creates the float64 dataset `name` (n_rows x columns) collectively; each rank writes `data`
  // (rows.size() x columns) to its `rows`.
  PetscErrorCode WriteRows(hid_t parent, const char *name, hsize_t n_rows, hsize_t columns, const std::vector<int> &rows, const std::vector<double> &data);
  // Rank 0: fills segment_first from /mesh/segment_element.
  PetscErrorCode LoadSegmentTable();
  // Rank 0: opens the existing file, checks that it is the result file of run `run_id` holding
  // the frame of `last_step` and at least `history_rows` rows of every series, and only then
  // drops the frames after `last_step` and the rows beyond `history_rows`, rewrites the sidecar
  // and closes the file again (OutputFile::Reopen).
  PetscErrorCode Resume(int last_step, long long history_rows, const std::string &run_id);
  PetscErrorCode LinkNames(hid_t group, std::vector<std::string> *names) const;
  PetscErrorCode TruncateRows(hid_t parent, const std::string &name, hsize_t rows) const;
  PetscErrorCode Close();

  // Creates dataset `name` under `parent` with shape `dims` ({} = scalar) and writes `data`, laid
  // out in `memory_type`, stored as `file_type`.
  PetscErrorCode WriteDataset(hid_t parent, const char *name, hid_t file_type, hid_t memory_type, const std::vector<hsize_t> &dims, const void *data);
  PetscErrorCode WriteDoubles(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<double> &data);
  PetscErrorCode WriteInts(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<int> &data);
  PetscErrorCode WriteStrings(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<std::string> &strings);
  // Attaches scalar attribute `name` to the object at `object` (relative to `location`).
  PetscErrorCode WriteAttribute(hid_t location, const char *object, const char *name, hid_t file_type, hid_t memory_type, const void *value);
  PetscErrorCode CreateStringType(H5Id *type);
  // Writes `entry` (shape `entry_dims`, {} for a scalar) as row `rows_written` of the extensible
  // float64 dataset `name` under `parent`, creating the dataset for the first row.
  PetscErrorCode AppendRow(hid_t parent, const char *name, const std::vector<hsize_t> &entry_dims, const double *entry);

  std::string              path;         // the .h5 file, as given to Open
  std::string              xdmf_path;    // the sidecar: path with the extension replaced by .xmf
  std::string              h5_file_name; // base name of path, by which the sidecar refers to it
  H5Id                     file;
  hsize_t                  n_nodes = 0, n_elements = 0, n_segments = 0;
  std::vector<int>         segment_element; // rank 0, during Create: element of each 2-node visualisation segment
  std::vector<FrameEntry>  frames;          // in the order written
  hsize_t                  rows_written = 0;
  std::vector<std::string> history_names, probe_names; // fixed by the first history row
  MPI_Comm                 comm = MPI_COMM_NULL;
  PetscMPIInt              rank = 0;
  // Rank 0, only once a frame that is not distributed arrives (read back from /mesh):
  // n_elements + 1 entries, the segments of element e are [first[e], first[e + 1]).
  std::vector<int> segment_first;
};

PetscErrorCode OutputFile::Impl::CreateStringType(H5Id *type)
{
  PetscFunctionBeginUser;
  // Variable-length UTF-8: what h5py and the HDF5 tools read back as text.
  PetscCallHDF5(*type = H5Tcopy(H5T_C_S1));
  PetscCallHDF5(H5Tset_size(*type, H5T_VARIABLE));
  PetscCallHDF5(H5Tset_cset(*type, H5T_CSET_UTF8));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteDataset(hid_t parent, const char *name, hid_t file_type, hid_t memory_type, const std::vector<hsize_t> &dims,
                                              const void *data)
{
  H5Id    space, dataset;
  hsize_t n_values = 1;

  PetscFunctionBeginUser;
  for (const hsize_t d : dims) n_values *= d;
  PetscCallHDF5(space = dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple((int)dims.size(), dims.data(), nullptr));
  PetscCallHDF5(dataset = H5Dcreate2(parent, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  // An empty vector may have no buffer, which H5Dwrite rejects even for nothing to write.
  if (n_values > 0) PetscCallHDF5(H5Dwrite(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteDoubles(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<double> &data)
{
  PetscFunctionBeginUser;
  PetscCall(WriteDataset(parent, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, dims, data.data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteInts(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<int> &data)
{
  PetscFunctionBeginUser;
  PetscCall(WriteDataset(parent, name, H5T_STD_I32LE, H5T_NATIVE_INT, dims, data.data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteStrings(hid_t parent, const char *name, const std::vector<hsize_t> &dims, const std::vector<std::string> &strings)
{
  H5Id                      type;
  std::vector<const char *> pointers;

  PetscFunctionBeginUser;
  for (const std::string &s : strings) pointers.push_back(s.c_str());
  PetscCall(CreateStringType(&type));
  PetscCall(WriteDataset(parent, name, type, type, dims, pointers.data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteAttribute(hid_t location, const char *object, const char *name, hid_t file_type, hid_t memory_type, const void *value)
{
  H5Id space, attribute;

  PetscFunctionBeginUser;
  PetscCallHDF5(space = H5Screate(H5S_SCALAR));
  PetscCallHDF5(attribute = H5Acreate_by_name(location, object, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  PetscCallHDF5(H5Awrite(attribute, memory_type, value));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::AppendRow(hid_t parent, const char *name, const std::vector<hsize_t> &entry_dims, const double *entry)
{
  // Dataset shape (rows, entry_dims...); the new row is one hyperslab of shape (1, entry_dims...).
  std::vector<hsize_t> dims{rows_written + 1}, row_start{rows_written}, row_count{1};
  H5Id                 dataset, file_space, memory_space;

  PetscFunctionBeginUser;
  dims.insert(dims.end(), entry_dims.begin(), entry_dims.end());
  row_start.resize(dims.size(), 0);
  row_count.insert(row_count.end(), entry_dims.begin(), entry_dims.end());
  const int rank = (int)dims.size();
  if (rows_written == 0) {
    std::vector<hsize_t> max_dims = dims, chunk = dims;
    H5Id                 properties;
    max_dims[0] = H5S_UNLIMITED;
    chunk[0]    = kHistoryChunkRows;
    PetscCallHDF5(file_space = H5Screate_simple(rank, dims.data(), max_dims.data()));
    PetscCallHDF5(properties = H5Pcreate(H5P_DATASET_CREATE));
    PetscCallHDF5(H5Pset_chunk(properties, rank, chunk.data()));
    PetscCallHDF5(dataset = H5Dcreate2(parent, name, H5T_IEEE_F64LE, file_space, H5P_DEFAULT, properties, H5P_DEFAULT));
  } else {
    PetscCallHDF5(dataset = H5Dopen2(parent, name, H5P_DEFAULT));
    PetscCallHDF5(H5Dset_extent(dataset, dims.data()));
    PetscCallHDF5(file_space = H5Dget_space(dataset));
  }
  PetscCallHDF5(memory_space = H5Screate_simple(rank, row_count.data(), nullptr));
  if (this->rank != 0) {
    // Rank 0 writes the row; the others take part in the collective write with nothing.
    PetscCallHDF5(H5Sselect_none(file_space));
    PetscCallHDF5(H5Sselect_none(memory_space));
  } else PetscCallHDF5(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, row_start.data(), nullptr, row_count.data(), nullptr));
  H5Id transfer;
  PetscCall(CreateCollectiveTransfer(path, &transfer));
  PetscCallHDF5(H5Dwrite(dataset, H5T_NATIVE_DOUBLE, memory_space, file_space, transfer, entry));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::Create(bool overwrite, const std::string &input_file, const std::string &input_text, const OutputMesh &mesh,
                                        const FileMarker &marker)
{
  H5Id          group, string_type;
  const char   *input_file_c = input_file.c_str();
  TemporaryFile temporary; // removed by its destructor unless committed
  ExistingFile  existing;

  PetscFunctionBeginUser;
  // The run's policy (CheckRunFiles) decided already; this keeps the rule for any other caller:
  // only an msflex result file is ever replaced, and only when asked to.
  const std::string problem = ClassifyExistingFile(path, &existing);
  PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s", problem.c_str());
  PetscCheck(existing.kind == ExistingKind::Missing || overwrite, PETSC_COMM_SELF, PETSC_ERR_USER_INPUT,
             "output file '%s' exists; pass -output_overwrite to replace it", path.c_str());
  PetscCheck(existing.kind == ExistingKind::Missing || existing.kind == ExistingKind::MsflexResult, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE,
             "refusing to replace the output file '%s': it is %s; -output_overwrite replaces only msflex result files", path.c_str(),
             ExistingKindName(existing.kind));
  // Written under a new name beside the target and renamed over it at the end: an old result
  // stays intact until the new file is complete.
  PetscCall(CreateHdf5Temporary(path, &temporary, &file));
  PetscCall(WriteFileMarkerChecked(path, file, marker));
  PetscCall(WriteStrings(file, "input", {}, {input_text}));
  PetscCall(CreateStringType(&string_type));
  PetscCall(WriteAttribute(file, "input", "file", string_type, string_type, &input_file_c));
  PetscCall(WriteMesh(mesh));
  for (const char *name : {"/frames", "/history", "/probes"}) PetscCallHDF5(group = H5Gcreate2(file, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  PetscCallHDF5(H5Fflush(file, H5F_SCOPE_LOCAL));
  // The sidecar is written now, empty, so that it never describes an earlier run's frames.
  PetscCall(WriteXdmf());
  // Rank 0 wrote the replicated part; every rank reopens the file for the collective writes.
  std::vector<int>().swap(segment_element);
  PetscCallHDF5(H5Fclose(file.Release()));
  PetscCall(CommitHdf5Temporary(&temporary));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteMesh(const OutputMesh &mesh)
{
  H5Id             group;
  std::vector<int> segments;

  PetscFunctionBeginUser;
  n_nodes               = mesh.node_coordinates.size() / 3;
  n_elements            = mesh.element_order.size();
  const hsize_t n_beams = mesh.beam_names.size();
  PetscCheck(mesh.node_coordinates.size() == 3 * n_nodes && mesh.node_names.size() == n_nodes, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "output file '%s': %zu node coordinates and %zu node names do not describe n x 3 and n", path.c_str(), mesh.node_coordinates.size(),
             mesh.node_names.size());
  PetscCheck(mesh.element_nodes.size() == 3 * n_elements && mesh.element_beam.size() == n_elements, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "output file '%s': element arrays of sizes %zu (nodes), %zu (order), %zu (beam) do not describe n x 3, n, n", path.c_str(),
             mesh.element_nodes.size(), mesh.element_order.size(), mesh.element_beam.size());
  for (hsize_t e = 0; e < n_elements; ++e) {
    const int  order = mesh.element_order[e];
    const int *nodes = &mesh.element_nodes[3 * e];
    PetscCheck(order == 1 || order == 2, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "output file '%s': element %llu has order %d", path.c_str(),
               (unsigned long long)e, order);
    PetscCheck(mesh.element_beam[e] >= 0 && (hsize_t)mesh.element_beam[e] < n_beams, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE,
               "output file '%s': element %llu refers to beam %d of %llu", path.c_str(), (unsigned long long)e, mesh.element_beam[e],
               (unsigned long long)n_beams);
    PetscCheck(order == 2 || nodes[2] == -1, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "output file '%s': 2-node element %llu is not padded with -1", path.c_str(),
               (unsigned long long)e);
    for (int a = 0; a <= order; ++a)
      PetscCheck(nodes[a] >= 0 && (hsize_t)nodes[a] < n_nodes, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE,
                 "output file '%s': element %llu refers to node %d of %llu", path.c_str(), (unsigned long long)e, nodes[a], (unsigned long long)n_nodes);
    // Consecutive element nodes form the segments: (n0, n1) and, for order 2, (n1, n2).
    for (int a = 0; a < order; ++a) {
      segments.push_back(nodes[a]);
      segments.push_back(nodes[a + 1]);
      segment_element.push_back((int)e);
    }
  }
  n_segments = segment_element.size();

  PetscCallHDF5(group = H5Gcreate2(file, "/mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  PetscCall(WriteDoubles(group, "node_coordinates", {n_nodes, 3}, mesh.node_coordinates));
  PetscCall(WriteStrings(group, "node_names", {n_nodes}, mesh.node_names));
  PetscCall(WriteInts(group, "element_nodes", {n_elements, 3}, mesh.element_nodes));
  PetscCall(WriteInts(group, "element_order", {n_elements}, mesh.element_order));
  PetscCall(WriteInts(group, "element_beam", {n_elements}, mesh.element_beam));
  PetscCall(WriteStrings(group, "beam_names", {n_beams}, mesh.beam_names));
  PetscCall(WriteInts(group, "segments", {segment_element.size(), 2}, segments));
  PetscCall(WriteInts(group, "segment_element", {segment_element.size()}, segment_element));
  if (!mesh.node_rank.empty()) {
    PetscCheck(mesh.node_rank.size() == n_nodes, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "output file '%s': the partition does not match %llu nodes", path.c_str(),
               (unsigned long long)n_nodes);
    PetscCall(WriteInts(group, "node_rank", {n_nodes}, mesh.node_rank));
  }
  const hsize_t n_joints = mesh.joint_names.size();
  if (n_joints > 0) {
    PetscCheck(mesh.joint_types.size() == n_joints && mesh.joint_master.size() == n_joints && mesh.joint_slave.size() == n_joints &&
                   mesh.joint_axes.size() == 9 * n_joints && mesh.joint_offset.size() == 3 * n_joints,
               PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "output file '%s': joint arrays do not match %llu joints", path.c_str(), (unsigned long long)n_joints);
    PetscCall(WriteStrings(group, "joint_names", {n_joints}, mesh.joint_names));
    PetscCall(WriteStrings(group, "joint_types", {n_joints}, mesh.joint_types));
    PetscCall(WriteInts(group, "joint_master", {n_joints}, mesh.joint_master));
    PetscCall(WriteInts(group, "joint_slave", {n_joints}, mesh.joint_slave));
    PetscCall(WriteDoubles(group, "joint_axes", {n_joints, 9}, mesh.joint_axes));
    PetscCall(WriteDoubles(group, "joint_offset", {n_joints, 3}, mesh.joint_offset));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::CheckNewStep(int step) const
{
  PetscFunctionBeginUser;
  PetscCheck(step >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "output file '%s': negative step %d", path.c_str(), step);
  for (const FrameEntry &written : frames)
    PetscCheck(written.step != step, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "output file '%s': frame of step %d already written", path.c_str(), step);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::CheckHistory(const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<ProbeSample> &probes)
{
  const std::vector<std::string> sample_names = ProbeNames(probes);

  PetscFunctionBeginUser;
  PetscCheck(names.size() == values.size(), PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "output file '%s': %zu history names but %zu values", path.c_str(),
             names.size(), values.size());
  PetscCheck(!names.empty() && names.front() == "time", PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "output file '%s': the first history series must be 'time'",
             path.c_str());
  if (rows_written == 0 || history_names.empty()) { // the first row, or the first after Reopen
    history_names = names;
    probe_names   = sample_names;
  }
  PetscCheck(names == history_names && sample_names == probe_names, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG,
             "output file '%s': history and probe names must be the same in every row", path.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Rank 0's names and values are written; on other ranks `values` and the probe values
// are not read, but the names must be rank 0's.
PetscErrorCode OutputFile::Impl::WriteHistory(const std::vector<std::string> &names, const std::vector<double> &values,
                                              const std::vector<std::string> &sample_names, const std::vector<ProbeSample> &probes)
{
  H5Id history, probes_group;

  PetscFunctionBeginUser;
  PetscCallHDF5(history = H5Gopen2(file, "/history", H5P_DEFAULT));
  for (size_t i = 0; i < names.size(); ++i) PetscCall(AppendRow(history, names[i].c_str(), {}, &values[i]));
  PetscCallHDF5(probes_group = H5Gopen2(file, "/probes", H5P_DEFAULT));
  for (size_t p = 0; p < sample_names.size(); ++p) {
    const ProbeSample &probe = probes[p];
    H5Id               group;
    if (rows_written == 0) PetscCallHDF5(group = H5Gcreate2(probes_group, sample_names[p].c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    else PetscCallHDF5(group = H5Gopen2(probes_group, sample_names[p].c_str(), H5P_DEFAULT));
    PetscCall(AppendRow(group, "position", {3}, probe.position));
    PetscCall(AppendRow(group, "displacement", {3}, probe.displacement));
    PetscCall(AppendRow(group, "rotation", {4}, probe.rotation));
    PetscCall(AppendRow(group, "rotation_angle", {}, &probe.rotation_angle));
  }
  PetscCallHDF5(H5Fflush(file, H5F_SCOPE_LOCAL));
  ++rows_written;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteXdmf() const
{
  const std::string  h5_name = XmlEscape(h5_file_name);
  std::ostringstream xml;

  // One <DataItem> referring to a dataset of the .h5 file by its relative name.
  const auto data_item = [&](const char *number_type, int precision, hsize_t rows, int columns, const std::string &dataset) {
    std::ostringstream item;
    item << "<DataItem Format=\"HDF\" NumberType=\"" << number_type << "\" Precision=\"" << precision << "\" Dimensions=\"" << rows << " " << columns << "\">"
         << h5_name << ":" << dataset << "</DataItem>";
    return item.str();
  };
  const auto attribute = [&](const char *name, const char *type, const char *center, const std::string &item) {
    xml << "        <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\"" << center << "\">\n          " << item
        << "\n        </Attribute>\n";
  };

  PetscFunctionBeginUser;
  xml << "<?xml version=\"1.0\" ?>\n"
      << "<Xdmf Version=\"3.0\">\n"
      << "  <Domain>\n"
      << "    " << kSidecarMarker << "\n"
      << "    <Grid Name=\"msflex\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const FrameEntry &frame : frames) {
    const std::string group = FrameGroupName(frame.step);
    xml << "      <Grid Name=\"step " << frame.step << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << ShortestDecimal(frame.time) << "\"/>\n"
        << "        <Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"" << n_segments << "\">\n"
        << "          " << data_item("Int", 4, n_segments, 2, "/mesh/segments") << "\n"
        << "        </Topology>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n"
        << "          " << data_item("Float", 8, n_nodes, 3, group + "/position") << "\n"
        << "        </Geometry>\n";
    attribute("displacement", "Vector", "Node", data_item("Float", 8, n_nodes, 3, group + "/displacement"));
    attribute("rotation", "Matrix", "Node", data_item("Float", 8, n_nodes, 4, group + "/rotation"));
    if (frame.has_velocities) {
      attribute("velocity", "Vector", "Node", data_item("Float", 8, n_nodes, 3, group + "/velocity"));
      attribute("angular_velocity", "Vector", "Node", data_item("Float", 8, n_nodes, 3, group + "/angular_velocity"));
    }
    attribute("force", "Vector", "Cell", data_item("Float", 8, n_segments, 3, group + "/segment_force"));
    attribute("moment", "Vector", "Cell", data_item("Float", 8, n_segments, 3, group + "/segment_moment"));
    if (frame.has_section_triads)
      for (const char *axis : {"e1", "e2", "e3"})
        attribute((std::string("section_") + axis).c_str(), "Vector", "Cell", data_item("Float", 8, n_segments, 3, group + "/segment_" + axis));
    xml << "      </Grid>\n";
  }
  xml << "    </Grid>\n"
      << "  </Domain>\n"
      << "</Xdmf>\n";

  // Written under a new name beside it (O_EXCL, never through a link) and renamed over the old
  // sidecar, so a reader never sees a half-written one.
  PetscCall(WriteFileAtomicallyChecked(xdmf_path, xml.str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::OpenParallel()
{
  PetscFunctionBeginUser;
  PetscCall(OpenFileCollective(comm, path, &file));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteRows(hid_t parent, const char *name, hsize_t n_rows, hsize_t columns, const std::vector<int> &rows,
                                           const std::vector<double> &data)
{
  PetscFunctionBeginUser;
  PetscCall(WriteRowsCollective(path, parent, name, n_rows, columns, rows, data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::CheckFrame(const OutputFrame &frame, int step, bool has_velocities, const std::vector<int> &node_rows,
                                            const std::vector<int> &element_rows, hsize_t total_node_rows, hsize_t total_element_rows) const
{
  const size_t nr = node_rows.size(), er = element_rows.size();

  PetscFunctionBeginUser;
  PetscCall(CheckNewStep(step));
  PetscCheck(total_node_rows == n_nodes && total_element_rows == n_elements, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "output file '%s': step %d: the ranks hold %llu node and %llu element rows, not %llu and %llu", path.c_str(), step,
             (unsigned long long)total_node_rows, (unsigned long long)total_element_rows, (unsigned long long)n_nodes, (unsigned long long)n_elements);
  if (nr == 0 && er == 0) PetscFunctionReturn(PETSC_SUCCESS); // nothing of this rank's arrays is read
  PetscCheck(frame.position.size() == 3 * nr && frame.displacement.size() == 3 * nr && frame.rotation.size() == 4 * nr, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "output file '%s': step %d: nodal arrays do not match %llu nodes", path.c_str(), step, (unsigned long long)nr);
  PetscCheck(frame.element_resultants.size() == 6 * er && frame.element_strains.size() == 6 * er, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
             "output file '%s': step %d: element arrays do not match %llu elements", path.c_str(), step, (unsigned long long)er);
  if (has_velocities)
    PetscCheck(frame.velocity.size() == 3 * nr && frame.angular_velocity.size() == 3 * nr, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
               "output file '%s': step %d: velocity arrays do not match %llu nodes", path.c_str(), step, (unsigned long long)nr);
  for (const int row : node_rows)
    PetscCheck(row >= 0 && (hsize_t)row < n_nodes, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "output file '%s': step %d: node row %d of %llu", path.c_str(),
               step, row, (unsigned long long)n_nodes);
  for (const int row : element_rows)
    PetscCheck(row >= 0 && (hsize_t)row < n_elements, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "output file '%s': step %d: element row %d of %llu",
               path.c_str(), step, row, (unsigned long long)n_elements);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::WriteFrameRows(const OutputFrame &frame, int step, double time, bool has_velocities, const std::vector<int> &node_rows,
                                                const std::vector<int> &element_rows)
{
  const std::string   group_name = FrameGroupName(step);
  std::vector<int>    segment_rows;
  std::vector<double> segment_force, segment_moment, segment_axes[3];
  H5Id                group;

  PetscFunctionBeginUser;
  // A distributed frame numbers its elements' segments; otherwise rank 0 looks them up.
  const bool own_segments = frame.distributed;
  if (!own_segments && !element_rows.empty() && segment_first.empty()) PetscCall(LoadSegmentTable());
  PetscCheck(!own_segments || (frame.element_first_segment.size() == element_rows.size() && frame.element_segment_count.size() == element_rows.size()),
             PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "output file '%s': step %d: %zu element rows but %zu/%zu segment numbers", path.c_str(), step,
             element_rows.size(), frame.element_first_segment.size(), frame.element_segment_count.size());
  for (size_t k = 0; k < element_rows.size(); ++k) {
    const int first = own_segments ? frame.element_first_segment[k] : segment_first[element_rows[k]];
    const int last  = own_segments ? first + frame.element_segment_count[k] : segment_first[element_rows[k] + 1];
    PetscCheck(first >= 0 && (hsize_t)last <= n_segments, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "output file '%s': step %d: segments [%d, %d) of %llu",
               path.c_str(), step, first, last, (unsigned long long)n_segments);
    for (int s = first; s < last; ++s) {
      segment_rows.push_back(s);
      segment_force.insert(segment_force.end(), &frame.element_resultants[6 * k], &frame.element_resultants[6 * k + 3]);
      segment_moment.insert(segment_moment.end(), &frame.element_resultants[6 * k + 3], &frame.element_resultants[6 * k + 6]);
    }
  }
  // Section triads: the distributed frame lists them segment after segment, in element-row order.
  if (own_segments) {
    PetscCheck(frame.segment_triads.size() == 9 * segment_rows.size(), PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ,
               "output file '%s': step %d: %zu section triad values for %zu segments", path.c_str(), step, frame.segment_triads.size(), segment_rows.size());
    for (size_t s = 0; s < segment_rows.size(); ++s)
      for (int axis = 0; axis < 3; ++axis)
        segment_axes[axis].insert(segment_axes[axis].end(), &frame.segment_triads[9 * s + 3 * axis], &frame.segment_triads[9 * s + 3 * axis + 3]);
  }
  PetscCallHDF5(group = H5Gcreate2(file, group_name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  PetscCall(WriteAttribute(group, ".", "step", H5T_STD_I32LE, H5T_NATIVE_INT, &step));
  PetscCall(WriteAttribute(group, ".", "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &time));
  PetscCall(WriteRows(group, "position", n_nodes, 3, node_rows, frame.position));
  PetscCall(WriteRows(group, "displacement", n_nodes, 3, node_rows, frame.displacement));
  PetscCall(WriteRows(group, "rotation", n_nodes, 4, node_rows, frame.rotation));
  PetscCall(WriteRows(group, "element_resultants", n_elements, 6, element_rows, frame.element_resultants));
  PetscCall(WriteRows(group, "element_strains", n_elements, 6, element_rows, frame.element_strains));
  PetscCall(WriteRows(group, "segment_force", n_segments, 3, segment_rows, segment_force));
  PetscCall(WriteRows(group, "segment_moment", n_segments, 3, segment_rows, segment_moment));
  if (own_segments) {
    PetscCall(WriteRows(group, "segment_e1", n_segments, 3, segment_rows, segment_axes[0]));
    PetscCall(WriteRows(group, "segment_e2", n_segments, 3, segment_rows, segment_axes[1]));
    PetscCall(WriteRows(group, "segment_e3", n_segments, 3, segment_rows, segment_axes[2]));
  }
  if (has_velocities) {
    PetscCall(WriteRows(group, "velocity", n_nodes, 3, node_rows, frame.velocity));
    PetscCall(WriteRows(group, "angular_velocity", n_nodes, 3, node_rows, frame.angular_velocity));
  }
  PetscCallHDF5(H5Fflush(file, H5F_SCOPE_LOCAL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Names of the links in a group.
static herr_t CollectLinkName(hid_t, const char *name, const H5L_info_t *, void *names)
{
  static_cast<std::vector<std::string> *>(names)->push_back(name);
  return 0;
}

PetscErrorCode OutputFile::Impl::LinkNames(hid_t group, std::vector<std::string> *names) const
{
  PetscFunctionBeginUser;
  names->clear();
  PetscCallHDF5(H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, CollectLinkName, names));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Cuts an extensible dataset (history or probe series) to its first `rows` rows.
PetscErrorCode OutputFile::Impl::TruncateRows(hid_t parent, const std::string &name, hsize_t rows) const
{
  H5Id dataset, space;
  PetscFunctionBeginUser;
  PetscCallHDF5(dataset = H5Dopen2(parent, name.c_str(), H5P_DEFAULT));
  PetscCallHDF5(space = H5Dget_space(dataset));
  const int            rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims((size_t)std::max(rank, 1), 0);
  PetscCallHDF5(H5Sget_simple_extent_dims(space, dims.data(), nullptr));
  PetscCheck(dims[0] >= rows, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "output file '%s': %s has %llu rows, the checkpoint expects %llu", path.c_str(),
             name.c_str(), (unsigned long long)dims[0], (unsigned long long)rows);
  dims[0] = rows;
  PetscCallHDF5(H5Dset_extent(dataset, dims.data()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::Resume(int last_step, long long history_rows, const std::string &run_id)
{
  H5Id                     frames_group, history, probes;
  std::vector<std::string> names, probe_groups;
  const char              *p    = path.c_str();
  const hsize_t            rows = (hsize_t)history_rows;
  PetscFunctionBeginUser;
  PetscCall(OpenHdf5File(path, H5F_ACC_RDWR, H5P_DEFAULT, &file));
  // (1) Validation, nothing changes: the run this file belongs to (CheckRunFiles checked it as
  // well), the mesh, the frame of the checkpoint's last written step and every series' rows.
  FileMarker        marker;
  const std::string marker_problem = ReadFileMarker(file, &marker);
  PetscCheck(marker_problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, marker_problem.c_str());
  PetscCheck(run_id.empty() || marker.run.empty() || marker.run == run_id, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "the output file '%s' belongs to another run than the checkpoint; continue into a new file with -output_file NEW.h5", p);
  const auto rows_of = [&](const char *name, int rank, hsize_t *count) -> PetscErrorCode {
    std::vector<hsize_t> dims;
    PetscFunctionBeginUser;
    const std::string problem = DatasetDims(file, name, &dims);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
    PetscCheck((int)dims.size() == rank, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s has %d dimensions, expected %d", p, name, (int)dims.size(),
               rank);
    *count = dims[0];
    PetscFunctionReturn(PETSC_SUCCESS);
  };
  PetscCall(rows_of("/mesh/node_coordinates", 2, &n_nodes));
  PetscCall(rows_of("/mesh/element_order", 1, &n_elements));
  PetscCall(rows_of("/mesh/segment_element", 1, &n_segments));
  for (const char *group : {"/frames", "/history", "/probes"})
    PetscCheck(H5Lexists(file, group, H5P_DEFAULT) > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s' has no group %s", p, group);
  PetscCallHDF5(frames_group = H5Gopen2(file, "/frames", H5P_DEFAULT));
  PetscCall(LinkNames(frames_group, &names));
  frames.clear();
  std::vector<std::string> later_frames;
  for (const std::string &name : names) {
    FrameEntry entry{0, 0.0, false};
    {
      H5Id group, step, time;
      PetscCallHDF5(group = H5Gopen2(frames_group, name.c_str(), H5P_DEFAULT));
      PetscCallHDF5(step = H5Aopen(group, "step", H5P_DEFAULT));
      PetscCallHDF5(H5Aread(step, H5T_NATIVE_INT, &entry.step));
      PetscCallHDF5(time = H5Aopen(group, "time", H5P_DEFAULT));
      PetscCallHDF5(H5Aread(time, H5T_NATIVE_DOUBLE, &entry.time));
      entry.has_velocities     = H5Lexists(group, "velocity", H5P_DEFAULT) > 0;
      entry.has_section_triads = H5Lexists(group, "segment_e1", H5P_DEFAULT) > 0;
    }
    if (entry.step > last_step) later_frames.push_back(name);
    else frames.push_back(entry);
  }
  PetscCheck(std::any_of(frames.begin(), frames.end(), [&](const FrameEntry &f) { return f.step == last_step; }), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED,
             "'%s' has no frame for step %d, the last one the checkpoint wrote", p, last_step);
  std::sort(frames.begin(), frames.end(), [](const FrameEntry &a, const FrameEntry &b) { return a.step < b.step; });
  // Every history and probe series (group, name) must hold the checkpoint's rows.
  std::vector<std::pair<std::string, std::string>> series;
  PetscCallHDF5(history = H5Gopen2(file, "/history", H5P_DEFAULT));
  PetscCall(LinkNames(history, &names));
  for (const std::string &name : names) series.emplace_back("/history", name);
  PetscCallHDF5(probes = H5Gopen2(file, "/probes", H5P_DEFAULT));
  PetscCall(LinkNames(probes, &probe_groups));
  for (const std::string &probe : probe_groups) {
    H5Id group;
    PetscCallHDF5(group = H5Gopen2(probes, probe.c_str(), H5P_DEFAULT));
    PetscCall(LinkNames(group, &names));
    for (const std::string &name : names) series.emplace_back("/probes/" + probe, name);
  }
  PetscCheck(!series.empty() || rows == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s' has no history, the checkpoint expects %llu rows", p,
             (unsigned long long)rows);
  for (const auto &[group, name] : series) {
    std::vector<hsize_t> dims;
    const std::string    full    = group + "/" + name;
    const std::string    problem = DatasetDims(file, full, &dims);
    PetscCheck(problem.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s", p, problem.c_str());
    PetscCheck(!dims.empty() && dims[0] >= rows, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "'%s': %s has %llu rows, the checkpoint expects %llu", p,
               full.c_str(), dims.empty() ? 0ULL : (unsigned long long)dims[0], (unsigned long long)rows);
  }
  // (2) Changes: frames written after the checkpoint go, the series are cut to its rows.
  for (const std::string &name : later_frames) PetscCallHDF5(H5Ldelete(frames_group, name.c_str(), H5P_DEFAULT));
  for (const auto &[group, name] : series) {
    H5Id parent;
    PetscCallHDF5(parent = H5Gopen2(file, group.c_str(), H5P_DEFAULT));
    PetscCall(TruncateRows(parent, name, rows));
  }
  rows_written = rows;
  history_names.clear(); // taken from the next row, whose datasets must exist
  probe_names.clear();
  PetscCallHDF5(H5Fflush(file, H5F_SCOPE_LOCAL));
  PetscCall(WriteXdmf());
  PetscCallHDF5(H5Fclose(file.Release()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::LoadSegmentTable()
{
  H5Id dataset, space;
  PetscFunctionBeginUser;
  PetscCallHDF5(dataset = H5Dopen2(file, "/mesh/segment_element", H5P_DEFAULT));
  PetscCallHDF5(space = H5Dget_space(dataset));
  const hssize_t count = H5Sget_simple_extent_npoints(space);
  PetscCheck(count == (hssize_t)n_segments, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "output file '%s': /mesh/segment_element has %lld entries, not %llu",
             path.c_str(), (long long)count, (unsigned long long)n_segments);
  std::vector<int> element_of_segment(n_segments);
  if (n_segments > 0) PetscCallHDF5(H5Dread(dataset, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, element_of_segment.data()));
  segment_first.assign(n_elements + 1, 0);
  for (const int e : element_of_segment) ++segment_first[e + 1];
  for (hsize_t e = 0; e < n_elements; ++e) segment_first[e + 1] += segment_first[e];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Impl::Close()
{
  PetscFunctionBeginUser;
  PetscCallHDF5(H5Fclose(file.Release()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

OutputFile::~OutputFile()
{
  // Serial HDF5: not collective, only rank 0 holds a file, which the Impl's H5Id closes. Parallel
  // HDF5: closing is collective, so every rank must destroy an open OutputFile (Close is better).
  delete impl_;
}

PetscErrorCode OutputFile::Open(MPI_Comm comm, const std::string &path, bool overwrite, const std::string &input_file, const std::string &input_text,
                                const OutputMesh &mesh, const std::string &model_fingerprint, const std::string &run_id)
{
  PetscFunctionBeginUser;
  PetscCall(OpenWith(comm, path, [&] { return impl_->Create(overwrite, input_file, input_text, mesh, {kResultFormat, model_fingerprint, run_id}); }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Reopen(MPI_Comm comm, const std::string &path, int last_step, long long history_rows, const std::string &run_id)
{
  PetscFunctionBeginUser;
  PetscCall(OpenWith(comm, path, [&] { return impl_->Resume(last_step, history_rows, run_id); }));
  long long rows = impl_->rows_written;
  PetscCallMPI(MPI_Bcast(&rows, 1, MPI_LONG_LONG, 0, comm));
  impl_->rows_written = (hsize_t)rows;
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <class RootWork> PetscErrorCode OutputFile::OpenWith(MPI_Comm comm, const std::string &path, RootWork &&root_work)
{
  PetscFunctionBeginUser;
  PetscCheck(!impl_, comm, PETSC_ERR_ARG_WRONGSTATE, "cannot open output file '%s': '%s' is still open", path.c_str(), path_.c_str());
  comm_       = comm;
  path_       = path;
  impl_       = new Impl(path);
  impl_->comm = comm;
  PetscCallMPI(MPI_Comm_rank(comm, &impl_->rank));
  // Rank 0 prepares the file (creates it with /input and /mesh — replicated, small, partly
  // variable-length strings, which MPI-IO cannot write — or trims an existing one); then every
  // rank opens it for the collective writes.
  PetscErrorCode status = RunOnRoot(comm_, root_work);
  if (status == PETSC_SUCCESS) {
    // Only the sizes travel: a distributed frame brings the segment numbers of its elements.
    unsigned long long sizes[3] = {impl_->n_nodes, impl_->n_elements, impl_->n_segments};
    PetscCallMPI(MPI_Bcast(sizes, 3, MPI_UNSIGNED_LONG_LONG, 0, comm));
    impl_->n_nodes    = sizes[0];
    impl_->n_elements = sizes[1];
    impl_->n_segments = sizes[2];
    status            = RunCollective(comm_, [&] { return impl_->OpenParallel(); });
  }
  if (status != PETSC_SUCCESS) {
    // A failed Open leaves nothing open, so the object can be opened again.
    delete impl_;
    impl_ = nullptr;
  }
  PetscCall(status);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::WriteFrame(const OutputFrame &frame)
{
  PetscFunctionBeginUser;
  PetscCheck(impl_, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE, "WriteFrame: no output file is open");
  // Rank 0's step, time and kind of frame; the velocities are present if any rank has them.
  int    flags[2] = {frame.distributed ? 1 : 0, frame.velocity.empty() ? 0 : 1};
  int    step     = frame.step;
  double time     = frame.time;
  PetscCallMPI(MPI_Bcast(flags, 2, MPI_INT, 0, comm_));
  PetscCallMPI(MPI_Bcast(&step, 1, MPI_INT, 0, comm_));
  PetscCallMPI(MPI_Bcast(&time, 1, MPI_DOUBLE, 0, comm_));
  const bool       distributed    = flags[0] != 0;
  int              has_velocities = flags[1];
  std::vector<int> node_rows, element_rows;
  if (distributed) {
    const int mine = frame.velocity.empty() ? 0 : 1;
    PetscCallMPI(MPI_Allreduce(&mine, &has_velocities, 1, MPI_INT, MPI_LOR, comm_));
    node_rows    = frame.node_rows;
    element_rows = frame.element_rows;
  } else if (impl_->rank == 0) {
    // Rank 0 holds the whole frame (CheckFrame reports arrays of other sizes).
    for (hsize_t i = 0; i < impl_->n_nodes; ++i) node_rows.push_back((int)i);
    for (hsize_t e = 0; e < impl_->n_elements; ++e) element_rows.push_back((int)e);
  }
  unsigned long long local[2] = {node_rows.size(), element_rows.size()}, total[2];
  PetscCallMPI(MPI_Allreduce(local, total, 2, MPI_UNSIGNED_LONG_LONG, MPI_SUM, comm_));
  PetscCall(RunCollective(comm_, [&] { return impl_->CheckFrame(frame, step, has_velocities, node_rows, element_rows, total[0], total[1]); }));
  PetscCall(RunCollective(comm_, [&] { return impl_->WriteFrameRows(frame, step, time, has_velocities, node_rows, element_rows); }));
  impl_->frames.push_back({step, time, has_velocities != 0, distributed});
  PetscCall(RunOnRoot(comm_, [&] { return impl_->WriteXdmf(); }));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::AppendHistory(const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<ProbeSample> &probes)
{
  PetscFunctionBeginUser;
  PetscCheck(impl_, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE, "AppendHistory: no output file is open");
  // Rank 0 checks its row; every rank then creates and extends the datasets under rank 0's names,
  // and rank 0 alone selects the values in the collective writes.
  PetscCall(RunOnRoot(comm_, [&] { return impl_->CheckHistory(names, values, probes); }));
  std::vector<std::string> row_names = names, sample_names = ProbeNames(probes);
  PetscCall(BcastStrings(comm_, &row_names));
  PetscCall(BcastStrings(comm_, &sample_names));
  if (impl_->rank == 0) {
    PetscCall(RunCollective(comm_, [&] { return impl_->WriteHistory(row_names, values, sample_names, probes); }));
  } else {
    const std::vector<double>      no_values(row_names.size(), 0.0);
    const std::vector<ProbeSample> no_probes(sample_names.size());
    PetscCall(RunCollective(comm_, [&] { return impl_->WriteHistory(row_names, no_values, sample_names, no_probes); }));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode OutputFile::Close()
{
  PetscFunctionBeginUser;
  if (!impl_) PetscFunctionReturn(PETSC_SUCCESS); // closing twice is harmless, as for files
  const PetscErrorCode status = RunCollective(comm_, [&] { return impl_->Close(); });
  delete impl_;
  impl_ = nullptr;
  PetscCall(status);
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
