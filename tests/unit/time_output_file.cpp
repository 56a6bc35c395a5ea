// Output cost per frame, for runs of different lengths: writes F frames of a 101-node beam with
// one history row (26 series and two probes) per step and a frame every `every` steps, and prints
// the wall time per frame and per history row for each F. A writer whose cost per frame grows
// with the number of frames already written (a sidecar rewritten whole, say) shows as a time per
// frame that grows with F. Not a test (nothing is asserted); run by hand:
//   build/tests/time_output_file [-frames 10,1000] [-every 1] [-dir /tmp]
#include "output/output_file.hpp"

#include <petscsys.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

using namespace msflex;

namespace {

constexpr int kNodes = 101;

OutputMesh BeamMesh()
{
  OutputMesh mesh;
  for (int i = 0; i < kNodes; ++i) {
    mesh.node_coordinates.insert(mesh.node_coordinates.end(), {0.1 * i, 0.0, 0.0});
    mesh.node_names.push_back("beam." + std::to_string(i));
  }
  for (int e = 0; e + 1 < kNodes; ++e) {
    mesh.element_nodes.insert(mesh.element_nodes.end(), {e, e + 1, -1});
    mesh.element_order.push_back(1);
    mesh.element_beam.push_back(0);
  }
  mesh.beam_names = {"beam"};
  return mesh;
}

OutputFrame Frame(int step, bool root)
{
  OutputFrame frame;
  frame.step = step;
  frame.time = 0.01 * step;
  if (!root) return frame;
  const int n_elements = kNodes - 1;
  frame.position.assign(3 * kNodes, 0.001 * step);
  frame.displacement.assign(3 * kNodes, 0.002 * step);
  frame.rotation.assign(4 * kNodes, 0.5);
  frame.velocity.assign(3 * kNodes, 1.0);
  frame.angular_velocity.assign(3 * kNodes, 2.0);
  frame.element_resultants.assign(6 * n_elements, 3.0);
  frame.element_strains.assign(6 * n_elements, 4.0);
  return frame;
}

// The series of a dynamic run's history row.
std::vector<std::string> HistoryNames()
{
  return {"time",
          "step",
          "step_size",
          "newton_iterations",
          "residual_norm",
          "strain_energy",
          "kinetic_energy",
          "total_energy",
          "external_work",
          "energy_balance",
          "linear_momentum_x",
          "linear_momentum_y",
          "linear_momentum_z",
          "angular_momentum_x",
          "angular_momentum_y",
          "angular_momentum_z",
          "energy_correction",
          "j.tx",
          "j.rx",
          "j.tx_rate",
          "j.rx_rate",
          "j.force_x",
          "j.force_y",
          "j.force_z",
          "j.moment_x",
          "j.moment_y"};
}

PetscErrorCode TimeRun(const std::string &path, int frames, int every, double *seconds_per_frame, double *seconds_per_row)
{
  PetscMPIInt rank;
  OutputFile  out;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  const std::vector<std::string> names = HistoryNames();
  // Markers as a run writes them (a fixed fingerprint and run id: the file is thrown away).
  PetscCall(out.Open(PETSC_COMM_WORLD, path, true, "bench.yaml", "bench", rank == 0 ? BeamMesh() : OutputMesh{}, "sha256:" + std::string(64, '0'),
                     std::string(32, 'b')));
  double frame_time = 0.0, row_time = 0.0;
  int    rows = 0;
  for (int step = 0; step < frames * every; ++step) {
    std::vector<double> values(names.size(), 0.5 * step);
    values[0] = 0.01 * step;
    std::vector<ProbeSample> probes(2);
    probes[0].name = "A", probes[1].name = "B";
    double start = MPI_Wtime();
    PetscCall(out.AppendHistory(names, values, probes));
    row_time += MPI_Wtime() - start;
    ++rows;
    if (step % every == 0) {
      const OutputFrame frame = Frame(step, rank == 0);
      start                   = MPI_Wtime();
      PetscCall(out.WriteFrame(frame));
      frame_time += MPI_Wtime() - start;
    }
  }
  const double start = MPI_Wtime();
  PetscCall(out.Close());
  frame_time += MPI_Wtime() - start; // what Close still has to write belongs to the frames
  *seconds_per_frame = frame_time / frames;
  *seconds_per_row   = row_time / rows;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  char      frames_text[256] = "10,1000", directory[PETSC_MAX_PATH_LEN] = "";
  PetscInt  every = 1;
  PetscBool found;
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-frames", frames_text, sizeof frames_text, &found));
  PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-every", &every, &found));
  PetscCall(PetscOptionsGetString(nullptr, nullptr, "-dir", directory, sizeof directory, &found));
  long id = getpid();
  MPI_Bcast(&id, 1, MPI_LONG, 0, PETSC_COMM_WORLD);
  const std::string base = std::string(found ? directory : std::filesystem::temp_directory_path().c_str()) + "/msflex_time_output_" + std::to_string(id);
  std::stringstream list(frames_text);
  std::string       item;
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%8s %6s %18s %18s\n", "frames", "every", "ms per frame", "ms per history row"));
  while (std::getline(list, item, ',')) {
    const int frames    = std::stoi(item);
    double    per_frame = 0, per_row = 0;
    PetscCall(TimeRun(base + ".h5", frames, (int)every, &per_frame, &per_row));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%8d %6d %18.4f %18.4f\n", frames, (int)every, 1e3 * per_frame, 1e3 * per_row));
  }
  PetscMPIInt rank;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  if (rank == 0) {
    std::filesystem::remove(base + ".h5");
    std::filesystem::remove(base + ".xmf");
  }
  PetscCall(PetscFinalize());
  return 0;
}
