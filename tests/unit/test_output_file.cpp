// OutputFile round trip: writes a tiny mesh, two frames and three history rows, then reads the
// file back with the HDF5 C API. Runs on any number of ranks: as in the solver, only rank 0 passes
// data, and only rank 0 reads the file back.
#include "output/output_file.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace msflex {
namespace {

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
    return out->Open(PETSC_COMM_WORLD, h5_path().string(), overwrite, "tiny.yaml", "analysis: {type: static}\n", IsRoot() ? TinyMesh() : OutputMesh{});
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
  const hid_t string_type = CreateUtf8StringType();
  char       *input_file  = ReadAttribute<char *>(file, "/input", "file", string_type);
  EXPECT_STREQ(input_file, "tiny.yaml");
  H5free_memory(input_file);
  H5Tclose(string_type);

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

  for (const int step : kFrameSteps) {
    const OutputFrame expected = FrameOfStep(step);
    const std::string group    = step == 0 ? "/frames/000000" : "/frames/000003";
    EXPECT_EQ(ReadAttribute<int>(file, group, "step", H5T_NATIVE_INT), step);
    EXPECT_EQ(ReadAttribute<double>(file, group, "time", H5T_NATIVE_DOUBLE), FrameTime(step));
    EXPECT_EQ(ReadDoubles(file, group + "/position", &dims), expected.position);
    EXPECT_EQ(dims, (Shape{3, 3}));
    EXPECT_EQ(ReadDoubles(file, group + "/displacement", &dims), expected.displacement);
    EXPECT_EQ(ReadDoubles(file, group + "/rotation", &dims), expected.rotation);
    EXPECT_EQ(dims, (Shape{3, 4}));
    EXPECT_EQ(ReadDoubles(file, group + "/element_resultants", &dims), expected.element_resultants);
    EXPECT_EQ(dims, (Shape{2, 6}));
    EXPECT_EQ(ReadDoubles(file, group + "/element_strains", &dims), expected.element_strains);
    // Segments 0 and 1 belong to element 0, segment 2 to element 1.
    const std::vector<double> &r = expected.element_resultants;
    EXPECT_EQ(ReadDoubles(file, group + "/segment_force", &dims), (std::vector<double>{r[0], r[1], r[2], r[0], r[1], r[2], r[6], r[7], r[8]}));
    EXPECT_EQ(dims, (Shape{3, 3}));
    EXPECT_EQ(ReadDoubles(file, group + "/segment_moment", &dims), (std::vector<double>{r[3], r[4], r[5], r[3], r[4], r[5], r[9], r[10], r[11]}));
  }

  for (size_t i = 0; i < kHistoryNames.size(); ++i) {
    std::vector<double> expected;
    for (int row = 0; row < kHistoryRows; ++row) expected.push_back(HistoryRow(row)[i]);
    EXPECT_EQ(ReadDoubles(file, "/history/" + kHistoryNames[i], &dims), expected) << kHistoryNames[i];
    EXPECT_EQ(dims, Shape{kHistoryRows});
  }
  EXPECT_EQ(ReadDoubles(file, "/probes/tip/position", &dims), (std::vector<double>{0, 0.25, 0.5, 1, 1.25, 1.5, 2, 2.25, 2.5}));
  EXPECT_EQ(dims, (Shape{kHistoryRows, 3}));
  EXPECT_EQ(ReadDoubles(file, "/probes/tip/displacement", &dims), (std::vector<double>{0, 0, 0, -1, 0, 0, -2, 0, 0}));
  EXPECT_EQ(ReadDoubles(file, "/probes/tip/rotation", &dims), (std::vector<double>{1, 0, 0, 0, 1, 0, 0, 0.1, 1, 0, 0, 0.2}));
  EXPECT_EQ(dims, (Shape{kHistoryRows, 4}));
  EXPECT_EQ(ReadDoubles(file, "/probes/tip/rotation_angle", &dims), (std::vector<double>{0, 0.2, 0.4}));
  EXPECT_EQ(dims, Shape{kHistoryRows});
  EXPECT_GE(H5Fclose(file), 0);

  ASSERT_TRUE(fs::exists(xdmf_path()));
  const std::string xdmf = ReadText(xdmf_path());
  EXPECT_NE(xdmf.find("CollectionType=\"Temporal\""), std::string::npos);
  for (const char *expected : {"<Time Value=\"0\"/>", "<Time Value=\"0.75\"/>", ">output.h5:/frames/000000/position<", ">output.h5:/frames/000003/position<",
                               ">output.h5:/frames/000003/segment_force<", ">output.h5:/mesh/segments<"})
    EXPECT_NE(xdmf.find(expected), std::string::npos) << "sidecar lacks " << expected << ":\n" << xdmf;
  EXPECT_EQ(xdmf.find(directory_.string()), std::string::npos) << "the sidecar must refer to the .h5 by its relative name";
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

} // namespace
} // namespace msflex
