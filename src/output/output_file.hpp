// The msflex HDF5 result file and its XDMF sidecar (layout: docs/output.md).
//
// All calls are collective over the communicator given to Open. The file is open on every rank
// (MPI-IO, parallel HDF5) and frames are written collectively: each rank writes the node and
// element rows it holds (OutputFrame::distributed) or, for a frame that is not distributed, rank 0
// writes every row and the arrays passed on other ranks are ignored. The mesh, /input, history and
// probes are taken from rank 0 (other ranks may pass empty arrays); after Open no rank keeps any
// per-node or per-element table.
//
// Cost and safety: history rows and frames are kept in memory and written in blocks, every series
// and frame dataset extended once per block. Flush writes the buffered rows and frames, makes the
// file consistent on disk (H5Fflush) and appends the frames written since the last flush to the
// XDMF sidecar (constant cost per frame; the sidecar is a complete XDMF file at every moment and
// lists only flushed frames). Flushes happen at Close, when Flush is called (checkpoints), and,
// from WriteFrame and AppendHistory, once `flush_interval` seconds of wall time have passed since
// the last one: a killed run loses at most that much of its results.
#pragma once

#include <petscsys.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace msflex {

// The syntax of the XDMF sidecar's per-frame data items (docs/output.md): `Xdmf3` selects a
// frame's rows of a /frames dataset with the `file.h5:/path|start:stride:count:dims` form that
// ParaView's Xdmf3 readers (its default for .xmf) read; `Xdmf2` with HyperSlab data items, which
// ParaView's "XDMF Reader" and VisIt read. Neither reader reads the other's form.
enum class XdmfFlavour { Xdmf3, Xdmf2 };

struct OutputMesh {
  std::vector<double>      node_coordinates; // n_nodes * 3, reference positions
  std::vector<std::string> node_names;       // n_nodes
  std::vector<int>         element_nodes;    // n_elements * 3, 0-based node indices, -1 padded (2-node elements)
  std::vector<int>         element_order;    // n_elements: 1 (2 nodes) or 2 (3 nodes, middle node second)
  std::vector<int>         element_beam;     // n_elements: index into beam_names
  std::vector<std::string> beam_names;
  // Joints (empty when there are none): name, type, master (-1: ground) and slave node indices,
  // axes (n_joints x 9: a1, a2, a3 one after the other) and the slave's reference offset (x 3).
  std::vector<std::string> joint_names, joint_types;
  std::vector<int>         joint_master, joint_slave;
  std::vector<double>      joint_axes, joint_offset;
  std::vector<int>         node_rank; // n_nodes: the MPI rank owning each node (the partition)
  // "static" or "dynamic" (the unit of time in /history: the load factor, or s); empty: static.
  std::string analysis_type;
  // Rigid bodies (empty when there are none): name, node index, mass, inertia about the centre of
  // mass (x 9, row-major) and offset of the centre of mass from the node (x 3) at the reference
  // configuration; principal moments (x 3, ascending), principal axes (x 9: three unit vectors,
  // right-handed) and the semi-axes of the uniform solid ellipsoid of the same mass and inertia
  // (x 3), which scale the axes drawn per frame.
  std::vector<std::string> body_names;
  std::vector<int>         body_node;
  std::vector<double>      body_mass, body_inertia, body_offset, body_principal_moments, body_principal_axes, body_semi_axes;
  // Ground markers (empty when there are none): one per joint to the ground (at the slave's
  // reference position, the joint's axes), per fully fixed support node (at the node, the global
  // axes) and per pinned node (translations fixed; BuildOutputMesh): name (joint or node), kind
  // ("joint", "support" or "pin"), position (x 3), axes a1, a2,
  // a3 (x 9, one after the other).
  std::vector<std::string> ground_names, ground_kinds;
  std::vector<double>      ground_position, ground_axes;
  // Force elements (empty when there are none): name, kind ("coordinate", "spring_damper",
  // "bushing"), and the two node indices of the segment drawn for each (x 2): a two-node element's
  // nodes; a coordinate element's joint's master and slave, or the slave twice (a segment of no
  // length, a point) when the master is the ground.
  std::vector<std::string> force_element_names, force_element_kinds;
  std::vector<int>         force_element_nodes;
};

struct OutputFrame {
  int                 step = 0;           // converged step number (0 = initial state)
  double              time = 0.0;         // time, or pseudo-time (load factor) in statics
  std::vector<double> position;           // n_nodes * 3
  std::vector<double> displacement;       // n_nodes * 3
  std::vector<double> rotation;           // n_nodes * 4, quaternion (w, x, y, z) from the reference configuration
  std::vector<double> element_resultants; // n_elements * 6: N1 N2 N3 M1 M2 M3, section frame, mean over Gauss points
  std::vector<double> element_strains;    // n_elements * 6: Gamma - Gamma0 (3), K - K0 (3), mean over Gauss points
  std::vector<double> velocity;           // dynamics only (else empty): n_nodes * 3
  std::vector<double> angular_velocity;   // dynamics only (else empty): n_nodes * 3, spatial (global axes)
  // Distributed frame: the arrays above hold only this rank's rows, node_rows.size() node rows
  // and element_rows.size() element rows, whose global indices (file rows) these are. Every row
  // must be held by exactly one rank. The velocities are present when any rank has them.
  // Each element row also names its visualisation segments (rows of /mesh/segments): the
  // element's order many, from element_first_segment.
  bool             distributed = false;
  std::vector<int> node_rows, element_rows;
  std::vector<int> element_first_segment, element_segment_count;
  // Distributed frames: the current section triad (axes e1 = beam axis, e2, e3, each 3 numbers)
  // at the first node of every segment of the element rows, in order (9 per segment).
  std::vector<double> segment_triads;
  // Rigid bodies, rows of /mesh/body_*: per row the centre of mass (3), the principal axes in their
  // current orientation scaled by the semi-axes (9: axis 1, axis 2, axis 3) and the rotation
  // quaternion (4, w x y z). Distributed frame: body_rows names this rank's rows; otherwise rank 0
  // holds every row in order. No rows on any rank: the frame has no rigid-body data.
  std::vector<int>    body_rows;
  std::vector<double> body_center, body_axes, body_rotation;
  // Joints, rows of /mesh/joint_*, likewise: the marker position (the slave node's position, 3) and
  // the joint axes a1 a2 a3 in their current orientation (master rotation times reference axes, 9).
  std::vector<int>    joint_rows;
  std::vector<double> joint_position, joint_axes;

  // Empties every array but keeps its storage: a frame object reused from step to step costs no
  // allocation.
  void Clear()
  {
    step = 0, time = 0.0, distributed = false;
    for (std::vector<double> *values : {&position, &displacement, &rotation, &element_resultants, &element_strains, &velocity, &angular_velocity,
                                        &segment_triads, &body_center, &body_axes, &body_rotation, &joint_position, &joint_axes})
      values->clear();
    for (std::vector<int> *rows : {&node_rows, &element_rows, &element_first_segment, &element_segment_count, &body_rows, &joint_rows}) rows->clear();
  }
};

struct ProbeSample {
  std::string name;
  double      position[3]     = {0, 0, 0};
  double      displacement[3] = {0, 0, 0};
  double      rotation[4]     = {1, 0, 0, 0};
  double      rotation_angle  = 0; // tracked angle 2 atan2(|q_v|, q_w) in [0, 2 pi]
};

class OutputFile {
public:
  OutputFile()                              = default;
  OutputFile(const OutputFile &)            = delete;
  OutputFile &operator=(const OutputFile &) = delete;
  ~OutputFile();

  // Creates `path` (an existing file is an error unless overwrite, and only an msflex result file
  // is ever replaced) and its sidecar `path` with the extension replaced by .xmf. Writes the
  // marker (msflex_format kResultFormat, msflex_model `model_fingerprint`, msflex_run
  // `run_id`), the provenance attributes of the root group (version, git commit, command line,
  // options, ranks, start time), /input and /mesh into a new temporary file renamed over `path`
  // when complete.
  PetscErrorCode Open(MPI_Comm comm, const std::string &path, bool overwrite, const std::string &input_file, const std::string &input_text,
                      const OutputMesh &mesh, const std::string &model_fingerprint, const std::string &run_id);
  // Continues the result file of an interrupted run (a restart): keeps the frames up to step
  // `last_step` and the first `history_rows` rows of the history table, drops the
  // rest, rewrites the sidecar, and opens the file as Open does.
  // Nothing changes unless the file is the result of run `run_id` and holds the frame of
  // `last_step` and `history_rows` rows of history (one line naming what is missing).
  // `checkpoint_step`: the step the run continues from (recorded in restart_N); -1: last_step.
  // `series_by_settings`: history series that this run's settings write (true) or leave out
  // (false), checked against the file's before anything changes.
  PetscErrorCode Reopen(MPI_Comm comm, const std::string &path, int last_step, long long history_rows, const std::string &run_id, int checkpoint_step = -1,
                        const std::vector<std::pair<std::string, bool>> &series_by_settings = {});
  // Appends a frame to the /frames datasets (one row each): kept in memory and written in blocks,
  // at the latest at the next flush, from which on the sidecar lists it.
  PetscErrorCode WriteFrame(const OutputFrame &frame);
  // Appends one row to the history table /history/values: one column per name (the set of names
  // must be the same on every call, "time" first, no name twice), then kProbeColumns per probe
  // sample (<probe>.position.x, ...), in memory until the next flush. Once HistoryNamesKnown(), `names` may be empty (and the probe
  // samples' names too): the row then only has to have as many values and samples as the first.
  PetscErrorCode AppendHistory(const std::vector<std::string> &names, const std::vector<double> &values, const std::vector<ProbeSample> &probes);
  // Whether the series names are known (from the first row since Open or Reopen), so that a
  // caller can leave building them out of the rows that follow.
  bool HistoryNamesKnown() const { return impl_ != nullptr && HistoryNamesKnownImpl(); }
  // Writes the buffered history rows, makes the file consistent on disk and lists the new frames
  // in the sidecar. Does nothing when nothing was written since the last flush.
  PetscErrorCode Flush();
  // Flush, then the result file and its sidecar to the device (fsync, rank 0: see docs/options.md
  // for file systems shared by several nodes): a checkpoint counts what they hold.
  PetscErrorCode SyncToDevice();
  // Flushes and closes.
  PetscErrorCode Close();

  // Wall-time seconds between automatic flushes (default 10; 0 flushes at every frame and row).
  // The same value on every rank. May be called before Open or at any time.
  void   SetFlushInterval(double seconds) { flush_interval_ = seconds; }
  double FlushInterval() const { return flush_interval_; }
  // The sidecar's syntax (default Xdmf3). Before Open or Reopen.
  void SetXdmfFlavour(XdmfFlavour flavour) { xdmf_flavour_ = flavour; }
  // Before Open, for a restart into a new file: what the file continues (the checkpoint, its step
  // and time), written as the root attribute `continues`.
  void SetContinues(const std::string &what) { continues_ = what; }
  // Number of history rows written so far, including the buffered ones.
  long long HistoryRows() const;
  // After Reopen, rank 0: the rows the file kept of energy_balance, total_energy, external_work and
  // dissipated_energy, four numbers per row (0 for a series the file lacks; empty without the first
  // two), so that a restarted run's summary covers the whole file (it covered the restarted part:
  // "initial total energy" was the restart's). Empty on other ranks.
  const std::vector<double> &ResumedEnergyRows() const;
  // After Open or Reopen, before the first history row: units of series that depend on the model
  // (a driven coordinate's drive_force, a coordinate element's force: N or N m) and the kinds of
  // the series' owners (a bushing, a revolute joint), for the units and descriptions of /history.
  void SetSeriesKnowledge(const std::map<std::string, std::string> &series_units, const std::map<std::string, std::string> &owner_kinds);
  // How the run ended, for the root attribute run_end that Close writes ("running" from Open or
  // Reopen until then): "completed ...", "stopped by SIGTERM ...", "stopped at t = ...: ...". The
  // same text on every rank.
  void SetRunEnd(const std::string &how);

  const std::string &Path() const { return path_; }

private:
  struct Impl;
  template <class RootWork> PetscErrorCode OpenWith(MPI_Comm comm, const std::string &path, RootWork &&root_work);
  // Flushes when the flush interval has passed since the last flush (rank 0's clock). Collective.
  PetscErrorCode FlushIfDue();
  bool           HistoryNamesKnownImpl() const;
  Impl          *impl_           = nullptr;
  double         flush_interval_ = 10.0;
  XdmfFlavour    xdmf_flavour_   = XdmfFlavour::Xdmf3;
  std::string    continues_;
  MPI_Comm       comm_ = MPI_COMM_NULL;
  std::string    path_;
};

} // namespace msflex
