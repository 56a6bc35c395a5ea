#include "integrators/static_solver.hpp"

#include "assembly/assembler.hpp"
#include "core/errors.hpp"
#include "integrators/newton.hpp"
#include "integrators/step_controller.hpp"
#include "output/results.hpp"
#include "parallel/partition.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

namespace {

// The next time the steps must land on: the first requested output time after t, or the end.
double NextTarget(const AnalysisSettings &analysis, double t)
{
  for (double output_time : analysis.output_times)
    if (output_time > t * (1.0 + 1e-12) + 1e-14) return std::min(output_time, analysis.end_time);
  return analysis.end_time;
}

struct StepRecord {
  int    step;
  double time, step_size;
  int    newton_iterations;
  double residual_norm;
};

PetscErrorCode WriteHistory(MPI_Comm comm, const Model &model, Assembler &assembler, OutputFile &output, const StepRecord &record, double strain_energy)
{
  std::vector<ProbeSample> probes;
  PetscFunctionBeginUser;
  PetscCall(SampleProbes(comm, model, assembler, &probes));
  const std::vector<std::string> names  = {"time", "step", "step_size", "newton_iterations", "residual_norm", "strain_energy"};
  const std::vector<double>      values = {record.time, (double)record.step, record.step_size, (double)record.newton_iterations, record.residual_norm, strain_energy};
  PetscCall(output.AppendHistory(names, values, probes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode WriteFrame(MPI_Comm comm, const Model &model, Assembler &assembler, OutputFile &output, int step, double time, double *strain_energy)
{
  std::vector<ElementResults> results;
  OutputFrame                 frame;
  PetscFunctionBeginUser;
  PetscCall(assembler.EvaluateResults(&results, strain_energy));
  PetscCall(GatherFrame(comm, model, assembler, results, step, time, &frame));
  PetscCall(output.WriteFrame(frame));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode RunStaticAnalysis(MPI_Comm comm, const Model &model, const RunOptions &options)
{
  const AnalysisSettings &analysis = model.analysis;
  PetscLogStage           stage_setup, stage_solve, stage_output;
  PetscFunctionBeginUser;
  PetscCall(PetscLogStageRegister("Setup", &stage_setup));
  PetscCall(PetscLogStageRegister("Solve", &stage_solve));
  PetscCall(PetscLogStageRegister("Output", &stage_output));

  PetscCall(PetscLogStagePush(stage_setup));
  PartitionerType  partitioner;
  std::vector<int> node_rank;
  DofMap           map;
  Assembler        assembler;
  PetscCall(PartitionerTypeFromOptions(comm, &partitioner));
  PetscCall(PartitionNodes(comm, model, partitioner, &node_rank));
  PetscCall(DofMapCreate(comm, model, node_rank, &map));
  PetscCall(assembler.Setup(comm, model, map));
  NewtonContext context;
  context.assembler = &assembler;
  SNES snes;
  PetscCall(NewtonSolverCreate(comm, analysis, &context, &snes));
  Vec increments;
  PetscCall(VecDuplicate(assembler.SolutionTemplate(), &increments));
  OutputMesh mesh;
  BuildOutputMesh(model, &mesh);
  OutputFile output;
  PetscCall(output.Open(comm, options.output_file, options.output_overwrite, model.input_file, model.input_text, mesh));
  PetscCall(PetscLogStagePop());

  if (!options.quiet)
    PetscCall(PetscPrintf(comm, "msflex: static analysis of '%s': %zu nodes, %zu elements, %" PetscInt_FMT " unknowns; output %s\n", model.input_file.c_str(),
                          model.nodes.size(), model.elements.size(), map.num_global, options.output_file.c_str()));

  double strain_energy = 0.0;
  PetscCall(PetscLogStagePush(stage_output));
  PetscCall(WriteFrame(comm, model, assembler, output, 0, 0.0, &strain_energy));
  PetscCall(WriteHistory(comm, model, assembler, output, {0, 0.0, 0.0, 0, 0.0}, strain_energy));
  PetscCall(PetscLogStagePop());

  StepControllerSettings controller_settings;
  controller_settings.initial_step       = analysis.initial_step;
  controller_settings.min_step           = analysis.min_step;
  controller_settings.max_step           = analysis.max_step;
  controller_settings.growth_factor      = analysis.growth_factor;
  controller_settings.easy_iterations    = analysis.easy_iterations;
  controller_settings.easy_steps_to_grow = analysis.easy_steps_to_grow;
  StepController controller(controller_settings);

  double t = 0.0;
  int    step = 0, last_written = 0;
  while (t < analysis.end_time * (1.0 - 1e-14)) {
    const double target = NextTarget(analysis, t);
    double       dt     = controller.Propose(t, target);
    for (;;) {
      PetscCall(PetscLogStagePush(stage_solve));
      PetscCall(assembler.BeginStep(t, t + dt));
      PetscCall(VecZeroEntries(increments));
      PetscCall(SNESSolve(snes, nullptr, increments));
      PetscCall(assembler.SetIncrements(increments));
      PetscCall(PetscLogStagePop());
      SNESConvergedReason reason;
      PetscInt            iterations;
      PetscReal           residual_norm;
      double              max_rotation = 0.0;
      PetscCall(SNESGetConvergedReason(snes, &reason));
      PetscCall(SNESGetIterationNumber(snes, &iterations));
      PetscCall(SNESGetFunctionNorm(snes, &residual_norm));
      if (reason > 0) PetscCall(assembler.MaxRotationIncrement(&max_rotation));
      const bool rotation_too_large = max_rotation > analysis.max_rotation_increment;
      if (reason > 0 && !rotation_too_large) {
        PetscCall(assembler.CommitStep());
        t = (t + dt >= target * (1.0 - 1e-14)) ? target : t + dt;
        ++step;
        controller.Accept(dt, (int)iterations);
        PetscCall(PetscLogStagePush(stage_output));
        const bool write_frame = (step % options.output_every == 0) || t >= analysis.end_time * (1.0 - 1e-14) ||
                                 std::find(analysis.output_times.begin(), analysis.output_times.end(), t) != analysis.output_times.end();
        if (write_frame) {
          PetscCall(WriteFrame(comm, model, assembler, output, step, t, &strain_energy));
          last_written = step;
        } else {
          std::vector<ElementResults> unused;
          PetscCall(assembler.EvaluateResults(&unused, &strain_energy));
        }
        PetscCall(WriteHistory(comm, model, assembler, output, {step, t, dt, (int)iterations, residual_norm}, strain_energy));
        PetscCall(PetscLogStagePop());
        if (!options.quiet)
          PetscCall(PetscPrintf(comm, "step %5d  t = %-12.6g dt = %-10.4g newton %2" PetscInt_FMT "  |R| = %.3e  strain energy = %.6e\n", step, t, dt, iterations,
                                residual_norm, strain_energy));
        break;
      }
      PetscCall(assembler.DiscardStep());
      const char *why = rotation_too_large ? "rotation increment above max_rotation_increment" : SNESConvergedReasons[reason];
      const bool  retry = controller.Reject(dt);
      if (!options.quiet) PetscCall(PetscPrintf(comm, "step %5d  t = %-12.6g dt = %-10.4g rejected (%s): halving\n", step + 1, t + dt, dt, why));
      if (!retry) {
        if (last_written != step) PetscCall(WriteFrame(comm, model, assembler, output, step, t, &strain_energy));
        PetscCall(output.Close());
        PetscCall(VecDestroy(&increments));
        PetscCall(SNESDestroy(&snes));
        SETERRQ(comm, PETSC_ERR_NOT_CONVERGED,
                "static analysis stopped at t = %g after step %d: the step to t = %g failed (%s) and halving it would go below min_step = %g; the "
                "results up to t = %g are in %s",
                t, step, t + dt, why, analysis.min_step, t, options.output_file.c_str());
      }
      dt = controller.Propose(t, target);
    }
  }
  PetscCall(output.Close());
  if (!options.quiet) PetscCall(PetscPrintf(comm, "msflex: completed %d steps to t = %g; results in %s\n", step, t, options.output_file.c_str()));
  PetscCall(VecDestroy(&increments));
  PetscCall(SNESDestroy(&snes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
