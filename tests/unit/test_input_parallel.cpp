// Reading a model with an HDF5 mesh on several ranks (ReadModelFile's communicator): each rank
// reads a slice of every dataset's rows and the slices are shared. The model must be exactly the
// one a single reader gets, including uneven slices and ranks with no rows, variable- and
// fixed-length strings; a broken mesh fails on every rank with the same message, without a hang.
#include "io/input_reader.hpp"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <mpi.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace msflex;

namespace {

int Rank()
{
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}

// Writes a 1-D or 2-D dataset of `type` from `data` (creating the groups on the way).
void WriteDataset(hid_t file, const char *name, hid_t type, std::vector<hsize_t> dims, const void *data)
{
  const hid_t links = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(links, 1);
  const hid_t space   = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t dataset = H5Dcreate2(file, name, type, space, links, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(dataset, 0) << name;
  ASSERT_GE(H5Dwrite(dataset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), 0) << name;
  H5Dclose(dataset);
  H5Sclose(space);
  H5Pclose(links);
}

// A chain of 7 mesh nodes: 5 beams (of 1-2 elements, one quadratic), 2 joints; node names are
// variable-length strings, beam names fixed-length ones. `with_sections`: false leaves out
// /beams/section to make the mesh invalid.
void WriteChainMesh(const std::filesystem::path &path, bool with_sections)
{
  const hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const std::vector<double> coordinates = {0, 0, 0, 1, 0, 0, 2, 0.5, 0, 2, 0.5, 0, 3, 1, 0.2, 4, 1, 0.4, 4, 1, 0.4};
  WriteDataset(file, "/nodes/coordinates", H5T_NATIVE_DOUBLE, {7, 3}, coordinates.data());
  const std::vector<std::string> node_names = {"a", "bb", "ccc", "d", "eeeee", "f", "gg"};
  std::vector<const char *>      pointers;
  for (const std::string &name : node_names) pointers.push_back(name.c_str());
  const hid_t variable = H5Tcopy(H5T_C_S1);
  H5Tset_size(variable, H5T_VARIABLE);
  WriteDataset(file, "/nodes/names", variable, {7}, pointers.data());
  const std::vector<long long> beam_nodes = {0, 1, 1, 2, 3, 4, 4, 5, 0, 4};
  WriteDataset(file, "/beams/nodes", H5T_NATIVE_LLONG, {5, 2}, beam_nodes.data());
  const std::vector<long long> sections = {0, 0, 0, 0, 0}, elements = {2, 1, 2, 1, 3}, orders = {1, 2, 1, 1, 1};
  if (with_sections) WriteDataset(file, "/beams/section", H5T_NATIVE_LLONG, {5}, sections.data());
  WriteDataset(file, "/beams/elements", H5T_NATIVE_LLONG, {5}, elements.data());
  WriteDataset(file, "/beams/order", H5T_NATIVE_LLONG, {5}, orders.data());
  const hid_t fixed = H5Tcopy(H5T_C_S1);
  H5Tset_size(fixed, 6);
  const char beam_names[5][6] = {"one", "two", "three", "four", "five"};
  WriteDataset(file, "/beams/names", fixed, {5}, beam_names);
  pointers = {"revolute", "spherical"};
  WriteDataset(file, "/joints/type", variable, {2}, pointers.data());
  const std::vector<long long> masters = {2, 5}, slaves = {3, 6};
  WriteDataset(file, "/joints/master", H5T_NATIVE_LLONG, {2}, masters.data());
  WriteDataset(file, "/joints/slave", H5T_NATIVE_LLONG, {2}, slaves.data());
  const std::vector<double> axes = {0, 0, 1, 1, 0, 0}, parameters = {0, 0};
  WriteDataset(file, "/joints/axis", H5T_NATIVE_DOUBLE, {2, 3}, axes.data());
  WriteDataset(file, "/joints/parameter", H5T_NATIVE_DOUBLE, {2}, parameters.data());
  H5Tclose(variable);
  H5Tclose(fixed);
  H5Fclose(file);
}

const char *const kModel = R"(sections:
  - {name: s, EA: 1.0e7, GA2: 4.0e6, GA3: 4.0e6, GJ: 8.0e5, EI2: 8.0e5, EI3: 8.0e5, rhoA: 7.8, rhoJ: [0.1, 0.05, 0.05]}
mesh: chain.h5
supports:
  - {nodes: a, fix: all}
probes:
  - {name: end, node: gg}
analysis: {type: dynamic}
)";

// Writes the YAML file and the mesh (rank 0) into a directory every rank sees, named after rank
// 0's process: ctest runs this test on 1, 2 and 3 ranks at once, and HDF5 refuses to open a mesh
// another run is writing.
std::filesystem::path WriteCase(bool valid_mesh)
{
  long process = (long)getpid();
  MPI_Bcast(&process, 1, MPI_LONG, 0, MPI_COMM_WORLD);
  const std::filesystem::path directory =
      std::filesystem::temp_directory_path() / ("msflex_input_parallel_" + std::to_string(process) + "_" + std::to_string(valid_mesh));
  if (Rank() == 0) {
    std::filesystem::create_directories(directory);
    WriteChainMesh(directory / "chain.h5", valid_mesh);
    std::ofstream(directory / "model.yaml") << kModel;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return directory / "model.yaml";
}

// A case's directory, removed when the test ends (after every rank is done with it).
struct CaseFiles {
  std::filesystem::path input;
  explicit CaseFiles(bool valid_mesh) : input(WriteCase(valid_mesh)) {}
  ~CaseFiles()
  {
    MPI_Barrier(MPI_COMM_WORLD);
    std::error_code ignored;
    if (Rank() == 0) std::filesystem::remove_all(input.parent_path(), ignored);
  }
};

TEST(InputParallel, SlicedReadGivesTheSingleReaderModel)
{
  const CaseFiles             files(true);
  const std::filesystem::path input = files.input;
  Model                       alone, together;
  InputError                  error;
  ASSERT_TRUE(ReadModelFile(input.string(), &alone, &error, MPI_COMM_SELF)) << error.Format();
  ASSERT_TRUE(ReadModelFile(input.string(), &together, &error, MPI_COMM_WORLD)) << error.Format();
  ASSERT_EQ(together.nodes.size(), alone.nodes.size());
  ASSERT_GT(alone.nodes.size(), 7u); // the mesh nodes and those generated inside the beams
  for (size_t node = 0; node < alone.nodes.size(); ++node) {
    EXPECT_EQ(together.nodes[node].name, alone.nodes[node].name);
    EXPECT_EQ(together.nodes[node].position, alone.nodes[node].position); // bit for bit
  }
  EXPECT_EQ(alone.nodes[4].name, "eeeee");
  ASSERT_EQ(together.beams.size(), 5u);
  for (size_t beam = 0; beam < alone.beams.size(); ++beam) {
    EXPECT_EQ(together.beams[beam].name, alone.beams[beam].name);
    EXPECT_EQ(together.beams[beam].nodes, alone.beams[beam].nodes);
  }
  EXPECT_EQ(alone.beams[2].name, "three");
  ASSERT_EQ(together.elements.size(), alone.elements.size());
  for (size_t element = 0; element < alone.elements.size(); ++element) {
    EXPECT_EQ(together.elements[element].nodes, alone.elements[element].nodes);
    EXPECT_EQ(together.elements[element].order, alone.elements[element].order);
    for (int a = 0; a <= alone.elements[element].order; ++a)
      EXPECT_EQ(together.elements[element].reference_triads[a], alone.elements[element].reference_triads[a]);
  }
  ASSERT_EQ(together.joints.size(), 2u);
  for (size_t joint = 0; joint < 2; ++joint) {
    EXPECT_EQ(together.joints[joint].kind, alone.joints[joint].kind);
    EXPECT_EQ(together.joints[joint].master, alone.joints[joint].master);
    EXPECT_EQ(together.joints[joint].slave, alone.joints[joint].slave);
    EXPECT_EQ(together.joints[joint].axes, alone.joints[joint].axes);
  }
  EXPECT_EQ(together.joints[1].kind, JointKind::Spherical);
  EXPECT_EQ(together.input_text, alone.input_text); // rank 0's text reached every rank
  ASSERT_EQ(together.probes.size(), 1u);
  EXPECT_EQ(together.probes[0].node, alone.probes[0].node);
}

TEST(InputParallel, BrokenMeshFailsTheSameEverywhere)
{
  const CaseFiles             files(false);
  const std::filesystem::path input = files.input;
  Model                       model;
  InputError                  error;
  ASSERT_FALSE(ReadModelFile(input.string(), &model, &error, MPI_COMM_WORLD));
  EXPECT_NE(error.message.find("chain.h5: /beams/section: missing dataset"), std::string::npos) << error.Format();
  EXPECT_EQ(error.line, 3); // the `mesh:` key
  // Every rank holds the same message.
  int length = static_cast<int>(error.message.size()), shortest = 0, longest = 0;
  MPI_Allreduce(&length, &shortest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(&length, &longest, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_EQ(shortest, longest);
  // A missing input file is reported by rank 0 to all.
  ASSERT_FALSE(ReadModelFile((input.parent_path() / "absent.yaml").string(), &model, &error, MPI_COMM_WORLD));
  EXPECT_NE(error.message.find("cannot open input file"), std::string::npos) << error.Format();
}

} // namespace

int main(int argc, char **argv)
{
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  if (Rank() != 0) {
    ::testing::TestEventListeners &listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  const int failed     = RUN_ALL_TESTS();
  int       any_failed = 0;
  MPI_Allreduce(&failed, &any_failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any_failed;
}
