// OutputFile round trip: writes a tiny mesh, frames and history rows, then reads the file back with
// the HDF5 C API. Runs on any number of ranks: as in the solver, only rank 0 passes data (or each
// rank its rows, for distributed frames), and only rank 0 reads the file back. Also: history rows
// buffered and written in chunks, the flush semantics, the sidecar well-formed after every frame
// and its cost per frame, rigid bodies, joints, ground and force elements, units and provenance.
#include "core/hdf5_files.hpp"
#include "output/output_file.hpp"
#include "output/output_units.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <msflex_version.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

namespace msflex {
namespace {

// The markers of the files these tests write (a run writes its model fingerprint and run id).
const std::string kFingerprint = "sha256:" + std::string(64, '0');
const std::string kRunId       = std::string(32, 'a');

namespace fs = std::filesystem;

const std::vector<std::string> kHistoryNames = {"time", "load_factor", "newton_iterations"};
constexpr int                  kHistoryRows  = 3;
constexpr int                  kFrameSteps[] = {0, 3};

bool IsRoot()
{
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  return rank == 0;
}

std::vector<double> Ramp(size_t n, double first)
{
  std::vector<double> values(n);
  for (size_t i = 0; i < n; ++i) values[i] = first + (double)i;
  return values;
}

// Three nodes; element 0 is quadratic through all of them, element 1 is linear from node 2 back
// to node 0.
OutputMesh TinyMesh()
{
  OutputMesh mesh;
  mesh.node_coordinates = {0.0, 0.0, 0.0, 0.5, 0.1, 0.0, 1.0, 0.0, 0.0};
  mesh.node_names       = {"root", "mid", "tip"};
  mesh.element_nodes    = {0, 1, 2, 2, 0, -1};
  mesh.element_order    = {2, 1};
  mesh.element_beam     = {0, 1};
  mesh.beam_names       = {"arc", "chord"};
  return mesh;
}

double FrameTime(int step) { return 0.25 * step; }

// Every array gets distinct values (offset by the step) so that a swapped array shows.
OutputFrame FrameOfStep(int step)
{
  OutputFrame frame;
  frame.step               = step;
  frame.time               = FrameTime(step);
  frame.position           = Ramp(9, 100.0 * step);
  frame.displacement       = Ramp(9, 100.0 * step + 10.0);
  frame.rotation           = Ramp(12, 100.0 * step + 20.0);
  frame.element_resultants = Ramp(12, 100.0 * step + 40.0);
  frame.element_strains    = Ramp(12, 100.0 * step + 60.0);
  return frame;
}

std::vector<double> HistoryRow(int row) { return {0.5 * row, 0.1 * row, 3.0 + row}; }

ProbeSample ProbeOfRow(int row)
{
  ProbeSample probe;
  probe.name            = "tip";
  probe.position[0]     = row;
  probe.position[1]     = row + 0.25;
  probe.position[2]     = row + 0.5;
  probe.displacement[0] = -row;
  probe.rotation[3]     = 0.1 * row;
  probe.rotation_angle  = 0.2 * row;
  return probe;
}

// Reads a whole dataset as `memory_type` into a vector of T, and its shape into *dims.
template <class T> std::vector<T> ReadDataset(hid_t file, const std::string &name, hid_t memory_type, std::vector<hsize_t> *dims)
{
  const hid_t dataset = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  if (dataset < 0) {
    ADD_FAILURE() << "missing dataset " << name;
    return {};
  }
  const hid_t space = H5Dget_space(dataset);
  dims->assign(H5Sget_simple_extent_ndims(space), 0);
  H5Sget_simple_extent_dims(space, dims->data(), nullptr);
  std::vector<T> data(H5Sget_simple_extent_npoints(space));
  EXPECT_GE(H5Dread(dataset, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0) << name;
  H5Sclose(space);
  H5Dclose(dataset);
  return data;
}

std::vector<double> ReadDoubles(hid_t file, const std::string &name, std::vector<hsize_t> *dims)
{
  return ReadDataset<double>(file, name, H5T_NATIVE_DOUBLE, dims);
}

std::vector<int> ReadInts(hid_t file, const std::string &name, std::vector<hsize_t> *dims) { return ReadDataset<int>(file, name, H5T_NATIVE_INT, dims); }

// Frame `index` of the frame dataset /frames/<field> (frames x rows x columns): its values, and
// in *dims its shape (rows, columns).
std::vector<double> ReadFrame(hid_t file, const std::string &field, size_t index, std::vector<hsize_t> *dims)
{
  std::vector<hsize_t>      all;
  const std::vector<double> values = ReadDoubles(file, "/frames/" + field, &all);
  if (all.size() != 3 || index >= all[0]) {
    dims->clear();
    return {};
  }
  *dims                  = {all[1], all[2]};
  const size_t per_frame = all[1] * all[2];
  return std::vector<double>(values.begin() + index * per_frame, values.begin() + (index + 1) * per_frame);
}

// The history table's column names (/history/names, fixed-length strings), read by msflex's own reader.
std::vector<std::string> HistoryColumns(hid_t file, const char *list = "/history/names")
{
  std::vector<std::string> names;
  const std::string        problem = ReadFixedStrings(file, list, &names);
  EXPECT_EQ(problem, "");
  return names;
}

// Column `series` of the history table /history/values; *dims = {rows}.
std::vector<double> ReadSeries(hid_t file, const std::string &series, std::vector<hsize_t> *dims)
{
  std::vector<hsize_t>           table_dims;
  const std::vector<double>      table = ReadDoubles(file, "/history/values", &table_dims);
  const std::vector<std::string> names = HistoryColumns(file);
  const auto                     found = std::find(names.begin(), names.end(), series);
  dims->clear();
  EXPECT_NE(found, names.end()) << "no history column " << series;
  if (found == names.end() || table_dims.size() != 2) return {};
  const size_t        column = (size_t)(found - names.begin());
  std::vector<double> values;
  for (hsize_t row = 0; row < table_dims[0]; ++row) values.push_back(table[row * table_dims[1] + column]);
  *dims = {table_dims[0]};
  return values;
}

// A probe's quantity from its history columns, row after row: position and displacement (x, y,
// z), rotation (w, x, y, z), rotation_angle; *dims = {rows, components} ({rows} for the angle).
std::vector<double> ReadProbe(hid_t file, const std::string &probe, const std::string &quantity, std::vector<hsize_t> *dims)
{
  const std::string components = quantity == "rotation" ? "wxyz" : quantity == "rotation_angle" ? "" : "xyz";
  if (components.empty()) return ReadSeries(file, probe + "." + quantity, dims);
  std::vector<std::vector<double>> columns;
  for (const char c : components) columns.push_back(ReadSeries(file, probe + "." + quantity + "." + c, dims));
  std::vector<double> values;
  for (size_t row = 0; row < columns[0].size(); ++row)
    for (const std::vector<double> &column : columns) values.push_back(column[row]);
  *dims = {columns[0].size(), components.size()};
  return values;
}

// The unit ("units") or description ("descriptions") of history column `series`.
std::string SeriesQuantity(hid_t file, const std::string &series, const char *which)
{
  const std::vector<std::string> names = HistoryColumns(file),
                                 texts = HistoryColumns(file, which == std::string("units") ? "/history/units" : "/history/descriptions");
  const auto found                     = std::find(names.begin(), names.end(), series);
  EXPECT_NE(found, names.end()) << "no history column " << series;
  return found == names.end() || texts.size() != names.size() ? std::string("?") : texts[(size_t)(found - names.begin())];
}

// The in-memory type of the file's strings: HDF5 does not convert between character sets.
hid_t CreateUtf8StringType()
{
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  return type;
}

std::vector<std::string> ReadStrings(hid_t file, const std::string &name, std::vector<hsize_t> *dims)
{
  const hid_t              type = CreateUtf8StringType();
  std::vector<std::string> strings;
  for (char *s : ReadDataset<char *>(file, name, type, dims)) {
    strings.emplace_back(s ? s : "");
    H5free_memory(s);
  }
  H5Tclose(type);
  return strings;
}

template <class T> T ReadAttribute(hid_t file, const std::string &object, const char *name, hid_t memory_type)
{
  T           value{};
  const hid_t attribute = H5Aopen_by_name(file, object.c_str(), name, H5P_DEFAULT, H5P_DEFAULT);
  EXPECT_GE(attribute, 0) << object << " has no attribute " << name;
  if (attribute >= 0) {
    EXPECT_GE(H5Aread(attribute, memory_type, &value), 0);
    H5Aclose(attribute);
  }
  return value;
}

// A string attribute, written fixed-length (OutputFile::Impl::WriteStringAttribute): read in its own type.
std::string ReadStringAttribute(hid_t file, const std::string &object, const char *name)
{
  const hid_t attribute = H5Aopen_by_name(file, object.c_str(), name, H5P_DEFAULT, H5P_DEFAULT);
  EXPECT_GE(attribute, 0) << object << " has no attribute " << name;
  if (attribute < 0) return "";
  const hid_t type = H5Aget_type(attribute);
  EXPECT_EQ(H5Tget_class(type), H5T_STRING) << object << ": " << name;
  EXPECT_EQ(H5Tis_variable_str(type), 0) << object << ": " << name << " is not fixed-length";
  std::string text(H5Tget_size(type), '\0');
  EXPECT_GE(H5Aread(attribute, type, text.data()), 0);
  H5Tclose(type);
  H5Aclose(attribute);
  return std::string(text.c_str());
}

std::string ReadText(const fs::path &path)
{
  std::ifstream      in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A scratch directory shared by all ranks (named after rank 0's process), removed afterwards.
class OutputFileTest : public ::testing::Test {
protected:
  void SetUp() override
  {
    long id = getpid();
    MPI_Bcast(&id, 1, MPI_LONG, 0, PETSC_COMM_WORLD);
    directory_ = fs::temp_directory_path() / ("msflex_test_output_file_" + std::to_string(id));
    if (IsRoot()) fs::create_directories(directory_);
    MPI_Barrier(PETSC_COMM_WORLD);
  }
  void TearDown() override
  {
    MPI_Barrier(PETSC_COMM_WORLD);
    if (IsRoot()) fs::remove_all(directory_);
  }

  // Opens `path` as the solver does: only rank 0 passes the mesh.
  PetscErrorCode OpenTiny(OutputFile *out, bool overwrite)
  {
    return out->Open(PETSC_COMM_WORLD, h5_path().string(), overwrite, "tiny.yaml", "analysis: {type: static}\n", IsRoot() ? TinyMesh() : OutputMesh{},
                     kFingerprint, kRunId);
  }

  fs::path h5_path() const { return directory_ / "output.h5"; }
  fs::path xdmf_path() const { return directory_ / "output.xmf"; }

  fs::path directory_;
};

TEST_F(OutputFileTest, WritesMeshFramesHistoryAndSidecar)
{
  OutputFile out;
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  for (const int step : kFrameSteps) {
    OutputFrame frame = IsRoot() ? FrameOfStep(step) : OutputFrame{};
    ASSERT_EQ(out.WriteFrame(frame), PETSC_SUCCESS);
  }
  for (int row = 0; row < kHistoryRows; ++row) ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(row), {ProbeOfRow(row)}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;

  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  using Shape = std::vector<hsize_t>;

  EXPECT_EQ(ReadStrings(file, "/input", &dims), std::vector<std::string>{"analysis: {type: static}\n"});
  EXPECT_EQ(dims, Shape{});
  EXPECT_EQ(ReadStringAttribute(file, "/input", "file"), "tiny.yaml");

  const OutputMesh mesh = TinyMesh();
  EXPECT_EQ(ReadDoubles(file, "/mesh/node_coordinates", &dims), mesh.node_coordinates);
  EXPECT_EQ(dims, (Shape{3, 3}));
  EXPECT_EQ(ReadStrings(file, "/mesh/node_names", &dims), mesh.node_names);
  EXPECT_EQ(dims, Shape{3});
  EXPECT_EQ(ReadInts(file, "/mesh/element_nodes", &dims), mesh.element_nodes);
  EXPECT_EQ(dims, (Shape{2, 3}));
  EXPECT_EQ(ReadInts(file, "/mesh/element_order", &dims), mesh.element_order);
  EXPECT_EQ(ReadInts(file, "/mesh/element_beam", &dims), mesh.element_beam);
  EXPECT_EQ(ReadStrings(file, "/mesh/beam_names", &dims), mesh.beam_names);
  EXPECT_EQ(ReadInts(file, "/mesh/segments", &dims), (std::vector<int>{0, 1, 1, 2, 2, 0}));
  EXPECT_EQ(dims, (Shape{3, 2}));
  EXPECT_EQ(ReadInts(file, "/mesh/segment_element", &dims), (std::vector<int>{0, 0, 1}));

  std::vector<int> steps;
  for (const int step : kFrameSteps) steps.push_back(step);
  EXPECT_EQ(ReadInts(file, "/frames/step", &dims), steps);
  EXPECT_EQ(dims, Shape{steps.size()});
  EXPECT_EQ(ReadDoubles(file, "/frames/time", &dims), (std::vector<double>{FrameTime(steps[0]), FrameTime(steps[1])}));
  EXPECT_EQ(ReadInts(file, "/frames/contents", &dims), (std::vector<int>{0, 0})) << "static frames of rank 0: no velocities, triads, bodies, joints";
  for (size_t k = 0; k < steps.size(); ++k) {
    const OutputFrame expected = FrameOfStep(steps[k]);
    EXPECT_EQ(ReadFrame(file, "position", k, &dims), expected.position);
    EXPECT_EQ(dims, (Shape{3, 3}));
    EXPECT_EQ(ReadFrame(file, "displacement", k, &dims), expected.displacement);
    EXPECT_EQ(ReadFrame(file, "rotation", k, &dims), expected.rotation);
    EXPECT_EQ(dims, (Shape{3, 4}));
    EXPECT_EQ(ReadFrame(file, "element_resultants", k, &dims), expected.element_resultants);
    EXPECT_EQ(dims, (Shape{2, 6}));
    EXPECT_EQ(ReadFrame(file, "element_strains", k, &dims), expected.element_strains);
    // Segments 0 and 1 belong to element 0, segment 2 to element 1.
    const std::vector<double> &r = expected.element_resultants;
    EXPECT_EQ(ReadFrame(file, "segment_force", k, &dims), (std::vector<double>{r[0], r[1], r[2], r[0], r[1], r[2], r[6], r[7], r[8]}));
    EXPECT_EQ(dims, (Shape{3, 3}));
    EXPECT_EQ(ReadFrame(file, "segment_moment", k, &dims), (std::vector<double>{r[3], r[4], r[5], r[3], r[4], r[5], r[9], r[10], r[11]}));
  }

  for (size_t i = 0; i < kHistoryNames.size(); ++i) {
    std::vector<double> expected;
    for (int row = 0; row < kHistoryRows; ++row) expected.push_back(HistoryRow(row)[i]);
    EXPECT_EQ(ReadSeries(file, kHistoryNames[i], &dims), expected) << kHistoryNames[i];
    EXPECT_EQ(dims, Shape{kHistoryRows});
  }
  EXPECT_EQ(ReadProbe(file, "tip", "position", &dims), (std::vector<double>{0, 0.25, 0.5, 1, 1.25, 1.5, 2, 2.25, 2.5}));
  EXPECT_EQ(dims, (Shape{kHistoryRows, 3}));
  EXPECT_EQ(ReadProbe(file, "tip", "displacement", &dims), (std::vector<double>{0, 0, 0, -1, 0, 0, -2, 0, 0}));
  EXPECT_EQ(ReadProbe(file, "tip", "rotation", &dims), (std::vector<double>{1, 0, 0, 0, 1, 0, 0, 0.1, 1, 0, 0, 0.2}));
  EXPECT_EQ(dims, (Shape{kHistoryRows, 4}));
  EXPECT_EQ(ReadProbe(file, "tip", "rotation_angle", &dims), (std::vector<double>{0, 0.2, 0.4}));
  EXPECT_EQ(dims, Shape{kHistoryRows});
  EXPECT_GE(H5Fclose(file), 0);

  ASSERT_TRUE(fs::exists(xdmf_path()));
  const std::string xdmf = ReadText(xdmf_path());
  EXPECT_NE(xdmf.find("CollectionType=\"Temporal\""), std::string::npos);
  // The default syntax, xdmf3: frame k of a dataset of K frames as `|k 0 0:1 1 1:1 rows cols:K rows cols`.
  for (const char *expected :
       {"<Time Value=\"0\"/>", "<Time Value=\"0.75\"/>", ">output.h5:/frames/position|0 0 0:1 1 1:1 3 3:1 3 3<",
        ">output.h5:/frames/position|1 0 0:1 1 1:1 3 3:2 3 3<", ">output.h5:/frames/segment_force|1 0 0:1 1 1:1 3 3:2 3 3<", ">output.h5:/mesh/segments<"})
    EXPECT_NE(xdmf.find(expected), std::string::npos) << "sidecar lacks " << expected << ":\n" << xdmf;
  EXPECT_EQ(xdmf.find("HyperSlab"), std::string::npos) << "an xdmf3 sidecar has no HyperSlab items:\n" << xdmf;
  EXPECT_EQ(xdmf.find(directory_.string()), std::string::npos) << "the sidecar must refer to the .h5 by its relative name";
}

// With XdmfFlavour::Xdmf2 the frames are HyperSlab items, the points named and referred to.
TEST_F(OutputFileTest, Xdmf2SidecarUsesHyperSlabs)
{
  OutputFile out;
  out.SetXdmfFlavour(XdmfFlavour::Xdmf2);
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  for (const int step : kFrameSteps) ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(step) : OutputFrame{}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const std::string xdmf = ReadText(xdmf_path());
  for (const char *expected : {"<DataItem Name=\"position_0\"", "<DataItem Name=\"position_1\"", "[@Name='position_1']", ">1 0 0 1 1 1 1 3 3<",
                               ">output.h5:/frames/segment_force<", ">output.h5:/mesh/segments<"})
    EXPECT_NE(xdmf.find(expected), std::string::npos) << "sidecar lacks " << expected << ":\n" << xdmf;
  EXPECT_EQ(xdmf.find("|"), std::string::npos) << "an xdmf2 sidecar has no xdmf3 selections:\n" << xdmf;
}

TEST_F(OutputFileTest, ExistingFileNeedsOverwrite)
{
  {
    OutputFile first;
    ASSERT_EQ(OpenTiny(&first, false), PETSC_SUCCESS);
    ASSERT_EQ(first.WriteFrame(IsRoot() ? FrameOfStep(0) : OutputFrame{}), PETSC_SUCCESS);
    ASSERT_EQ(first.Close(), PETSC_SUCCESS);
  }

  // Every rank must fail, with rank 0's message, rather than hang or go on.
  OutputFile     second;
  char          *message = nullptr;
  PetscErrorCode status;
  ASSERT_EQ(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr), PETSC_SUCCESS);
  status = OpenTiny(&second, false);
  PetscErrorMessage(status, nullptr, &message);
  ASSERT_EQ(PetscPopErrorHandler(), PETSC_SUCCESS);
  EXPECT_EQ(status, PETSC_ERR_USER_INPUT);
  EXPECT_NE(std::string(message).find("output.h5' exists; pass -output_overwrite"), std::string::npos) << message;

  // The failed Open left the object closed, and overwriting starts an empty file and sidecar.
  ASSERT_EQ(OpenTiny(&second, true), PETSC_SUCCESS);
  ASSERT_EQ(second.Close(), PETSC_SUCCESS);
  if (IsRoot()) {
    EXPECT_EQ(ReadText(xdmf_path()).find("<Grid Name=\"step"), std::string::npos);
  }
}

// ---- Rigid bodies, joints, ground ----------------------------------------------------------------

// The tiny mesh with two rigid bodies (on root and tip), two joints (tip on the ground, mid on root)
// and two ground markers; a dynamic analysis.
OutputMesh MechanismMesh()
{
  OutputMesh mesh             = TinyMesh();
  mesh.analysis_type          = "dynamic";
  mesh.joint_names            = {"hinge", "slider"};
  mesh.joint_types            = {"revolute", "prismatic"};
  mesh.joint_master           = {-1, 0};
  mesh.joint_slave            = {2, 1};
  mesh.joint_axes             = Ramp(18, 0.5);
  mesh.joint_offset           = {0, 0, 0, 0.5, 0.1, 0};
  mesh.body_names             = {"root", "tip"};
  mesh.body_node              = {0, 2};
  mesh.body_mass              = {2.0, 3.0};
  mesh.body_inertia           = Ramp(18, 1.0);
  mesh.body_offset            = Ramp(6, 0.25);
  mesh.body_principal_moments = Ramp(6, 4.0);
  mesh.body_principal_axes    = Ramp(18, 5.0);
  mesh.body_semi_axes         = Ramp(6, 6.0);
  mesh.ground_names           = {"hinge", "root"};
  mesh.ground_kinds           = {"joint", "support"};
  mesh.ground_position        = Ramp(6, 7.0);
  mesh.ground_axes            = Ramp(18, 8.0);
  return mesh;
}

int WorldSize()
{
  int size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  return size;
}

int WorldRank()
{
  int rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  return rank;
}

// A frame of the mechanism with distinct values in every array, bodies and joints included.
OutputFrame MechanismFrame(int step)
{
  OutputFrame frame      = FrameOfStep(step);
  frame.velocity         = Ramp(9, 100.0 * step + 70.0);
  frame.angular_velocity = Ramp(9, 100.0 * step + 80.0);
  frame.body_center      = Ramp(6, 1000.0 * step + 1.0);
  frame.body_axes        = Ramp(18, 1000.0 * step + 10.0);
  frame.body_rotation    = Ramp(8, 1000.0 * step + 30.0);
  frame.joint_position   = Ramp(6, 1000.0 * step + 40.0);
  frame.joint_axes       = Ramp(18, 1000.0 * step + 50.0);
  return frame;
}

// The part of `whole` (rank 0's complete frame) that rank `rank` of `size` holds when every table's
// rows are dealt out in turn: row i to rank i % size. Section triads: distinct values per segment.
OutputFrame DistributedPart(const OutputFrame &whole, int rank, int size)
{
  OutputFrame part;
  part.step        = whole.step;
  part.time        = whole.time;
  part.distributed = true;
  const auto take  = [&](const std::vector<double> &from, size_t width, size_t rows, std::vector<double> *to, std::vector<int> *row_numbers) {
    for (size_t i = 0; i < rows; ++i) {
      if ((int)(i % size) != rank) continue;
      to->insert(to->end(), &from[width * i], &from[width * i + width]);
      if (row_numbers) row_numbers->push_back((int)i);
    }
  };
  take(whole.position, 3, 3, &part.position, &part.node_rows);
  take(whole.displacement, 3, 3, &part.displacement, nullptr);
  take(whole.rotation, 4, 3, &part.rotation, nullptr);
  take(whole.velocity, 3, 3, &part.velocity, nullptr);
  take(whole.angular_velocity, 3, 3, &part.angular_velocity, nullptr);
  take(whole.element_resultants, 6, 2, &part.element_resultants, &part.element_rows);
  take(whole.element_strains, 6, 2, &part.element_strains, nullptr);
  const int first_segment[2] = {0, 2}, segment_count[2] = {2, 1};
  for (const int e : part.element_rows) {
    part.element_first_segment.push_back(first_segment[e]);
    part.element_segment_count.push_back(segment_count[e]);
    for (int s = first_segment[e]; s < first_segment[e] + segment_count[e]; ++s)
      for (int k = 0; k < 9; ++k) part.segment_triads.push_back(100.0 * whole.step + 10.0 * s + k);
  }
  take(whole.body_center, 3, 2, &part.body_center, &part.body_rows);
  take(whole.body_axes, 9, 2, &part.body_axes, nullptr);
  take(whole.body_rotation, 4, 2, &part.body_rotation, nullptr);
  take(whole.joint_position, 3, 2, &part.joint_position, &part.joint_rows);
  take(whole.joint_axes, 9, 2, &part.joint_axes, nullptr);
  return part;
}

// Columns [3 part, 3 part + 3) of every row of 9: one of the three vectors of a table of triads.
std::vector<double> Part(const std::vector<double> &rows_of_nine, int part)
{
  std::vector<double> out;
  for (size_t r = 0; r + 9 <= rows_of_nine.size(); r += 9) out.insert(out.end(), &rows_of_nine[r + 3 * part], &rows_of_nine[r + 3 * part + 3]);
  return out;
}

size_t CountOf(const std::string &text, const std::string &needle)
{
  size_t count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++count;
  return count;
}

// Whether `text` is well-formed XML as far as the sidecar needs: one root element, every element
// closed in order, attribute values quoted, comments and the declaration closed. *why says what
// is wrong.
bool WellFormedXml(const std::string &text, std::string *why)
{
  std::vector<std::string> open;
  bool                     root_seen = false;
  for (size_t at = 0; at < text.size();) {
    if (text[at] != '<') {
      if (open.empty() && !std::isspace((unsigned char)text[at])) return *why = "text outside the root element at " + std::to_string(at), false;
      ++at;
      continue;
    }
    if (text.compare(at, 4, "<!--") == 0 || text.compare(at, 2, "<?") == 0) {
      const char  *end   = text.compare(at, 4, "<!--") == 0 ? "-->" : "?>";
      const size_t close = text.find(end, at);
      if (close == std::string::npos) return *why = "unclosed comment or declaration", false;
      at = close + std::strlen(end);
      continue;
    }
    size_t close = at + 1;
    char   quote = 0;
    for (; close < text.size() && (quote || text[close] != '>'); ++close)
      if (text[close] == '"' || text[close] == '\'') quote = quote == text[close] ? 0 : quote ? quote : text[close];
    if (close >= text.size()) return *why = "unclosed tag at " + std::to_string(at), false;
    const std::string tag = text.substr(at + 1, close - at - 1);
    if (tag.empty()) return *why = "empty tag", false;
    if (tag[0] == '/') {
      const std::string name = tag.substr(1, tag.find_first_of(" \t\n", 1) - 1);
      if (open.empty() || open.back() != name) return *why = "</" + name + "> closes " + (open.empty() ? "nothing" : "<" + open.back() + ">"), false;
      open.pop_back();
    } else {
      if (open.empty() && root_seen) return *why = "a second root element", false;
      root_seen = true;
      if (tag.back() != '/') open.push_back(tag.substr(0, tag.find_first_of(" \t\n/")));
    }
    at = close + 1;
  }
  if (!open.empty()) return *why = "<" + open.back() + "> not closed", false;
  if (!root_seen) return *why = "no root element", false;
  return true;
}

// Rows of a 1-D or 2-D dataset in the file as it is on disk, read through a second, independent
// handle (the POSIX driver) while the writer keeps its own open; -1 when the dataset is missing.
long long RowsOnDisk(const fs::path &path, const char *dataset)
{
  const hid_t access = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fapl_sec2(access);
  long long   rows = -1;
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, access);
  H5Pclose(access);
  if (file < 0) return -2;
  if (H5Lexists(file, "/history", H5P_DEFAULT) > 0 && H5Lexists(file, dataset, H5P_DEFAULT) > 0) {
    const hid_t set   = H5Dopen2(file, dataset, H5P_DEFAULT);
    const hid_t space = H5Dget_space(set);
    hsize_t     dims[2];
    H5Sget_simple_extent_dims(space, dims, nullptr);
    rows = (long long)dims[0];
    H5Sclose(space);
    H5Dclose(set);
  }
  H5Fclose(file);
  return rows;
}

TEST_F(OutputFileTest, HistoryIsBufferedAndWrittenInChunks)
{
  constexpr int kRows = 2500; // more than two chunks of 1024 rows
  OutputFile    out;
  out.SetFlushInterval(1e9); // only explicit flushes and Close
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  EXPECT_FALSE(out.HistoryNamesKnown());
  for (int row = 0; row < kRows; ++row) {
    // Rows after the first may leave the names out (as msflex does); every third still names them.
    const bool named = !out.HistoryNamesKnown() || row % 3 == 0;
    ASSERT_EQ(out.AppendHistory(named ? kHistoryNames : std::vector<std::string>{}, HistoryRow(row), {ProbeOfRow(row)}), PETSC_SUCCESS);
    EXPECT_TRUE(out.HistoryNamesKnown());
    EXPECT_EQ(out.HistoryRows(), row + 1);
    if (row == 6 || row == 1500) {
      const long long before = IsRoot() ? RowsOnDisk(h5_path(), "/history/values") : 0;
      ASSERT_EQ(out.Flush(), PETSC_SUCCESS);
      const long long after = IsRoot() ? RowsOnDisk(h5_path(), "/history/values") : 0;
      if (IsRoot()) {
        EXPECT_EQ(before, row == 6 ? -1 : 7) << "rows are kept in memory until a flush";
        EXPECT_EQ(after, row + 1) << "a flush writes every buffered row";
      }
    }
  }
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  for (size_t i = 0; i < kHistoryNames.size(); ++i) {
    std::vector<double> expected;
    for (int row = 0; row < kRows; ++row) expected.push_back(HistoryRow(row)[i]);
    EXPECT_EQ(ReadSeries(file, kHistoryNames[i], &dims), expected) << kHistoryNames[i];
  }
  std::vector<double> position, angle;
  for (int row = 0; row < kRows; ++row) {
    const ProbeSample probe = ProbeOfRow(row);
    position.insert(position.end(), probe.position, probe.position + 3);
    angle.push_back(probe.rotation_angle);
  }
  EXPECT_EQ(ReadProbe(file, "tip", "position", &dims), position);
  EXPECT_EQ(dims, (std::vector<hsize_t>{kRows, 3}));
  EXPECT_EQ(ReadProbe(file, "tip", "rotation_angle", &dims), angle);
  // Chunks as large as the first write needs, rounded up to a power of two: the flush at 7 rows
  // created the table, so its chunks have the fewest rows (64), not 1024, and every column.
  const hid_t dataset = H5Dopen2(file, "/history/values", H5P_DEFAULT), properties = H5Dget_create_plist(dataset);
  hsize_t     chunk[2] = {0, 0};
  EXPECT_EQ(H5Pget_chunk(properties, 2, chunk), 2);
  EXPECT_EQ(chunk[0], 64u);
  EXPECT_EQ(chunk[1], kHistoryNames.size() + kProbeColumns);
  H5Pclose(properties);
  H5Dclose(dataset);
  EXPECT_GE(H5Fclose(file), 0);
}

TEST_F(OutputFileTest, UnnamedHistoryRowsMustMatchTheFirst)
{
  OutputFile out;
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  // Every rank gets rank 0's error (the rows are checked there).
  auto rejected = [&](const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<ProbeSample> &probes, const char *expected) {
    char *message = nullptr;
    EXPECT_EQ(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr), PETSC_SUCCESS);
    const PetscErrorCode status = out.AppendHistory(names, values, probes);
    PetscErrorMessage(status, nullptr, &message);
    EXPECT_EQ(PetscPopErrorHandler(), PETSC_SUCCESS);
    EXPECT_NE(status, PETSC_SUCCESS);
    EXPECT_NE(std::string(message ? message : "").find(expected), std::string::npos) << message;
  };
  rejected({}, HistoryRow(0), {ProbeOfRow(0)}, "the first history row must name its series");
  EXPECT_FALSE(out.HistoryNamesKnown());
  ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(0), {ProbeOfRow(0)}), PETSC_SUCCESS);
  std::vector<double> short_row = HistoryRow(1);
  short_row.pop_back();
  rejected({}, short_row, {ProbeOfRow(1)}, "a history row of 2 values and 1 probe samples, the first had 3 and 1");
  rejected({}, HistoryRow(1), {ProbeOfRow(1), ProbeOfRow(1)}, "a history row of 3 values and 2 probe samples, the first had 3 and 1");
  EXPECT_EQ(out.HistoryRows(), 1);
  ASSERT_EQ(out.AppendHistory({}, HistoryRow(1), {ProbeOfRow(1)}), PETSC_SUCCESS);
  EXPECT_EQ(out.HistoryRows(), 2);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
}

TEST_F(OutputFileTest, FlushIntervalZeroWritesEveryRowAndATimedFlushComesWhenDue)
{
  OutputFile out;
  out.SetFlushInterval(0.0);
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  for (int row = 0; row < 3; ++row) {
    ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(row), {ProbeOfRow(row)}), PETSC_SUCCESS);
    if (IsRoot()) {
      EXPECT_EQ(RowsOnDisk(h5_path(), "/history/values"), row + 1);
    }
  }
  // One second between flushes: a row right after a flush stays in memory, one after a second does not.
  out.SetFlushInterval(1.0);
  ASSERT_EQ(out.Flush(), PETSC_SUCCESS);
  ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(3), {ProbeOfRow(3)}), PETSC_SUCCESS);
  if (IsRoot()) {
    EXPECT_EQ(RowsOnDisk(h5_path(), "/history/values"), 3);
  }
  usleep(1100000);
  ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(4), {ProbeOfRow(4)}), PETSC_SUCCESS);
  if (IsRoot()) {
    EXPECT_EQ(RowsOnDisk(h5_path(), "/history/values"), 5);
  }
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
}

TEST_F(OutputFileTest, SidecarIsWellFormedAfterEveryFrameAndListsFlushedFrames)
{
  OutputFile out;
  out.SetFlushInterval(1e9);
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  std::string why;
  if (IsRoot()) {
    EXPECT_TRUE(WellFormedXml(ReadText(xdmf_path()), &why)) << why;
  }
  const std::string beams_grid = "<Grid Name=\"beams\" GridType=\"Uniform\">";
  // Unflushed frames are not listed (the file does not hold them safely yet) ...
  for (int step = 0; step < 3; ++step) ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(step) : OutputFrame{}), PETSC_SUCCESS);
  if (IsRoot()) {
    EXPECT_EQ(CountOf(ReadText(xdmf_path()), beams_grid), 0u);
  }
  ASSERT_EQ(out.Flush(), PETSC_SUCCESS);
  // ... and with a flush at every step the sidecar grows by one grid each time. (A step's flush
  // comes with its history row, after its frame, as in a run: a flush between the two left a killed
  // run's file with a frame of a step its history did not reach.)
  out.SetFlushInterval(0.0);
  for (int step = 3; step < 9; ++step) {
    ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(step) : OutputFrame{}), PETSC_SUCCESS);
    if (IsRoot()) EXPECT_EQ(CountOf(ReadText(xdmf_path()), beams_grid), (size_t)step) << "the frame of step " << step << " before its row";
    ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(step), {ProbeOfRow(step)}), PETSC_SUCCESS);
    if (!IsRoot()) continue;
    const std::string xdmf = ReadText(xdmf_path());
    EXPECT_TRUE(WellFormedXml(xdmf, &why)) << "after step " << step << ": " << why << "\n" << xdmf;
    EXPECT_EQ(CountOf(xdmf, beams_grid), (size_t)step + 1);
    EXPECT_EQ(CountOf(xdmf, "<xi:include xpointer=\"xpointer(/Xdmf/Information[@Name='frames']"), 1u) << "one collection: the beams";
    EXPECT_EQ(CountOf(xdmf, "<xi:include xpointer=\"xpointer(/Xdmf/Information[@Name='shared']"), (size_t)step + 1) << "each grid includes the topology";
    const std::string tail = "  </Information>\n</Xdmf>\n";
    EXPECT_EQ(xdmf.substr(xdmf.size() - tail.size()), tail);
    const char *times[] = {"0", "0.25", "0.5", "0.75", "1", "1.25", "1.5", "1.75", "2"}; // steps of 0.25, shortest decimals
    EXPECT_NE(xdmf.find(std::string("<Time Value=\"") + times[step] + "\"/>"), std::string::npos) << times[step];
  }
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
}

// What a frame costs, sidecar included, in a run that flushes every 10 frames: the same for the
// last 20 of 20 frames as for the last 20 of 400. Printed, not asserted (timings vary with the
// machine's load); the sidecar's contents are checked. (Flushing after every frame makes HDF5's
// H5Fflush itself slower as its metadata cache fills up; the timed flushes of a run are seconds
// apart.)
TEST_F(OutputFileTest, CostPerFrameDoesNotGrowWithTheFrameCount)
{
  double    seconds_per_frame[2] = {0, 0};
  const int counts[2]            = {20, 400};
  for (int run = 0; run < 2; ++run) {
    OutputFile out;
    out.SetFlushInterval(1e9);
    ASSERT_EQ(OpenTiny(&out, true), PETSC_SUCCESS);
    double started = MPI_Wtime();
    for (int step = 0; step < counts[run]; ++step) {
      if (step == counts[run] - 20) started = MPI_Wtime(); // the last 20 frames
      ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(step) : OutputFrame{}), PETSC_SUCCESS);
      if (step % 10 == 9) {
        ASSERT_EQ(out.Flush(), PETSC_SUCCESS);
      }
    }
    seconds_per_frame[run] = (MPI_Wtime() - started) / 20;
    ASSERT_EQ(out.Close(), PETSC_SUCCESS);
    if (IsRoot()) {
      EXPECT_EQ(CountOf(ReadText(xdmf_path()), "<Grid Name=\"beams\" GridType=\"Uniform\">"), (size_t)counts[run]);
    }
  }
  if (IsRoot())
    std::printf("[ cost     ] frames %d..%d of %d: %.3f ms per frame; frames %d..%d of %d: %.3f ms per frame; ratio %.2f\n", counts[0] - 20, counts[0] - 1,
                counts[0], 1e3 * seconds_per_frame[0], counts[1] - 20, counts[1] - 1, counts[1], 1e3 * seconds_per_frame[1],
                seconds_per_frame[1] / seconds_per_frame[0]);
}

// Bodies, joints and ground markers, in frames held whole by rank 0 (steps 0, 1) or dealt out
// over the ranks (step 2), and a frame without them (step 3).
TEST_F(OutputFileTest, WritesRigidBodiesJointsAndGround)
{
  OutputFile out;
  ASSERT_EQ(out.Open(PETSC_COMM_WORLD, h5_path().string(), false, "mechanism.yaml", "analysis: {type: dynamic}\n", IsRoot() ? MechanismMesh() : OutputMesh{},
                     kFingerprint, kRunId),
            PETSC_SUCCESS);
  for (int step = 0; step < 2; ++step) ASSERT_EQ(out.WriteFrame(IsRoot() ? MechanismFrame(step) : OutputFrame{}), PETSC_SUCCESS);
  ASSERT_EQ(out.WriteFrame(DistributedPart(MechanismFrame(2), WorldRank(), WorldSize())), PETSC_SUCCESS);
  OutputFrame bare = FrameOfStep(3);
  bare.velocity = bare.angular_velocity = Ramp(9, 0.0);
  ASSERT_EQ(out.WriteFrame(IsRoot() ? bare : OutputFrame{}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;

  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  using Shape           = std::vector<hsize_t>;
  const OutputMesh mesh = MechanismMesh();
  EXPECT_EQ(ReadStrings(file, "/mesh/body_names", &dims), mesh.body_names);
  EXPECT_EQ(ReadInts(file, "/mesh/body_node", &dims), mesh.body_node);
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_mass", &dims), mesh.body_mass);
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_inertia", &dims), mesh.body_inertia);
  EXPECT_EQ(dims, (Shape{2, 9}));
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_offset", &dims), mesh.body_offset);
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_principal_moments", &dims), mesh.body_principal_moments);
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_principal_axes", &dims), mesh.body_principal_axes);
  EXPECT_EQ(ReadDoubles(file, "/mesh/body_semi_axes", &dims), mesh.body_semi_axes);
  EXPECT_EQ(ReadInts(file, "/mesh/body_vertices", &dims), (std::vector<int>{0, 1}));
  EXPECT_EQ(ReadInts(file, "/mesh/joint_vertices", &dims), (std::vector<int>{0, 1}));
  EXPECT_EQ(ReadStrings(file, "/mesh/ground_names", &dims), mesh.ground_names);
  EXPECT_EQ(ReadStrings(file, "/mesh/ground_kinds", &dims), mesh.ground_kinds);
  EXPECT_EQ(ReadDoubles(file, "/mesh/ground_position", &dims), mesh.ground_position);
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_EQ(ReadDoubles(file, "/mesh/ground_a" + std::to_string(axis + 1), &dims), Part(mesh.ground_axes, axis)) << "ground axis " << axis + 1;
  EXPECT_EQ(ReadInts(file, "/frames/step", &dims), (std::vector<int>{0, 1, 2, 3}));
  // Bodies and joints in frames 0-2 (velocities in all, section triads in the distributed frame 2).
  EXPECT_EQ(ReadInts(file, "/frames/contents", &dims), (std::vector<int>{1 | 4 | 8, 1 | 4 | 8, 1 | 2 | 4 | 8, 1}));
  for (size_t step = 0; step < 3; ++step) {
    const OutputFrame expected = MechanismFrame((int)step);
    const std::string frame    = "frame " + std::to_string(step);
    EXPECT_EQ(ReadFrame(file, "body_center", step, &dims), expected.body_center) << frame;
    EXPECT_EQ(dims, (Shape{2, 3}));
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_EQ(ReadFrame(file, "body_axis_" + std::to_string(axis + 1), step, &dims), Part(expected.body_axes, axis)) << frame << " axis " << axis;
      EXPECT_EQ(ReadFrame(file, "joint_a" + std::to_string(axis + 1), step, &dims), Part(expected.joint_axes, axis)) << frame << " axis " << axis;
    }
    EXPECT_EQ(ReadFrame(file, "body_rotation", step, &dims), expected.body_rotation) << frame;
    EXPECT_EQ(dims, (Shape{2, 4}));
    EXPECT_EQ(ReadFrame(file, "joint_position", step, &dims), expected.joint_position) << frame;
    EXPECT_EQ(ReadFrame(file, "position", step, &dims), expected.position) << frame;
    EXPECT_EQ(ReadFrame(file, "velocity", step, &dims), expected.velocity) << frame;
  }
  EXPECT_EQ(ReadFrame(file, "body_center", 3, &dims), std::vector<double>(6, 0.0)) << "a frame without rigid-body rows holds zeros there";
  EXPECT_EQ(ReadFrame(file, "joint_position", 3, &dims), std::vector<double>(6, 0.0));
  EXPECT_GE(H5Fclose(file), 0);

  // The sidecar: four collections; bodies and joints in the first three frames, the ground in all.
  const std::string xdmf = ReadText(xdmf_path());
  std::string       why;
  EXPECT_TRUE(WellFormedXml(xdmf, &why)) << why;
  for (const char *kind : {"beams", "bodies", "joints", "ground"})
    EXPECT_NE(xdmf.find(std::string("Grid[@Name='") + kind + "']"), std::string::npos) << "no collection of " << kind;
  EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"beams\" GridType=\"Uniform\">"), 4u);
  EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"bodies\" GridType=\"Uniform\">"), 3u);
  EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"joints\" GridType=\"Uniform\">"), 3u);
  EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"ground\" GridType=\"Uniform\">"), 4u);
  for (const char *name : {"\"displacement [m]\"", "\"velocity [m/s]\"", "\"angular_velocity [rad/s]\"", "\"force [N]\"", "\"moment [N m]\"", "\"axis_1 [m]\"",
                           "\"mass [kg]\"", "\"semi_axes [m]\"", "\"a1\"", "\"rotation\"", "\"section_e1\""})
    EXPECT_NE(xdmf.find(std::string("Attribute Name=") + name), std::string::npos) << "no attribute " << name;
  EXPECT_NE(xdmf.find(">output.h5:/frames/body_axis_3|2 0 0:1 1 1:1 2 3:3 2 3<"), std::string::npos);
  EXPECT_NE(xdmf.find(">output.h5:/mesh/ground_position<"), std::string::npos);
}

// A model of rigid bodies alone (nodes, no beam elements): its beams grid has no cells, so the
// sidecar lists no cell arrays (empty data items, which were a third of such a sidecar), and the
// points and bodies keep every array; xdmf2 has no beams grid at all (ParaView's XDMF Reader
// rejects a topology without cells).
void WriteRigidBodiesAlone(const fs::path &h5_path, XdmfFlavour flavour)
{
  OutputMesh mesh = MechanismMesh();
  mesh.element_nodes.clear();
  mesh.element_order.clear();
  mesh.element_beam.clear();
  OutputFile out;
  out.SetXdmfFlavour(flavour);
  ASSERT_EQ(
      out.Open(PETSC_COMM_WORLD, h5_path.string(), false, "bodies.yaml", "analysis: {type: dynamic}\n", IsRoot() ? mesh : OutputMesh{}, kFingerprint, kRunId),
      PETSC_SUCCESS);
  for (int step = 0; step < 3; ++step) {
    OutputFrame frame        = MechanismFrame(step);
    frame.element_resultants = frame.element_strains = {};
    ASSERT_EQ(out.WriteFrame(IsRoot() ? frame : OutputFrame{}), PETSC_SUCCESS);
  }
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
}

TEST_F(OutputFileTest, SidecarOfRigidBodiesAloneHasNoCellArrays)
{
  for (XdmfFlavour flavour : {XdmfFlavour::Xdmf3, XdmfFlavour::Xdmf2}) {
    const bool xdmf3 = flavour == XdmfFlavour::Xdmf3;
    WriteRigidBodiesAlone(h5_path(), flavour);
    if (!IsRoot()) continue;
    const std::string xdmf = ReadText(xdmf_path());
    std::string       why;
    EXPECT_TRUE(WellFormedXml(xdmf, &why)) << why;
    EXPECT_EQ(CountOf(xdmf, "Center=\"Cell\""), 0u);
    EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"beams\" GridType=\"Uniform\">"), xdmf3 ? 3u : 0u);
    EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"bodies\" GridType=\"Uniform\">"), 3u);
    EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"joints\" GridType=\"Uniform\">"), 3u);
    for (const char *name : {"\"displacement [m]\"", "\"velocity [m/s]\"", "\"angular_velocity [rad/s]\""})
      EXPECT_EQ(CountOf(xdmf, std::string("Attribute Name=") + name), xdmf3 ? 3u : 0u) << name;
    EXPECT_EQ(CountOf(xdmf, "Attribute Name=\"axis_1 [m]\""), 3u) << "the bodies' axes";
    fs::remove(h5_path()), fs::remove(xdmf_path());
  }
}

// ---- Force elements ------------------------------------------------------------------------------

// The mechanism with three force elements: a bushing (tip, mid), a coordinate element on the
// hinge to the ground (a point at its slave, the tip, twice) and a spring-damper (root, tip).
OutputMesh ForceElementMesh()
{
  OutputMesh mesh          = MechanismMesh();
  mesh.force_element_names = {"mount", "motor", "strut"};
  mesh.force_element_kinds = {"bushing", "coordinate", "spring_damper"};
  mesh.force_element_nodes = {2, 1, 2, 2, 0, 2};
  return mesh;
}

// Frames 0 and 1 whole on rank 0, frame 2 dealt out over the ranks, a history row each; then
// (restart) the file reopened after frame 1 and frame 3 written.
void WriteMechanismRun(const fs::path &h5_path, XdmfFlavour flavour, const OutputMesh &mesh)
{
  {
    OutputFile out;
    out.SetXdmfFlavour(flavour);
    ASSERT_EQ(out.Open(PETSC_COMM_WORLD, h5_path.string(), false, "mechanism.yaml", "analysis: {type: dynamic}\n", IsRoot() ? mesh : OutputMesh{}, kFingerprint,
                       kRunId),
              PETSC_SUCCESS);
    for (int step = 0; step < 3; ++step) {
      ASSERT_EQ(out.WriteFrame(step < 2 ? (IsRoot() ? MechanismFrame(step) : OutputFrame{}) : DistributedPart(MechanismFrame(step), WorldRank(), WorldSize())),
                PETSC_SUCCESS);
      ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(step), {}), PETSC_SUCCESS);
    }
    ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  }
  OutputFile out;
  out.SetXdmfFlavour(flavour);
  ASSERT_EQ(out.Reopen(PETSC_COMM_WORLD, h5_path.string(), 1, 2, kRunId), PETSC_SUCCESS);
  ASSERT_EQ(out.WriteFrame(IsRoot() ? MechanismFrame(3) : OutputFrame{}), PETSC_SUCCESS);
  ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(3), {}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
}

// /mesh/force_element_* (names, kinds as text and codes, the segments' node indices), and a
// force_elements grid in every frame of the sidecar: the segments as 2-node polylines whose points
// are the nodes' positions of the frame (the beams' points), with the kind as a cell array; also
// after a restart, and in both syntaxes. A model without force elements has neither.
TEST_F(OutputFileTest, WritesForceElementsAsSegmentsBetweenNodes)
{
  for (XdmfFlavour flavour : {XdmfFlavour::Xdmf3, XdmfFlavour::Xdmf2}) {
    const bool xdmf3 = flavour == XdmfFlavour::Xdmf3;
    WriteMechanismRun(h5_path(), flavour, ForceElementMesh());
    if (IsRoot()) {
      const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      ASSERT_GE(file, 0);
      std::vector<hsize_t> dims;
      const OutputMesh     mesh = ForceElementMesh();
      EXPECT_EQ(ReadStrings(file, "/mesh/force_element_names", &dims), mesh.force_element_names);
      EXPECT_EQ(ReadStrings(file, "/mesh/force_element_kinds", &dims), mesh.force_element_kinds);
      EXPECT_EQ(ReadInts(file, "/mesh/force_element_kind_codes", &dims), (std::vector<int>{2, 0, 1}));
      EXPECT_EQ(dims, (std::vector<hsize_t>{3}));
      EXPECT_EQ(ReadInts(file, "/mesh/force_element_vertices", &dims), mesh.force_element_nodes);
      EXPECT_EQ(dims, (std::vector<hsize_t>{3, 2}));
      EXPECT_EQ(ReadInts(file, "/frames/step", &dims), (std::vector<int>{0, 1, 3}));
      for (const char *name : {"force_element_names", "force_element_kinds", "force_element_kind_codes", "force_element_vertices"}) {
        const std::string dataset = std::string("/mesh/") + name;
        EXPECT_EQ(ReadStringAttribute(file, dataset.c_str(), "unit"), DatasetQuantity("mesh", name, AnalysisType::Dynamic).unit) << name;
        EXPECT_FALSE(ReadStringAttribute(file, dataset.c_str(), "description").empty()) << name;
        EXPECT_EQ(DatasetQuantity("mesh", name, AnalysisType::Dynamic).description.find("unknown"), std::string::npos) << name;
      }
      EXPECT_GE(H5Fclose(file), 0);

      const std::string xdmf = ReadText(xdmf_path());
      std::string       why;
      EXPECT_TRUE(WellFormedXml(xdmf, &why)) << why;
      EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"force_elements\" GridType=\"Collection\" CollectionType=\"Temporal\">"), 1u);
      EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"force_elements\" GridType=\"Uniform\">"), 3u) << "one grid per frame, the restart's included";
      EXPECT_LT(xdmf.find("<Grid Name=\"ground\" GridType=\"Collection\""), xdmf.find("<Grid Name=\"force_elements\" GridType=\"Collection\""))
          << "the force elements come after the kinds before them";
      EXPECT_EQ(CountOf(xdmf, "<Topology TopologyType=\"Polyline\" NodesPerElement=\"2\" NumberOfElements=\"3\">\n        <DataItem Format=\"HDF\" "
                              "NumberType=\"Int\" Precision=\"4\" Dimensions=\"3 2\">output.h5:/mesh/force_element_vertices<"),
                xdmf3 ? 1u : 3u);
      EXPECT_EQ(CountOf(xdmf, ">output.h5:/mesh/force_element_vertices<"), xdmf3 ? 1u : 3u);
      EXPECT_EQ(CountOf(xdmf, "<Attribute Name=\"kind\" AttributeType=\"Scalar\" Center=\"Cell\">"), xdmf3 ? 1u : 3u);
      EXPECT_EQ(CountOf(xdmf, ">output.h5:/mesh/force_element_kind_codes<"), xdmf3 ? 1u : 3u);
      if (xdmf3) { // both grids of a frame take the nodes' positions as their points
        EXPECT_EQ(CountOf(xdmf, ">output.h5:/frames/position|2 0 0:1 1 1:1 3 3:3 3 3<"), 2u);
      } else { // the positions' hyperslab named once per frame, the geometry of both grids
        EXPECT_EQ(CountOf(xdmf, "Name=\"position_2\""), 1u);
        EXPECT_EQ(CountOf(xdmf, "/DataItem[@Name='position_2']"), 2u);
      }
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    if (IsRoot()) fs::remove(h5_path()), fs::remove(xdmf_path());
    MPI_Barrier(PETSC_COMM_WORLD);

    // Without force elements: no datasets, no grid.
    WriteMechanismRun(h5_path(), flavour, MechanismMesh());
    if (IsRoot()) {
      const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
      ASSERT_GE(file, 0);
      for (const char *name : {"/mesh/force_element_names", "/mesh/force_element_kinds", "/mesh/force_element_kind_codes", "/mesh/force_element_vertices"})
        EXPECT_EQ(H5Lexists(file, name, H5P_DEFAULT), 0) << name;
      EXPECT_GE(H5Fclose(file), 0);
      const std::string xdmf = ReadText(xdmf_path());
      EXPECT_EQ(xdmf.find("force_element"), std::string::npos);
      if (!xdmf3) EXPECT_EQ(CountOf(xdmf, "/DataItem[@Name='position_2']"), 1u);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    if (IsRoot()) fs::remove(h5_path()), fs::remove(xdmf_path());
    MPI_Barrier(PETSC_COMM_WORLD);
  }
}

// A rank's part of a frame with every table's rows in reverse order (segments following their
// elements), as a partition may hand them over.
OutputFrame Reversed(const OutputFrame &part)
{
  OutputFrame out            = part;
  const auto  reverse_blocks = [](std::vector<double> *values, size_t rows) {
    if (rows == 0) return;
    const size_t        width = values->size() / rows;
    std::vector<double> reversed;
    for (size_t r = rows; r-- > 0;) reversed.insert(reversed.end(), values->begin() + width * r, values->begin() + width * (r + 1));
    *values = reversed;
  };
  const size_t nodes = part.node_rows.size(), elements = part.element_rows.size(), bodies = part.body_rows.size(), joints = part.joint_rows.size();
  for (std::vector<double> *values : {&out.position, &out.displacement, &out.rotation, &out.velocity, &out.angular_velocity}) reverse_blocks(values, nodes);
  for (std::vector<double> *values : {&out.element_resultants, &out.element_strains}) reverse_blocks(values, elements);
  for (std::vector<double> *values : {&out.body_center, &out.body_axes, &out.body_rotation}) reverse_blocks(values, bodies);
  for (std::vector<double> *values : {&out.joint_position, &out.joint_axes}) reverse_blocks(values, joints);
  for (std::vector<int> *rows : {&out.node_rows, &out.element_rows, &out.element_first_segment, &out.element_segment_count, &out.body_rows, &out.joint_rows})
    std::reverse(rows->begin(), rows->end());
  // The triads, segment after segment of the elements in their new order.
  out.segment_triads.clear();
  size_t              first = 0;
  std::vector<size_t> first_triad; // of each element in the original order
  for (size_t k = 0; k < elements; ++k) first_triad.push_back(first), first += 9 * (size_t)part.element_segment_count[k];
  for (size_t k = elements; k-- > 0;)
    out.segment_triads.insert(out.segment_triads.end(), part.segment_triads.begin() + first_triad[k],
                              part.segment_triads.begin() + first_triad[k] + 9 * part.element_segment_count[k]);
  return out;
}

// Rows handed over in any order land in file order: two frames whose every table (nodes,
// elements and their segments, bodies, joints) comes in reverse order on each rank.
TEST_F(OutputFileTest, WritesRowsGivenInAnyOrder)
{
  OutputFile out;
  ASSERT_EQ(out.Open(PETSC_COMM_WORLD, h5_path().string(), false, "mechanism.yaml", "analysis: {type: dynamic}\n", IsRoot() ? MechanismMesh() : OutputMesh{},
                     kFingerprint, kRunId),
            PETSC_SUCCESS);
  for (int step = 0; step < 2; ++step) ASSERT_EQ(out.WriteFrame(Reversed(DistributedPart(MechanismFrame(step), WorldRank(), WorldSize()))), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  for (size_t step = 0; step < 2; ++step) {
    const OutputFrame expected = MechanismFrame((int)step);
    const std::string frame    = "frame " + std::to_string(step);
    EXPECT_EQ(ReadFrame(file, "position", step, &dims), expected.position) << frame;
    EXPECT_EQ(ReadFrame(file, "rotation", step, &dims), expected.rotation) << frame;
    EXPECT_EQ(ReadFrame(file, "velocity", step, &dims), expected.velocity) << frame;
    EXPECT_EQ(ReadFrame(file, "element_resultants", step, &dims), expected.element_resultants) << frame;
    EXPECT_EQ(ReadFrame(file, "element_strains", step, &dims), expected.element_strains) << frame;
    EXPECT_EQ(ReadFrame(file, "body_center", step, &dims), expected.body_center) << frame;
    EXPECT_EQ(ReadFrame(file, "joint_position", step, &dims), expected.joint_position) << frame;
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_EQ(ReadFrame(file, "body_axis_" + std::to_string(axis + 1), step, &dims), Part(expected.body_axes, axis)) << frame << " axis " << axis;
      EXPECT_EQ(ReadFrame(file, "joint_a" + std::to_string(axis + 1), step, &dims), Part(expected.joint_axes, axis)) << frame << " axis " << axis;
    }
    // Segments: elements 0 (segments 0, 1) and 1 (segment 2); each segment carries its element's
    // force, and its own triad (DistributedPart: 100 step + 10 segment + k).
    std::vector<double> force, e2;
    const int           element_of_segment[3] = {0, 0, 1};
    for (int segment = 0; segment < 3; ++segment) {
      const int e = element_of_segment[segment];
      force.insert(force.end(), &expected.element_resultants[6 * e], &expected.element_resultants[6 * e + 3]);
      for (int k = 3; k < 6; ++k) e2.push_back(100.0 * (double)step + 10.0 * segment + k);
    }
    EXPECT_EQ(ReadFrame(file, "segment_force", step, &dims), force) << frame;
    EXPECT_EQ(ReadFrame(file, "segment_e2", step, &dims), e2) << frame;
  }
  EXPECT_GE(H5Fclose(file), 0);
}

// Every dataset carries a unit and a description; the units follow the table in output_units.cpp.
TEST_F(OutputFileTest, EveryDatasetHasAUnitAndADescription)
{
  OutputFile out;
  ASSERT_EQ(out.Open(PETSC_COMM_WORLD, h5_path().string(), false, "mechanism.yaml", "analysis: {type: dynamic}\n", IsRoot() ? ForceElementMesh() : OutputMesh{},
                     kFingerprint, kRunId),
            PETSC_SUCCESS);
  ASSERT_EQ(out.WriteFrame(DistributedPart(MechanismFrame(0), WorldRank(), WorldSize())), PETSC_SUCCESS);
  const std::vector<std::string> names = {"time",          "kinetic_energy", "linear_momentum_x", "angular_momentum_z", "hinge.rx",
                                          "hinge.rx_rate", "slider.tx",      "slider.force_y",    "slider.moment_z",    "residual_norm"};
  ASSERT_EQ(out.AppendHistory(names, Ramp(names.size(), 0.0), {ProbeOfRow(0)}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  // Every dataset in the file, by H5Ovisit.
  std::vector<std::string> datasets;
  const auto               visit = [](hid_t, const char *name, const H5O_info_t *info, void *found) -> herr_t {
    if (info->type == H5O_TYPE_DATASET) static_cast<std::vector<std::string> *>(found)->push_back(std::string("/") + name);
    return 0;
  };
  ASSERT_GE(H5Ovisit(file, H5_INDEX_NAME, H5_ITER_INC, visit, &datasets), 0);
  EXPECT_GT(datasets.size(), 50u);
  for (const std::string &dataset : datasets) {
    EXPECT_GT(H5Aexists_by_name(file, dataset.c_str(), "unit", H5P_DEFAULT), 0) << dataset << " has no unit";
    EXPECT_FALSE(ReadStringAttribute(file, dataset, "description").empty()) << dataset << " has no description";
  }
  const std::pair<const char *, const char *> units[] = {
      {"/history/values", "mixed"},
      {"/history/names", ""},
      {"/mesh/node_coordinates", "m"},
      {"/mesh/body_inertia", "kg m^2"},
      {"/mesh/body_mass", "kg"},
      {"/mesh/node_names", ""},
      {"/frames/step", "1"},
      {"/frames/time", "s"},
      {"/frames/contents", "1"},
      {"/frames/position", "m"},
      {"/frames/velocity", "m/s"},
      {"/frames/angular_velocity", "rad/s"},
      {"/frames/element_resultants", "N, N, N, N m, N m, N m"},
      {"/frames/segment_moment", "N m"},
      {"/frames/body_axis_1", "m"},
      {"/frames/joint_a2", "1"},
      {"/mesh/force_element_vertices", "1"},
      {"/mesh/force_element_kinds", ""},
      {"/input", ""},
  };
  for (const auto &[dataset, unit] : units) EXPECT_EQ(ReadStringAttribute(file, dataset, "unit"), unit) << dataset;
  // Every column of the history table has its unit and a description.
  const std::pair<const char *, const char *> series_units[] = {
      {"time", "s"},
      {"kinetic_energy", "J"},
      {"linear_momentum_x", "kg m/s"},
      {"angular_momentum_z", "kg m^2/s"},
      {"hinge.rx", "rad"},
      {"hinge.rx_rate", "rad/s"},
      {"slider.tx", "m"},
      {"slider.force_y", "N"},
      {"slider.moment_z", "N m"},
      {"residual_norm", "mixed"},
      {"tip.position.x", "m"},
      {"tip.rotation.w", "1"},
      {"tip.rotation_angle", "rad"},
  };
  for (const auto &[series, unit] : series_units) EXPECT_EQ(SeriesQuantity(file, series, "units"), unit) << series;
  const std::vector<std::string> columns = HistoryColumns(file), units_of_columns = HistoryColumns(file, "/history/units"),
                                 descriptions = HistoryColumns(file, "/history/descriptions");
  EXPECT_EQ(units_of_columns.size(), columns.size());
  ASSERT_EQ(descriptions.size(), columns.size());
  for (size_t k = 0; k < columns.size(); ++k) EXPECT_FALSE(descriptions[k].empty()) << columns[k] << " has no description";
  EXPECT_EQ(SeriesQuantity(file, "tip.position.y", "descriptions"),
            "probe tip: current position of the probed point (node, its offset point or a rigid body's centre of mass), y");
  EXPECT_GE(H5Fclose(file), 0);
}

TEST_F(OutputFileTest, StaticHistoryTimeIsTheDimensionlessLoadFactor)
{
  OutputFile out;
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  const std::vector<std::string> names = {"time", "step_size", "j.tx_rate"};
  ASSERT_EQ(out.AppendHistory(names, {0.0, 0.0, 0.0}, {}), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  EXPECT_EQ(SeriesQuantity(file, "time", "units"), "1");
  EXPECT_NE(SeriesQuantity(file, "time", "descriptions").find("load factor"), std::string::npos);
  EXPECT_EQ(SeriesQuantity(file, "step_size", "units"), "1");
  EXPECT_EQ(SeriesQuantity(file, "j.tx_rate", "units"), "m");
  EXPECT_EQ(ReadStringAttribute(file, "/", "analysis_type"), "static");
  EXPECT_GE(H5Fclose(file), 0);
}

TEST_F(OutputFileTest, RootAttributesRecordProvenance)
{
  OutputFile out;
  ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  EXPECT_EQ(ReadStringAttribute(file, "/", "msflex_version"), MSFLEX_VERSION);
  EXPECT_EQ(ReadStringAttribute(file, "/", "git_hash"), MSFLEX_GIT_HASH);
  EXPECT_FALSE(ReadStringAttribute(file, "/", "git_hash").empty());
  EXPECT_NE(ReadStringAttribute(file, "/", "command_line").find("test_output_file"), std::string::npos);
  EXPECT_GT(H5Aexists(file, "options"), 0);
  EXPECT_EQ(ReadAttribute<int>(file, "/", "ranks", H5T_NATIVE_INT), WorldSize());
  // ISO 8601, UTC: 2024-05-01T12:34:56Z, and within a minute of now.
  const std::string start = ReadStringAttribute(file, "/", "start_time");
  ASSERT_EQ(start.size(), 20u) << start;
  EXPECT_TRUE(start[4] == '-' && start[7] == '-' && start[10] == 'T' && start[13] == ':' && start[16] == ':' && start[19] == 'Z') << start;
  std::tm written{};
  ASSERT_NE(strptime(start.c_str(), "%Y-%m-%dT%H:%M:%SZ", &written), nullptr) << start;
  EXPECT_LT(std::fabs(std::difftime(timegm(&written), std::time(nullptr))), 60.0) << start;
  EXPECT_GE(H5Fclose(file), 0);
}

// A restart: the rows up to the checkpoint are kept, buffering goes on after them.
TEST_F(OutputFileTest, ReopenKeepsTheCheckpointedRowsAndFramesAndGoesOn)
{
  {
    OutputFile out;
    out.SetFlushInterval(1e9);
    ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
    for (int row = 0; row < 15; ++row) {
      if (row == 0 || row == 5 || row == 12) {
        ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(row) : OutputFrame{}), PETSC_SUCCESS);
      }
      ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(row), {ProbeOfRow(row)}), PETSC_SUCCESS);
      if (row == 9) { // the checkpoint: step 9, 10 rows, last frame 5
        ASSERT_EQ(out.Flush(), PETSC_SUCCESS);
      }
    }
    ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  }
  OutputFile out;
  ASSERT_EQ(out.Reopen(PETSC_COMM_WORLD, h5_path().string(), 5, 10, kRunId), PETSC_SUCCESS);
  EXPECT_EQ(out.HistoryRows(), 10);
  for (int row = 10; row < 13; ++row) {
    if (row == 11) {
      ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(row) : OutputFrame{}), PETSC_SUCCESS);
    }
    ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(100 + row), {ProbeOfRow(100 + row)}), PETSC_SUCCESS);
  }
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (!IsRoot()) return;
  const hid_t file = H5Fopen(h5_path().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  std::vector<hsize_t> dims;
  std::vector<double>  expected;
  for (int row = 0; row < 13; ++row) expected.push_back(HistoryRow(row < 10 ? row : 100 + row)[2]);
  EXPECT_EQ(ReadSeries(file, "newton_iterations", &dims), expected);
  EXPECT_EQ(ReadProbe(file, "tip", "rotation_angle", &dims).size(), 13u);
  EXPECT_EQ(ReadInts(file, "/frames/step", &dims), (std::vector<int>{0, 5, 11})) << "the frame after the checkpoint (12) is dropped";
  EXPECT_EQ(ReadFrame(file, "position", 2, &dims), FrameOfStep(11).position);
  ReadDoubles(file, "/frames/element_strains", &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{3, 2, 6})) << "every frame dataset holds the kept frames";
  EXPECT_EQ(SeriesQuantity(file, "time", "units"), "1");
  EXPECT_GE(H5Fclose(file), 0);
  const std::string xdmf = ReadText(xdmf_path());
  std::string       why;
  EXPECT_TRUE(WellFormedXml(xdmf, &why)) << why;
  EXPECT_EQ(CountOf(xdmf, "<Grid Name=\"beams\" GridType=\"Uniform\">"), 3u);
  EXPECT_EQ(xdmf.find("<Time Value=\"3\"/>"), std::string::npos) << "the dropped frame (t = 3) is not listed";
}

// A history column is found by its name: the same name twice is refused; a restarted file goes on
// with the columns it holds, and a run that writes others is refused at its first flush.
TEST_F(OutputFileTest, HistoryColumnsAreUniqueAndARestartKeepsThem)
{
  const auto failure = [](PetscErrorCode status) {
    char *message = nullptr;
    PetscErrorMessage(status, nullptr, &message);
    return std::string(message ? message : "");
  };
  {
    OutputFile out;
    ASSERT_EQ(OpenTiny(&out, false), PETSC_SUCCESS);
    ProbeSample probe = ProbeOfRow(0);
    probe.name        = "j";
    EXPECT_EQ(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr), PETSC_SUCCESS);
    const PetscErrorCode twice = out.AppendHistory({"time", "step", "step"}, {0.0, 0.0, 0.0}, {});
    EXPECT_NE(twice, PETSC_SUCCESS);
    EXPECT_NE(failure(twice).find("two history series are named 'step'"), std::string::npos) << failure(twice);
    // A series named like a probe's column.
    const PetscErrorCode clash = out.AppendHistory({"time", "j.position.x"}, {0.0, 0.0}, {probe});
    EXPECT_NE(clash, PETSC_SUCCESS);
    EXPECT_NE(failure(clash).find("two history series are named 'j.position.x'"), std::string::npos) << failure(clash);
    EXPECT_EQ(PetscPopErrorHandler(), PETSC_SUCCESS);
    ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(0), {ProbeOfRow(0)}), PETSC_SUCCESS);
    ASSERT_EQ(out.WriteFrame(IsRoot() ? FrameOfStep(0) : OutputFrame{}), PETSC_SUCCESS);
    ASSERT_EQ(out.AppendHistory(kHistoryNames, HistoryRow(1), {ProbeOfRow(1)}), PETSC_SUCCESS);
    ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  }
  OutputFile out;
  ASSERT_EQ(out.Reopen(PETSC_COMM_WORLD, h5_path().string(), 0, 1, kRunId), PETSC_SUCCESS);
  std::vector<std::string> other = kHistoryNames;
  other.back() += "_renamed";
  // Refused at the first row, before anything of it is written: the file keeps its row.
  EXPECT_EQ(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr), PETSC_SUCCESS);
  const PetscErrorCode appended = out.AppendHistory(other, HistoryRow(1), {ProbeOfRow(1)});
  EXPECT_EQ(PetscPopErrorHandler(), PETSC_SUCCESS);
  EXPECT_NE(appended, PETSC_SUCCESS);
  const std::string expected = "its history has " + std::to_string(kHistoryNames.size() + kProbeColumns) + " columns, this run writes " +
                               std::to_string(kHistoryNames.size() + kProbeColumns) + "; the first that differs is column " +
                               std::to_string(kHistoryNames.size() - 1) + " ('" + kHistoryNames.back() + "' in the file, '" + other.back() + "' now)";
  EXPECT_NE(failure(appended).find(expected), std::string::npos) << failure(appended);
  ASSERT_EQ(out.Close(), PETSC_SUCCESS);
  if (IsRoot()) EXPECT_EQ(RowsOnDisk(h5_path(), "/history/values"), 1);
}

} // namespace
} // namespace msflex
