#include "app/run_analysis.hpp"
#include "core/stop_signal.hpp"

#include "app/run_eigen.hpp"
#include "app/run_summary.hpp"
#include "core/errors.hpp"
#include "core/format.hpp"
#include "integrators/integrator.hpp"
#include "integrators/path_following.hpp"
#include "integrators/step_controller.hpp"
#include "model/joint_kinds.hpp"
#include "output/results.hpp"
#include "parallel/partition.hpp"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <initializer_list>
#include <iterator>
#include <map>

namespace msflex {

namespace {

// "42.0 s", "12 min 05 s", "3 h 07 min": wall times for the progress line.
std::string FormatDuration(double seconds)
{
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  if (seconds < 120) return Format("%.1f s", seconds);
  if (seconds < 7200) return Format("%d min %02d s", (int)(seconds / 60), (int)std::fmod(seconds, 60.0));
  return Format("%d h %02d min", (int)(seconds / 3600), (int)std::fmod(seconds / 60, 60.0));
}

// The next time the steps must land on: the first requested output time after t, or the end.
double NextTarget(const AnalysisSettings &analysis, double t)
{
  for (double output_time : analysis.output_times)
    if (output_time > t * (1.0 + 1e-12) + 1e-14) return std::min(output_time, analysis.end_time);
  return analysis.end_time;
}

// The Output stage's parts as -log_view events (registered once per process, in RunAnalysis):
// element results for the frame and history row, the history row's values, the frame's
// gathering, and the result file's writes (buffering, flushes, the sidecar, the closing).
struct OutputEvents {
  PetscLogEvent results = -1, history_row = -1, frame_gather = -1, file_write = -1;
} output_events;

// Everything one analysis owns, so that the step loop reads as the algorithm.
struct Analysis {
  MPI_Comm             comm;
  const RunOptions    &options;
  Model                model; // this rank's part of the model (the distributed model)
  DofMap               map;
  Integrator           integrator;
  PathFollower         path; // statics: the control of the steps and the stability of the path
  OutputFile           output;
  HistoryGather        joint_history;
  HistoryGather        force_element_history;
  const CheckpointRun *restart      = nullptr;                      // the checkpoint this run continues, or null
  long long            history_rows = 0;                            // rows written to /history
  std::string          input_file_absolute, input_text, input_file; // for checkpoints (the text only on rank 0)
  // Wall clock (rank 0's, broadcast) and simulated time when this process started stepping, and
  // of the last checkpoint.
  double     wall_start = 0.0, time_start = 0.0, last_checkpoint_wall = 0.0;
  double     last_progress_wall       = -1.0; // when the last progress line was printed (< 0: none yet)
  size_t     progress_critical_points = 0;    // the path's critical points named by the lines so far
  double     initial_energy           = 0.0;  // total energy of the first row (dynamics)
  RunSummary summary;                         // what the run printed at its end (-quiet: nothing)
  double     run_wall_start = MPI_Wtime();
  // -log_view stages: Setup, Partition, Output (the integrator adds LinearSolve and Assembly).
  PetscLogStage stage_setup, stage_partition, stage_output, stage_assembly;
  OutputFrame   frame; // the frame being written, kept so that its arrays are allocated once
  // Scratch of the history row and the step's element results, kept from step to step so that a
  // step's output allocates nothing once the first has sized them.
  struct HistoryRowScratch {
    std::vector<double>       values, joint_values, element_values, probe_values, probe_records;
    std::vector<ProbeSample>  probes;
    std::vector<HistoryValue> force_elements;
  } history_scratch;
  std::vector<ElementResults> step_results;
  // The local indices of the elements the element probes read (ProbeHistory), found at the first
  // row: a step without a frame computes their results alone.
  std::vector<int> probed_elements;
  bool             probed_elements_known = false;

  Analysis(MPI_Comm c, const RunOptions &o, const CheckpointRun *r) : comm(c), options(o), restart(r) {}
  bool Dynamic() const { return model.analysis.type == AnalysisType::Dynamic; }
  bool Static() const { return model.analysis.type == AnalysisType::Static; }
  // Whether the steps have reached the end at (pseudo-)time t (arc length: the load factor).
  bool Finished(double t) const { return Static() ? path.ReachedEnd(t) : t >= model.analysis.end_time * (1.0 - 1e-14); }
  // Whether a checkpoint of this run could be continued: not a static analysis under arc length or
  // displacement control, whose predictor needs the previous step (no checkpoint keeps it). Such
  // a run writes none, and says so.
  bool Checkpointable() const { return !Static() || model.analysis.control == PathControl::Load; }
};

struct StepRecord {
  int    step              = 0;
  double time              = 0.0;
  double step_size         = 0.0;
  int    newton_iterations = 0;
  double residual_norm     = 0.0;
};

// Units of the history series that depend on the model, and the kinds of the series' owners
// (OutputFile::SetSeriesKnowledge): a generalised force is N on a translation, N m on a rotation.
void SeriesKnowledge(const Model &whole, std::map<std::string, std::string> *series_units, std::map<std::string, std::string> *owner_kinds)
{
  // A name that owners of two kinds share (a joint and a beam probe may) keeps the generic
  // description: its series cannot be told apart by the name.
  std::map<std::string, std::string> kinds;
  std::vector<std::string>           shared;
  const auto                         claim = [&](const std::string &name, const std::string &kind) {
    const auto [at, inserted] = kinds.emplace(name, kind);
    if (!inserted && at->second != kind) shared.push_back(name);
  };
  const auto force_unit = [](const Joint &joint, int coordinate) { return coordinate < joint.num_translations ? "N" : "N m"; };
  for (const Joint &joint : whole.joints) {
    claim(joint.name, std::string(JointKindName(joint.kind)) + " joint");
    if (joint.driven_coordinate >= 0)
      // (a screw or rack driven by its translation: the force along it)
      (*series_units)[joint.name + ".drive_force"] = joint.drive_by_translation ? "N" : force_unit(joint, joint.driven_coordinate);
  }
  for (const ForceElement &element : whole.force_elements) {
    switch (element.kind) {
    case ForceElement::Kind::Coordinate:
      claim(element.name, "coordinate force element on joint " + whole.joints[element.joint].name);
      (*series_units)[element.name + ".force"] = force_unit(whole.joints[element.joint], element.coordinate);
      break;
    case ForceElement::Kind::SpringDamper:
      claim(element.name, "spring-damper");
      break;
    case ForceElement::Kind::Bushing:
      claim(element.name, "bushing");
      break;
    }
  }
  for (const Probe &probe : whole.probes) {
    if (probe.kind == Probe::Kind::Reaction) claim(probe.name, "reaction probe");
    if (probe.kind == Probe::Kind::Element) claim(probe.name, "beam probe");
  }
  for (const std::string &name : shared) kinds.erase(name);
  *owner_kinds = std::move(kinds);
}

// A warning line on standard error (also with -quiet) for the loads and actuators of a dynamic
// analysis that have no function: the default ramp f(t) = t is statics' load factor, and in
// dynamics it makes gravity three times g at t = 3 s, which users coming from other codes (whose
// loads hold their value) met without a word. The first one is named, the others counted.
PetscErrorCode WarnRampedDynamicLoads(MPI_Comm comm, const Model &whole)
{
  PetscFunctionBeginUser;
  if (whole.analysis.type != AnalysisType::Dynamic) PetscFunctionReturn(PETSC_SUCCESS);
  std::vector<std::pair<std::string, SourceMark>> ramped; // what, where
  for (const NodalLoad &load : whole.nodal_loads)
    if (load.function < 0 && (load.force.squaredNorm() > 0.0 || load.moment.squaredNorm() > 0.0)) ramped.push_back({"a nodal load", load.mark});
  for (const DistributedLoad &load : whole.distributed_loads)
    if (load.function < 0 && load.force_per_length.squaredNorm() > 0.0) ramped.push_back({load.gravity ? "gravity" : "a distributed load", load.mark});
  for (const ForceElement &element : whole.force_elements)
    if (element.has_actuator && element.actuator != 0.0 && element.actuator_function < 0)
      ramped.push_back({"the actuator of '" + element.name + "'", element.mark});
  if (ramped.empty()) PetscFunctionReturn(PETSC_SUCCESS);
  const auto &[what, mark]  = ramped.front();
  const std::string where   = mark.file.empty() ? std::string() : Format(" (%s:%d)", mark.file.c_str(), mark.line);
  const bool        one     = ramped.size() == 1;
  const std::string subject = one ? what + where + " has no function and grows"
                                  : Format("%s%s and %zu more loads or actuators without a function grow", what.c_str(), where.c_str(), ramped.size() - 1);
  PetscCall(PetscFPrintf(comm, PETSC_STDERR,
                         "msflex: warning: %s with time as f(t) = t in dynamics (twice %s value at t = 2 s); give %s a function (type: constant) to "
                         "keep %s value (docs/input.md, functions)\n",
                         subject.c_str(), one ? "its" : "their", one ? "it" : "them", one ? "its" : "their"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Set-up sees the whole model: partition, unknowns, the matrix pattern, nodal masses and the
// output mesh; then each rank keeps only its part (the distributed model) and the integrator is
// set up on it.
PetscErrorCode Setup(Analysis &a, Model whole)
{
  PartitionerType  partitioner;
  std::vector<int> node_rank;
  DofMap           whole_map;
  MatrixPattern    pattern;
  NodalMass        nodal_mass;
  PetscFunctionBeginUser;
  PetscCall(PetscLogStageRegister("Setup", &a.stage_setup));
  PetscCall(PetscLogStageRegister("Partition", &a.stage_partition));
  PetscCall(PetscLogStageRegister("Output", &a.stage_output));
  PetscCall(PetscLogStageRegister("Assembly", &a.stage_assembly));
  // Set-up's parts as -log_view events (registered once per process).
  static PetscLogEvent event_dof_map = -1, event_preallocation, event_integrator_setup, event_output_open, event_restrict;
  if (event_dof_map < 0) {
    PetscClassId classid;
    PetscCall(PetscClassIdRegister("msflex", &classid));
    PetscCall(PetscLogEventRegister("OutputResults", classid, &output_events.results));
    PetscCall(PetscLogEventRegister("OutputHistoryRow", classid, &output_events.history_row));
    PetscCall(PetscLogEventRegister("OutputFrameGather", classid, &output_events.frame_gather));
    PetscCall(PetscLogEventRegister("OutputFileWrite", classid, &output_events.file_write));
    PetscCall(PetscLogEventRegister("DofMapCreate", classid, &event_dof_map));
    PetscCall(PetscLogEventRegister("Preallocation", classid, &event_preallocation));
    PetscCall(PetscLogEventRegister("AssemblerSetup", classid, &event_integrator_setup));
    PetscCall(PetscLogEventRegister("OutputOpen", classid, &event_output_open));
    PetscCall(PetscLogEventRegister("ModelRestrict", classid, &event_restrict));
  }
  PetscCall(PetscLogStagePush(a.stage_setup));
  PetscCall(PetscLogStagePush(a.stage_partition));
  MSFLEX_CALL_READING_OPTIONS(a.comm, PartitionerTypeFromOptions(a.comm, &partitioner));
  PetscCall(PartitionNodes(a.comm, whole, partitioner, &node_rank));
  PetscCall(PetscLogStagePop());
  PetscCall(PetscLogEventBegin(event_dof_map, 0, 0, 0, 0));
  PetscCall(DofMapCreate(a.comm, whole, node_rank, &whole_map));
  PetscCall(PetscLogEventEnd(event_dof_map, 0, 0, 0, 0));
  // An eigenanalysis of a model without unknowns has no modes: said before any file is made.
  const bool eigen = whole.analysis.type == AnalysisType::Modes || whole.analysis.type == AnalysisType::Buckling;
  PetscCheck(!eigen || whole_map.num_global > 0, a.comm, PETSC_ERR_USER_INPUT,
             "%s analysis: the model has no unknowns (every degree of freedom is fixed or prescribed), so it has no %s",
             whole.analysis.type == AnalysisType::Buckling ? "buckling" : "modes",
             whole.analysis.type == AnalysisType::Buckling ? "buckling modes" : "modes of vibration");
  PetscCall(PetscLogEventBegin(event_preallocation, 0, 0, 0, 0));
  PetscCall(MechanicalSystemPrepare(whole, whole_map, &pattern, &nodal_mass));
  PetscCall(PetscLogEventEnd(event_preallocation, 0, 0, 0, 0));
  PetscMPIInt rank;
  PetscCallMPI(MPI_Comm_rank(a.comm, &rank));
  std::error_code                    no_throw;
  std::map<std::string, std::string> series_units, owner_kinds; // for the result file, from the whole model
  SeriesKnowledge(whole, &series_units, &owner_kinds);
  a.input_file          = whole.input_file;
  a.input_file_absolute = std::filesystem::absolute(whole.input_file, no_throw).string();
  if (rank == 0) a.input_text = whole.input_text;
  // A restart checks everything before any file changes (docs/options.md, "Files msflex
  // writes"): the checkpoint's sizes against the model, its state tables, the end time; the
  // result file is reopened (validated, then trimmed) or created only after the state is read.
  if (a.restart) {
    const DofMap::GlobalCount &count = whole_map.global_count;
    const char                *path  = a.options.restart_file.c_str();
    PetscCheck(a.restart->num_nodes == count.nodes && a.restart->num_joints == count.joints && a.restart->num_rigid_bodies == count.rigid_bodies, a.comm,
               PETSC_ERR_FILE_UNEXPECTED,
               "the checkpoint '%s' holds %lld nodes, %lld joints and %lld rigid bodies, but the model has %" PetscInt_FMT ", %" PetscInt_FMT
               " and %" PetscInt_FMT,
               path, a.restart->num_nodes, a.restart->num_joints, a.restart->num_rigid_bodies, count.nodes, count.joints, count.rigid_bodies);
    PetscCall(CheckpointValidateState(a.comm, a.options.restart_file, *a.restart));
    const bool load_factor_end = whole.analysis.type == AnalysisType::Static && whole.analysis.control == PathControl::ArcLength;
    PetscCheck(load_factor_end || a.restart->time < whole.analysis.end_time * (1.0 - 1e-14), a.comm, PETSC_ERR_FILE_UNEXPECTED,
               "the checkpoint '%s' is at t = %.6g, at or beyond the end time %.6g; give a later -analysis_end_time", path, a.restart->time,
               whole.analysis.end_time);
  }
  PetscCall(WarnRampedDynamicLoads(a.comm, whole));
  OutputMesh mesh; // rank 0: for a new result file
  if (!a.options.continue_output && rank == 0) {
    BuildOutputMesh(whole, &mesh);
    mesh.node_rank = whole_map.node_rank;
  }
  const std::string input_file = whole.input_file;
  PetscCall(PetscLogEventBegin(event_restrict, 0, 0, 0, 0));
  PetscCall(DofMapRestrictToLocal(whole, whole_map, &a.model, &a.map));
  whole     = Model{};
  whole_map = DofMap{};
  PetscCall(PetscLogEventEnd(event_restrict, 0, 0, 0, 0));
  PetscCall(PetscLogEventBegin(event_integrator_setup, 0, 0, 0, 0));
  PetscCall(a.integrator.Setup(a.comm, a.model, a.map, std::move(pattern), std::move(nodal_mass), a.stage_assembly));
  if (a.Static()) PetscCall(a.path.Setup(a.comm, &a.integrator));
  PetscCall(PetscLogEventEnd(event_integrator_setup, 0, 0, 0, 0));
  if (a.restart) {
    PetscCall(CheckpointReadState(a.comm, a.options.restart_file, a.model, a.map, a.integrator.MutableState()));
    a.integrator.SetExternalWork(a.restart->external_work);
    a.integrator.SetDissipatedEnergy(a.restart->dissipated_energy);
    a.integrator.SetPreviousStep(a.restart->previous_step);
    if (a.restart->step == 0) a.integrator.SetMotionStart(a.restart->time);
    if (a.restart->pivoting_lu) PetscCall(a.integrator.UsePivotingLU());
    a.initial_energy = a.restart->initial_energy;
  }
  // Only now, with the checkpoint read: the result file (the decision to continue it was main's).
  PetscCall(PetscLogEventBegin(event_output_open, 0, 0, 0, 0));
  a.output.SetFlushInterval(a.options.output_flush_interval);
  a.output.SetXdmfFlavour(a.options.output_xdmf == "xdmf2" ? XdmfFlavour::Xdmf2 : XdmfFlavour::Xdmf3);
  if (a.options.continue_output) {
    // The stability account's series, written or not by this run's settings (the static path's).
    std::vector<std::pair<std::string, bool>> series_by_settings;
    if (a.Static()) series_by_settings.push_back({"negative_pivots", a.model.analysis.stability});
    PetscCall(a.output.Reopen(a.comm, a.options.output_file, a.restart->last_written, a.restart->history_rows, a.options.run_id, a.restart->step,
                              series_by_settings));
    a.history_rows = a.restart->history_rows;
    // The summary's energy figures cover the whole file: its rows so far first.
    const std::vector<double> &rows = a.output.ResumedEnergyRows();
    for (size_t r = 0; r + 3 < rows.size(); r += 4) a.summary.Energy(rows[r], rows[r + 1], rows[r + 2], rows[r + 3]);
  } else {
    if (a.restart)
      a.output.SetContinues(Format("checkpoint %s at step %d, t = %.17g (of the run whose results were %s)", a.options.restart_file.c_str(), a.restart->step,
                                   a.restart->time, a.restart->output_file.c_str()));
    PetscCall(a.output.Open(a.comm, a.options.output_file, a.options.output_overwrite, input_file, a.input_text, mesh, a.options.model_fingerprint,
                            a.options.run_id));
  }
  a.output.SetSeriesKnowledge(series_units, owner_kinds);
  PetscCall(PetscLogEventEnd(event_output_open, 0, 0, 0, 0));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(PETSC_SUCCESS);
}

// *kinetic_energy: from the dynamics diagnostics of the row (0 in statics); *total_energy: kinetic
// + strain + spring energy.
PetscErrorCode WriteHistory(Analysis &a, const StepRecord &record, double strain_energy, const std::vector<ElementResults> &results, double *kinetic_energy,
                            double *total_energy)
{
  Analysis::HistoryRowScratch &scratch = a.history_scratch;
  std::vector<ProbeSample>    &probes  = scratch.probes;
  std::vector<std::string>     names;
  std::vector<double>         &values = scratch.values;
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(output_events.history_row, 0, 0, 0, 0));
  values.clear();
  // The series' names go with the first row only (the result file keeps them): building them for
  // every row was a third of a row's cost on a model of a few dozen series.
  const bool with_names = !a.output.HistoryNamesKnown();
  auto       add        = [&](std::initializer_list<const char *> row_names, std::initializer_list<double> row_values) {
    if (with_names) names.insert(names.end(), row_names.begin(), row_names.end());
    values.insert(values.end(), row_values);
  };
  auto append = [&](std::vector<std::string> &row_names, const std::vector<double> &row_values) {
    if (with_names) names.insert(names.end(), std::make_move_iterator(row_names.begin()), std::make_move_iterator(row_names.end()));
    values.insert(values.end(), row_values.begin(), row_values.end());
  };
  const State &state = a.integrator.GetState();
  PetscCall(SampleProbes(a.comm, a.model, a.map, state, &probes, &scratch.probe_records));
  add({"time", "step", "step_size", "newton_iterations", "residual_norm", "strain_energy"},
      {record.time, (double)record.step, record.step_size, (double)record.newton_iterations, record.residual_norm, strain_energy});
  // Force elements and damped beams: their stored energy, and in dynamics the energy their dampers dissipated.
  const bool force_elements = a.integrator.HasForceElementsOrDamping();
  double     spring_energy  = 0.0;
  if (force_elements) {
    PetscCall(a.integrator.SpringEnergy(&spring_energy));
    add({"spring_energy"}, {spring_energy});
  }
  *total_energy = strain_energy + spring_energy;
  if (a.Static()) {
    std::vector<std::string> path_names;
    std::vector<double>      path_values;
    a.path.HistoryColumns(&path_names, &path_values);
    append(path_names, path_values);
  }
  if (a.Dynamic()) {
    Momenta d;
    PetscCall(a.integrator.MomentaOfState(&d));
    *kinetic_energy    = d.kinetic_energy;
    *total_energy      = d.kinetic_energy + strain_energy + spring_energy;
    const double total = *total_energy, work = a.integrator.ExternalWork(), dissipated = a.integrator.DissipatedEnergy();
    if (record.step == 0 && !a.restart) a.initial_energy = total;
    // What the scheme itself dissipates (or creates): the external work less the change of energy
    // and the energy the dampers dissipated, with the work taken by the scheme's own quadrature
    // (Assembler::StepExternalWork) and the dampers' dissipation by their own (StepDissipation).
    const double dissipation = work - dissipated - (total - a.initial_energy);
    a.summary.Energy(total - work + dissipated, total, work, dissipated);
    add({"kinetic_energy", "total_energy", "external_work", "energy_balance", "algorithmic_dissipation", "linear_momentum_x", "linear_momentum_y",
         "linear_momentum_z", "angular_momentum_x", "angular_momentum_y", "angular_momentum_z", "energy_correction"},
        {d.kinetic_energy, total, work, total - work + dissipated, dissipation, d.linear_momentum(0), d.linear_momentum(1), d.linear_momentum(2),
         d.angular_momentum(0), d.angular_momentum(1), d.angular_momentum(2), record.step == 0 ? 0.0 : a.integrator.EnergyCorrectionFactor()});
    if (force_elements) add({"dissipated_energy"}, {dissipated});
  }
  if (a.map.global_count.joints > 0) {
    std::vector<std::string> joint_names;
    PetscCall(JointHistory(a.comm, a.model, a.map, state, &a.joint_history, with_names ? &joint_names : nullptr, &scratch.joint_values));
    append(joint_names, scratch.joint_values);
  }
  if (force_elements) {
    std::vector<std::string> element_names;
    scratch.force_elements.clear();
    // The names are gathered once (with the places that order the series), whatever the file knows.
    a.integrator.ForceElementHistory(with_names || !a.force_element_history.gathered, &scratch.force_elements);
    PetscCall(GatherHistory(a.comm, scratch.force_elements, &a.force_element_history, with_names ? &element_names : nullptr, &scratch.element_values));
    append(element_names, scratch.element_values);
  }
  {
    std::vector<std::string> probe_names;
    PetscCall(ProbeHistory(a.comm, a.model, a.map, state, results, with_names ? &probe_names : nullptr, &scratch.probe_values));
    append(probe_names, scratch.probe_values);
  }
  PetscCall(PetscLogEventEnd(output_events.history_row, 0, 0, 0, 0));
  PetscCall(PetscLogEventBegin(output_events.file_write, 0, 0, 0, 0));
  PetscCall(a.output.AppendHistory(names, values, probes));
  PetscCall(PetscLogEventEnd(output_events.file_write, 0, 0, 0, 0));
  ++a.history_rows;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// A frame of the current state; `results`: the element results of that state (computed when null).
PetscErrorCode WriteFrame(Analysis &a, int step, double time, double *strain_energy, const std::vector<ElementResults> *results = nullptr)
{
  std::vector<ElementResults> computed;
  OutputFrame                &frame = a.frame;
  PetscFunctionBeginUser;
  if (!results) {
    PetscCall(PetscLogEventBegin(output_events.results, 0, 0, 0, 0));
    PetscCall(a.integrator.ElementResults(&computed, strain_energy));
    PetscCall(PetscLogEventEnd(output_events.results, 0, 0, 0, 0));
    results = &computed;
  }
  PetscCall(PetscLogEventBegin(output_events.frame_gather, 0, 0, 0, 0));
  PetscCall(GatherFrame(a.comm, a.model, a.map, a.integrator.GetState(), *results, step, time, a.Dynamic(), &frame));
  PetscCall(PetscLogEventEnd(output_events.frame_gather, 0, 0, 0, 0));
  PetscCall(PetscLogEventBegin(output_events.file_write, 0, 0, 0, 0));
  PetscCall(a.output.WriteFrame(frame));
  PetscCall(PetscLogEventEnd(output_events.file_write, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The end-of-run summary, with the run's tangent counts (nothing with -quiet).
// A warning line on standard error (also with -quiet) when the dynamics created energy: the energy
// balance grew by more than kEnergyGrowthWarning of the largest total energy, which no scheme does
// on purpose (em conserves it, genalpha and the dampers only take energy away).
constexpr double kEnergyGrowthWarning = 0.05;

PetscErrorCode WarnEnergyGrowth(Analysis &a)
{
  PetscFunctionBeginUser;
  const double growth = a.summary.RelativeEnergyGrowth();
  if (!a.Dynamic() || !(growth > kEnergyGrowthWarning)) PetscFunctionReturn(PETSC_SUCCESS);
  const double      initial = std::fabs(a.summary.InitialTotalEnergy());
  const std::string scale =
      initial > 0 ? Format("%.3g J, %.3g times the initial total energy of %.4g J", a.summary.EnergyGrowth(), a.summary.EnergyGrowth() / initial, initial)
                  : Format("%.3g J, %.3g times the largest total energy", a.summary.EnergyGrowth(), growth);
  // newmark has no spectral radius to lower (it ignores -analysis_spectral_radius): genalpha does.
  const bool newmark = a.model.analysis.integrator == TimeSchemeKind::Newmark;
  PetscCall(PetscFPrintf(a.comm, PETSC_STDERR,
                         "msflex: warning: the energy balance grew by %s: %s created energy (newmark and genalpha "
                         "near rho_infinity = 1 are not energy-stable for rotating bodies and joints; em conserves energy, %s)\n",
                         scale.c_str(), TimeSchemeName(a.model.analysis.integrator),
                         newmark ? "genalpha with a spectral radius below 1 (-analysis_integrator genalpha -analysis_spectral_radius 0.8) damps it"
                                 : "a smaller -analysis_spectral_radius damps it"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode PrintSummary(Analysis &a)
{
  PetscFunctionBeginUser;
  PetscCall(WarnEnergyGrowth(a));
  if (a.options.quiet) PetscFunctionReturn(PETSC_SUCCESS);
  a.summary.Tangents(a.integrator.TangentsFormed(), a.integrator.TangentsReused());
  a.summary.ConsistentReactions(a.integrator.ConsistentReactionSolves(), a.integrator.ConsistentReactionFailures(), a.integrator.ConsistentReactionSeconds());
  PetscCall(a.summary.Print(a.comm, a.run_wall_start, a.Dynamic()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Closes the result file (the last flush: buffered frames and rows, sidecar) in the Output stage.
PetscErrorCode CloseOutput(Analysis &a)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogStagePush(a.stage_output));
  PetscCall(PetscLogEventBegin(output_events.file_write, 0, 0, 0, 0));
  const PetscErrorCode closed = a.output.Close();
  PetscCall(PetscLogEventEnd(output_events.file_write, 0, 0, 0, 0));
  PetscCall(PetscLogStagePop());
  PetscCall(closed);
  PetscFunctionReturn(PETSC_SUCCESS);
}

// PETSc's viewer lookups turned off for a scope (PetscOptionsPushGetViewerOff), and on again at
// its end whichever way it is left.
class ViewerLookupsOff {
public:
  explicit ViewerLookupsOff(bool off) : pushed_(off && PetscOptionsPushGetViewerOff(PETSC_TRUE) == PETSC_SUCCESS) {}
  ~ViewerLookupsOff()
  {
    if (pushed_) (void)PetscOptionsPopGetViewerOff(); // fails only when nothing was pushed
  }
  ViewerLookupsOff(const ViewerLookupsOff &)            = delete;
  ViewerLookupsOff &operator=(const ViewerLookupsOff &) = delete;

private:
  bool pushed_;
};

// Whether a step's progress line is printed (the step being one of every progress_every-th):
// at most one line per progress_interval seconds of wall time, since a line per step of a small
// model costs more than its output (a formatted write to standard output, flushed, per step);
// the first line, the last and a line naming a new critical point of the path always. Rank 0
// alone prints, so the ranks need not agree on it.
bool ProgressLineDue(const Analysis &a, bool last, double now)
{
  if (last || a.last_progress_wall < 0.0 || a.options.progress_interval <= 0.0) return true;
  if (a.path.CriticalPoints().size() != a.progress_critical_points) return true;
  return now - a.last_progress_wall >= a.options.progress_interval;
}

// The state after a converged step: frame (when due), history row, progress line.
PetscErrorCode RecordStep(Analysis &a, const StepRecord &record, bool write_frame)
{
  double                       strain_energy = 0.0, kinetic_energy = 0.0, total_energy = 0.0;
  std::vector<ElementResults> &results = a.step_results;
  PetscFunctionBeginUser;
  results.clear();
  PetscCall(PetscLogStagePush(a.stage_output));
  PetscCall(PetscLogEventBegin(output_events.results, 0, 0, 0, 0));
  // Every element's results only for a frame, those of the probed elements for the element probes;
  // the history's strain energy alone is what the converged step's last residual kept
  // (MechanicalSystem::StrainEnergy).
  if (!a.probed_elements_known) {
    for (const Probe &probe : a.model.probes) {
      if (probe.kind != Probe::Kind::Element || probe.element < 0) continue; // element < 0: held by another rank
      const int k = a.map.element_to_local[probe.element];
      if (k >= 0 && k < (int)a.map.local_elements.size()) a.probed_elements.push_back(k);
    }
    a.probed_elements_known = true;
  }
  if (write_frame) PetscCall(a.integrator.ElementResults(&results, &strain_energy));
  else {
    PetscCall(a.integrator.StrainEnergy(&strain_energy));
    if (!a.probed_elements.empty()) PetscCall(a.integrator.ElementResultsOf(a.probed_elements, &results));
  }
  PetscCall(PetscLogEventEnd(output_events.results, 0, 0, 0, 0));
  if (write_frame) PetscCall(WriteFrame(a, record.step, record.time, &strain_energy, &results));
  PetscCall(WriteHistory(a, record, strain_energy, results, &kinetic_energy, &total_energy));
  PetscCall(PetscLogStagePop());
  // The state a dynamic run starts from, in energies: initial conditions that turn a joint or some
  // nodes without their neighbours strain the beams, which shows here before it shows as a slow run.
  if (a.Dynamic() && record.step == 0 && !a.restart && !a.options.quiet)
    PetscCall(
        PetscPrintf(a.comm, "msflex: initial state: kinetic energy %.6g J, strain energy %.6g J%s\n", kinetic_energy, strain_energy,
                    a.integrator.HasForceElementsOrDamping() ? Format(", spring energy %.6g J", total_energy - kinetic_energy - strain_energy).c_str() : ""));
  const bool   last      = a.Finished(record.time);
  const bool   candidate = !a.options.quiet && record.step > 0 && (record.step % a.options.progress_every == 0 || last);
  const double now       = candidate ? MPI_Wtime() : 0.0;
  if (candidate && ProgressLineDue(a, last, now)) {
    // Wall time of this process so far and the time left at the average rate since it started.
    const double elapsed       = now - a.wall_start;
    a.last_progress_wall       = now;
    a.progress_critical_points = a.path.CriticalPoints().size();
    const double      left     = record.time > a.time_start ? elapsed * (a.model.analysis.end_time - record.time) / (record.time - a.time_start) : NAN;
    const std::string timing   = "wall " + FormatDuration(elapsed) + (last ? "" : ", left ~" + FormatDuration(left));
    if (a.Dynamic()) {
      PetscCall(PetscPrintf(a.comm, "step %6d  t = %-11.6g dt = %-10.4g newton %2d  |R| = %.3e  energy = %.10e  %s\n", record.step, record.time,
                            record.step_size, record.newton_iterations, record.residual_norm, total_energy, timing.c_str()));
    } else {
      PetscCall(PetscPrintf(a.comm, "step %5d  t = %-12.6g dt = %-10.4g newton %2d  |R| = %.3e  strain energy = %.6e%s  %s\n", record.step, record.time,
                            record.step_size, record.newton_iterations, record.residual_norm, strain_energy, a.path.ProgressNote().c_str(), timing.c_str()));
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Rank 0's wall clock, the same on every rank (decisions taken on it stay collective).
double WallClock(MPI_Comm comm)
{
  double now = MPI_Wtime();
  MPI_Bcast(&now, 1, MPI_DOUBLE, 0, comm);
  return now;
}

PetscErrorCode WriteCheckpoint(Analysis &a, int step, double t, int last_written, const StepController &controller)
{
  CheckpointRun run;
  PetscFunctionBeginUser;
  run.step                = step;
  run.time                = t;
  run.external_work       = a.integrator.ExternalWork();
  run.dissipated_energy   = a.integrator.DissipatedEnergy();
  run.initial_energy      = a.initial_energy;
  run.pivoting_lu         = a.integrator.PivotingLUForced();
  run.last_written        = last_written;
  run.history_rows        = a.history_rows;
  run.controller_step     = controller.CurrentStep();
  run.controller_easy_run = controller.EasyRun();
  run.previous_step       = a.integrator.PreviousStep();
  run.num_nodes           = a.map.global_count.nodes;
  run.num_joints          = a.map.global_count.joints;
  run.num_rigid_bodies    = a.map.global_count.rigid_bodies;
  run.input_file          = a.input_file_absolute;
  run.input_text          = a.input_text;
  run.options             = a.options.options_database;
  run.output_file         = a.options.output_file;
  run.run_id              = a.options.run_id;
  run.mesh_fingerprint    = a.options.mesh_fingerprint;
  PetscCall(PetscLogStagePush(a.stage_output));
  // The result file holds run.history_rows rows, which a restart keeps: on the device with the
  // sidecar before the checkpoint that counts them (a machine that fails after the checkpoint
  // leaves a pair a restart can continue).
  PetscCall(a.output.SyncToDevice());
  PetscCall(CheckpointWrite(a.comm, a.options.checkpoint_file, run, a.integrator.GetState(), a.map));
  PetscCall(PetscLogStagePop());
  // A restart from here starts on a new tangent; so does this run (modified Newton), which keeps
  // the two bitwise alike.
  a.integrator.ForgetKeptTangent();
  a.last_checkpoint_wall = WallClock(a.comm);
  PetscFunctionReturn(PETSC_SUCCESS);
}

const char *StopSignalName(int signal)
{
  return signal == SIGTERM ? "SIGTERM" : signal == SIGUSR1 ? "SIGUSR1" : signal == SIGINT ? "SIGINT" : signal == SIGHUP ? "SIGHUP" : "a signal";
}

// After a converged step: a checkpoint when one is due (every n steps, every so many seconds) or
// a stop signal arrived on any rank; *stop tells the step loop to end the run. A run stopped by a
// signal writes its last step as a frame first (the last step is always written); the checkpoint
// names the frame before it as its last, so that the restart drops the extra frame and the run it
// completes has the frames of one never stopped.
PetscErrorCode CheckpointIfDue(Analysis &a, int step, double t, int *last_written, const StepController &controller, bool *stop)
{
  const int mine = StopSignalReceived();
  int       signal;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Allreduce(&mine, &signal, 1, MPI_INT, MPI_MAX, a.comm));
  const RunOptions &o   = a.options;
  const bool        due = (o.checkpoint_every > 0 && step % o.checkpoint_every == 0) ||
                   (o.checkpoint_wall_time > 0 && WallClock(a.comm) - a.last_checkpoint_wall >= o.checkpoint_wall_time);
  // A signal during the last step: the run has completed, and it ends as completed (exit 0), or a
  // job script would resubmit a finished run, whose restart is then refused (nothing left to do).
  *stop = signal != 0 && !a.Finished(t);
  if (signal != 0 && !*stop)
    PetscCall(PetscFPrintf(a.comm, PETSC_STDERR, "msflex: %s arrived during the last step; the run has completed\n", StopSignalName(signal)));
  const int last_regular_frame = *last_written;
  if (*stop && *last_written != step) {
    double strain_energy;
    PetscCall(WriteFrame(a, step, t, &strain_energy));
    *last_written = step;
  }
  if (!a.Checkpointable()) {
    if (*stop)
      PetscCall(PetscPrintf(a.comm,
                            "msflex: stopped by %s at step %d, t = %.6g; the results up to here are in %s; no checkpoint: a static analysis under "
                            "control: %s cannot be continued from one\n",
                            StopSignalName(signal), step, t, o.output_file.c_str(), PathControlName(a.model.analysis.control)));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (!due && !*stop) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(WriteCheckpoint(a, step, t, last_regular_frame, controller));
  if (!o.quiet && !*stop) PetscCall(PetscPrintf(a.comm, "checkpoint at step %d, t = %.6g: %s\n", step, t, o.checkpoint_file.c_str()));
  if (*stop)
    PetscCall(PetscPrintf(a.comm, "msflex: stopped by %s at step %d, t = %.6g; checkpoint %s; continue with: msflex --restart %s\n", StopSignalName(signal),
                          step, t, o.checkpoint_file.c_str(), o.checkpoint_file.c_str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The static stage of a dynamic analysis: equilibrium under the loads at t = 0, reached with the
// load factor going from 0 to 1 under the step controller (first step 1/static_stage_steps); the
// dynamics start from it. Nothing is written; a progress line per step unless quiet.
PetscErrorCode RunStaticStage(Analysis &a)
{
  const AnalysisSettings &analysis = a.model.analysis;
  // The analysis' growth rules over the load factor 0 .. 1, in steps of its own.
  StepControllerSettings settings = StepControllerSettingsOf(analysis);
  PetscFunctionBeginUser;
  settings.initial_step  = 1.0 / analysis.static_stage_steps;
  settings.max_step      = 1.0;
  settings.error_control = false; // a load factor has no time-integration error
  settings.min_step      = std::min(1e-6, settings.initial_step);
  StepController controller(settings);
  double         factor = 0.0;
  int            steps  = 0;
  while (factor < 1.0 - 1e-14) {
    double dt = controller.Propose(factor, 1.0);
    for (;;) {
      StepOutcome outcome;
      PetscCall(a.integrator.TryStaticStageStep(0.0, factor, dt, &outcome));
      if (outcome.converged) {
        factor = factor + dt >= 1.0 - 1e-14 ? 1.0 : factor + dt;
        ++steps;
        controller.Accept(dt, outcome.newton_iterations);
        if (!a.options.quiet)
          PetscCall(PetscPrintf(a.comm, "static stage %3d  load factor = %-10.6g newton %2d  |R| = %.3e\n", steps, factor, outcome.newton_iterations,
                                outcome.residual_norm));
        break;
      }
      PetscCheck(controller.Reject(dt), a.comm, PETSC_ERR_NOT_CONVERGED,
                 "the static stage could not reach equilibrium under the loads at t = 0: the step to load factor %.6g failed (%s); a static stage needs every "
                 "free motion held (supports, drives, springs or stiffness)",
                 factor + dt, outcome.why.c_str());
      dt = controller.Propose(factor, 1.0);
    }
  }
  double strain_energy, spring_energy;
  PetscCall(a.integrator.StrainEnergy(&strain_energy));
  PetscCall(a.integrator.SpringEnergy(&spring_energy));
  if (!a.options.quiet)
    PetscCall(PetscPrintf(a.comm, "msflex: static stage: equilibrium under the loads at t = 0 in %d step(s); strain energy %.6e J, spring energy %.6e J\n",
                          steps, strain_energy, spring_energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

StopSignalHandlers::StopSignalHandlers()
{
  struct sigaction action = {};
  action.sa_handler       = RecordStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGTERM, &action, &previous_term_);
  sigaction(SIGUSR1, &action, &previous_usr1_);
  // SIGINT (Ctrl-C; LSF's bkill sends it first) and SIGHUP (a closed terminal) stop the run the
  // same way, once: the handler then gives way to the default, so a second Ctrl-C ends a long
  // step at once. (They printed PETSc's trace and lost what the run had not flushed.)
  action.sa_flags |= SA_RESETHAND;
  sigaction(SIGINT, &action, &previous_int_);
  sigaction(SIGHUP, &action, &previous_hup_);
  // A file-size limit (ulimit -f) is a write error like a full disk: the write fails with EFBIG,
  // which the file's writer reports in one line, instead of SIGXFSZ ending the run without a word.
  struct sigaction ignore = {};
  ignore.sa_handler       = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  sigaction(SIGXFSZ, &ignore, &previous_xfsz_);
  ClearStopSignal();
}

StopSignalHandlers::~StopSignalHandlers()
{
  sigaction(SIGTERM, &previous_term_, nullptr);
  sigaction(SIGUSR1, &previous_usr1_, nullptr);
  sigaction(SIGINT, &previous_int_, nullptr);
  sigaction(SIGHUP, &previous_hup_, nullptr);
  sigaction(SIGXFSZ, &previous_xfsz_, nullptr);
}

PetscErrorCode RunAnalysis(MPI_Comm comm, Model model, const RunOptions &options, const CheckpointRun *restart, RunEnd *end)
{
  Analysis a(comm, options, restart);
  PetscFunctionBeginUser;
  *end = RunEnd::Completed;
  PetscCall(Setup(a, std::move(model)));
  const AnalysisSettings &analysis = a.model.analysis;
  // Relay nodes (docs/joints.md) named with their 12 rows each, so the count of unknowns adds up.
  const std::string relays = a.map.num_relays > 0 ? Format(" (%" PetscInt_FMT " of them for %" PetscInt_FMT " relay nodes, condensation depth %d)",
                                                           12 * a.map.num_relays, a.map.num_relays, analysis.condensation_depth)
                                                  : "";
  if (!options.quiet)
    PetscCall(PetscPrintf(comm,
                          "msflex: %s analysis%s%s of '%s': %" PetscInt_FMT " nodes, %" PetscInt_FMT " elements, %" PetscInt_FMT " rigid bodies, %" PetscInt_FMT
                          " joints, %" PetscInt_FMT " unknowns%s; output %s\n",
                          AnalysisTypeName(analysis.type), a.Dynamic() ? " with " : "", a.Dynamic() ? TimeSchemeName(analysis.integrator) : "",
                          a.input_file.c_str(), a.map.global_count.nodes, a.map.global_count.elements, a.map.global_count.rigid_bodies,
                          a.map.global_count.joints, a.map.num_global, relays.c_str(), options.output_file.c_str()));
  a.integrator.SetQuiet(options.quiet);
  if (IsEigenAnalysis(analysis.type)) {
    bool stopped = false;
    PetscCall(RunEigenAnalysis(comm, a.model, a.map, a.integrator, a.output, options.quiet, &stopped));
    // A stop signal ends the eigensolver with the modes it has, written; no checkpoint can continue
    // it (exit 128 + the signal, as an arc-length run's).
    const std::string how = stopped ? Format("stopped by %s with the modes converged by then", StopSignalName(StopSignalReceived())) : std::string("completed");
    a.output.SetRunEnd(how);
    PetscCall(CloseOutput(a));
    if (stopped) {
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "msflex: %s; results in %s; no checkpoint: a modes or buckling analysis is run again from its input\n",
                             how.c_str(), options.output_file.c_str()));
      *end = RunEnd::StoppedBySignalWithoutCheckpoint;
    } else {
      // The solver checks for a signal between its outer iterations: one that came in the last
      // (often the only one) finds the modes complete.
      if (StopSignalReceived() != 0)
        PetscCall(PetscFPrintf(comm, PETSC_STDERR, "msflex: %s arrived during the eigensolver's last iteration; the analysis has completed\n",
                               StopSignalName(StopSignalReceived())));
      if (!options.quiet) PetscCall(PetscPrintf(comm, "msflex: results in %s\n", options.output_file.c_str()));
    }
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (a.Static()) PetscCall(a.path.Start(restart ? restart->time : 0.0));
  if (!restart) {
    PetscCall(a.integrator.InitialiseConfiguration());
    if (a.Dynamic() && analysis.static_stage) PetscCall(RunStaticStage(a));
    if (a.Dynamic()) PetscCall(a.integrator.InitialiseMotion(0.0));
    else PetscCall(a.integrator.InitialiseStatics());
    PetscCall(RecordStep(a, StepRecord{}, true));
  }

  StepControllerSettings controller_settings = StepControllerSettingsOf(analysis);
  const bool             arc_length          = a.Static() && analysis.control == PathControl::ArcLength;
  if (arc_length) controller_settings.desired_iterations = analysis.desired_iterations;
  StepController controller(controller_settings);

  double t    = 0.0;
  int    step = 0, last_written = 0;
  if (restart) {
    t            = restart->time;
    step         = restart->step;
    last_written = restart->last_written;
    controller.Restore(restart->controller_step, restart->controller_easy_run);
    if (!options.quiet) PetscCall(PetscPrintf(comm, "msflex: continuing from step %d, t = %.6g (checkpoint %s)\n", step, t, options.restart_file.c_str()));
  }
  a.wall_start = a.last_checkpoint_wall = WallClock(comm);
  a.time_start                          = t;
  if (!a.Checkpointable() && (options.checkpoint_every > 0 || options.checkpoint_wall_time > 0))
    PetscCall(PetscFPrintf(comm, PETSC_STDERR,
                           "msflex: warning: a static analysis under control: %s writes no checkpoints (a restart cannot continue it); "
                           "-checkpoint_every and -checkpoint_wall_time are ignored\n",
                           PathControlName(analysis.control)));
  // KSPSolve, SNESSolve and the assemblies look up a dozen viewer options in the database at
  // every call (-ksp_view, -snes_converged_reason, ...): 4 % of a small model's step. Where no
  // option asks for a viewer, the steps run with those lookups off.
  const ViewerLookupsOff viewer_lookups_off(!options.petsc_viewers_requested);
  while (!a.Finished(t)) {
    // Arc length has no target in t: it ends on the load factor.
    const double target = arc_length ? INFINITY : NextTarget(analysis, t);
    double       dt     = controller.Propose(t, target);
    for (;;) {
      StepOutcome outcome;
      if (a.Static()) PetscCall(a.path.TryStep(t, dt, &outcome));
      else PetscCall(a.integrator.TryStep(t, dt, &outcome));
      a.summary.Attempt(outcome);
      if (outcome.converged) {
        const double taken = std::isfinite(outcome.step_taken) ? outcome.step_taken : dt;
        t                  = (t + taken >= target * (1.0 - 1e-14)) ? target : t + taken;
        ++step;
        controller.Accept(dt, outcome.newton_iterations, outcome.error_ratio);
        const bool write_frame = (step % options.output_every == 0) || a.Finished(t) ||
                                 std::find(analysis.output_times.begin(), analysis.output_times.end(), t) != analysis.output_times.end();
        if (write_frame) last_written = step;
        PetscCall(RecordStep(a, {step, t, taken, outcome.newton_iterations, outcome.residual_norm}, write_frame));
        bool stop = false;
        PetscCall(CheckpointIfDue(a, step, t, &last_written, controller, &stop));
        if (stop) {
          a.output.SetRunEnd(Format("stopped by %s at step %d, t = %.8g; %s", StopSignalName(StopSignalReceived()), step, t,
                                    a.Checkpointable() ? ("checkpoint " + options.checkpoint_file).c_str() : "no checkpoint"));
          PetscCall(CloseOutput(a));
          PetscCall(PrintSummary(a));
          *end = a.Checkpointable() ? RunEnd::StoppedBySignal : RunEnd::StoppedBySignalWithoutCheckpoint;
          PetscFunctionReturn(PETSC_SUCCESS);
        }
        break;
      }
      const char *why   = outcome.why.c_str();
      const bool  retry = controller.Reject(dt, outcome.error_ratio) && !outcome.step_size_irrelevant;
      if (!options.quiet)
        PetscCall(PetscPrintf(comm, "step %5d  t = %-12.6g dt = %-10.4g rejected: %s%s\n", step + 1, t + dt, dt, why,
                              !retry                      ? ""
                              : outcome.error_ratio > 1.0 ? "; shortening"
                                                          : "; halving"));
      if (!retry) {
        // Keep what there is: the last converged state as a frame and as a checkpoint (to go on
        // with other settings, e.g. a smaller min_step).
        double strain_energy;
        if (last_written != step) {
          PetscCall(WriteFrame(a, step, t, &strain_energy));
          last_written = step;
        }
        // A restart that fails before its first step keeps the checkpoint it started from: that
        // state's checkpoint exists, and a new one would store this run's options with it (a
        // trial's -pc_type none came back with every later plain --restart).
        const bool new_state = !restart || step > restart->step;
        if (a.Checkpointable() && new_state) PetscCall(WriteCheckpoint(a, step, t, last_written, controller));
        a.output.SetRunEnd(Format("stopped at t = %.8g after step %d: the step to t = %.8g failed (%s)", t, step, t + dt, why));
        PetscCall(CloseOutput(a));
        PetscCall(PrintSummary(a));
        const std::string advice     = a.Static() ? a.path.StopAdvice() : std::string();
        const std::string checkpoint = !a.Checkpointable() ? std::string()
                                       : new_state         ? ", a checkpoint of that state in " + options.checkpoint_file
                                                           : ", and the checkpoint it started from, " + options.restart_file + ", is as it was";
        const std::string no_halving = outcome.step_size_irrelevant ? std::string("; a shorter step cannot help")
                                       : outcome.error_ratio > 1.0
                                           ? Format(" and the step its error estimate asks for is below min_step = %.6g", analysis.min_step)
                                           : Format(" and halving it would go below min_step = %.6g", analysis.min_step);
        SETERRQ(comm, PETSC_ERR_NOT_CONVERGED,
                "%s analysis stopped at t = %.8g after step %d: the step to t = %.8g failed (%s)%s%s; the results up to t = %.8g are in %s%s",
                AnalysisTypeName(analysis.type), t, step, t + dt, why, no_halving.c_str(), advice.c_str(), t, options.output_file.c_str(), checkpoint.c_str());
      }
      dt = controller.Propose(t, target);
    }
  }
  // The path's planned stop (max_steps is how an arc-length run that may never reach end_time
  // ends), not an error; said on standard error, -quiet or not, since the run did not complete.
  const bool stopped_by_max_steps = arc_length && a.path.StoppedByMaxSteps();
  a.output.SetRunEnd(stopped_by_max_steps ? Format("stopped after max_steps = %d steps at load factor %.8g", analysis.max_steps, a.path.LoadFactor())
                                          : Format("completed at t = %.8g after step %d", t, step));
  PetscCall(CloseOutput(a));
  if (stopped_by_max_steps)
    PetscCall(PetscFPrintf(comm, PETSC_STDERR,
                           "msflex: warning: stopped after max_steps = %d steps at load factor %.6g without reaching end_time = %.6g; results in %s\n",
                           analysis.max_steps, a.path.LoadFactor(), analysis.end_time, options.output_file.c_str()));
  // Under arc-length or displacement control t is the path's parameter, not the load factor.
  const bool path_parameter = a.Static() && analysis.control != PathControl::Load;
  if (!options.quiet && !stopped_by_max_steps) {
    if (path_parameter)
      PetscCall(PetscPrintf(comm, "msflex: completed %d steps to load factor %.6g (path parameter t = %.6g); results in %s\n", step, a.path.LoadFactor(), t,
                            options.output_file.c_str()));
    else PetscCall(PetscPrintf(comm, "msflex: completed %d steps to t = %.6g; results in %s\n", step, t, options.output_file.c_str()));
  }
  PetscCall(PrintSummary(a));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
