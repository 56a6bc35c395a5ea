#include "app/run_eigen.hpp"

#include "core/format.hpp"
#include "eigen/eigen_solver.hpp"
#include "integrators/linearization.hpp"
#include "integrators/step_controller.hpp"
#include "integrators/tangent_factor.hpp"
#include "output/results.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace msflex {

namespace {

// The static equilibrium under the loads at end_time, by load-controlled steps with the usual step
// control; *lambda: the load factor reached. Collective.
PetscErrorCode Preload(MPI_Comm comm, const Model &model, Integrator &integrator, bool quiet, double *lambda)
{
  const AnalysisSettings &a = model.analysis;
  StepController          controller(StepControllerSettingsOf(a));
  double                  t    = 0.0;
  int                     step = 0;
  PetscFunctionBeginUser;
  while (t < a.end_time * (1.0 - 1e-14)) {
    const double dt = controller.Propose(t, a.end_time);
    StepOutcome  outcome;
    PetscCall(integrator.TryStep(t, dt, &outcome));
    if (outcome.converged) {
      t = t + dt >= a.end_time * (1.0 - 1e-14) ? a.end_time : t + dt;
      controller.Accept(dt, outcome.newton_iterations);
      ++step;
      if (!quiet)
        PetscCall(PetscPrintf(comm, "preload step %4d  t = %-12.6g dt = %-10.4g newton %2d  |R| = %.3e\n", step, t, dt, outcome.newton_iterations,
                              outcome.residual_norm));
      continue;
    }
    PetscCheck(controller.Reject(dt), comm, PETSC_ERR_NOT_CONVERGED,
               "%s analysis: the preload stopped at t = %.6g: the step to t = %.6g failed (%s) and halving it would go below min_step = %.6g",
               AnalysisTypeName(a.type), t, t + dt, outcome.why.c_str(), a.min_step);
  }
  *lambda = t;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// A frame of the state with increments x (null: the equilibrium itself) added. Collective.
PetscErrorCode WriteShapeFrame(MPI_Comm comm, const Model &model, const DofMap &map, Integrator &integrator, OutputFile &output, double lambda, Vec x,
                               int number)
{
  Assembler                  &assembler = integrator.System().GetAssembler();
  std::vector<ElementResults> results;
  OutputFrame                 frame;
  double                      strain_energy;
  PetscFunctionBeginUser;
  PetscCall(assembler.BeginStep(StaticStep(lambda, lambda)));
  if (x) PetscCall(assembler.SetIncrements(x));
  PetscCall(integrator.ElementResults(&results, &strain_energy));
  PetscCall(GatherFrame(comm, model, map, integrator.GetState(), results, number, number, false, &frame));
  PetscCall(output.WriteFrame(frame));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The mode scaled for display: its largest translation, or rotation times `length`, becomes a
// tenth of `length`, and that entry positive (a sign the same on any number of ranks). Collective.
PetscErrorCode DisplayShape(Vec mode, Vec weights, double length, Vec shape)
{
  PetscReal largest;
  PetscInt  row;
  double    value;
  PetscFunctionBeginUser;
  PetscCall(VecCopy(weights, shape));
  PetscCall(VecSqrtAbs(shape));
  PetscCall(VecPointwiseMult(shape, shape, mode));
  PetscCall(VecAbs(shape));
  PetscCall(VecMax(shape, &row, &largest));
  PetscCall(VecEntry(mode, row, &value));
  PetscCall(VecCopy(mode, shape));
  if (largest > 0) PetscCall(VecScale(shape, (value < 0 ? -0.1 : 0.1) * length / largest));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// ||A - A^T||_inf / ||A||_inf: how far a matrix the symmetric eigenproblems take is from symmetric.
PetscErrorCode RelativeAsymmetry(Mat A, double *relative)
{
  Mat       transpose;
  PetscReal difference, size;
  PetscFunctionBeginUser;
  PetscCall(MatTranspose(A, MAT_INITIAL_MATRIX, &transpose));
  PetscCall(MatAXPY(transpose, -1.0, A, DIFFERENT_NONZERO_PATTERN));
  PetscCall(MatNorm(transpose, NORM_INFINITY, &difference));
  PetscCall(MatNorm(A, NORM_INFINITY, &size));
  PetscCall(MatDestroy(&transpose));
  *relative = size > 0 ? difference / size : 0.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Non-conservative loads make the stiffness non-symmetric (a moment of fixed direction on a free
// rotation: half its cross-product matrix; a loaded bushing, whose moment turns with its nodes):
// the symmetric eigensolvers then answer with load factors that change with the number of ranks
// (a cantilever under an end moment: 51.8, 42.8 and 57.3 on 1, 2 and 4 ranks). A follower load is
// refused from the input (CheckModelForAnalysis); these show only in the matrices. The level is far
// above the finite differences of K_sigma (1e-6 of its size for a spring) and far below what a
// fixed moment gives (0.31 for a cantilever's end moment).
constexpr double kAsymmetryRefused = 1e-3;

} // namespace

// The shift-and-invert's MUMPS Cholesky takes AIJ (and SBAIJ) only: the pencil assembled as BAIJ
// or dense (-jacobian_mat_type) is converted once, when it is complete.
static PetscErrorCode ConvertForCholesky(Mat *K, Mat *B)
{
  PetscFunctionBeginUser;
  for (Mat *matrix : {K, B}) {
    PetscBool is_aij;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)*matrix, &is_aij, MATSEQAIJ, MATMPIAIJ, ""));
    if (!is_aij) PetscCall(MatConvert(*matrix, MATAIJ, MAT_INPLACE_MATRIX, matrix));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode RunEigenAnalysis(MPI_Comm comm, const Model &model, const DofMap &map, Integrator &integrator, OutputFile &output, bool quiet,
                                bool *stopped_by_signal)
{
  const AnalysisSettings &a         = model.analysis;
  const bool              buckling  = a.type == AnalysisType::Buckling;
  MechanicalSystem       &system    = integrator.System();
  Assembler              &assembler = system.GetAssembler();
  double                  lambda    = 0.0, length;
  Mat                     K, B;
  Vec                     weights, shape;
  EigenPairs              pairs;
  PetscFunctionBeginUser;
  // (No follower load here: CheckModelForAnalysis, io/input_mechanism_check.cpp.)
  PetscCall(EigenInitialize());
  // No more modes than unknowns (relays' rows are none): asked for more, the solver returned
  // what it found after a second solve, without a word.
  const PetscInt unknowns = map.NumStateUnknowns();
  const int      count    = (int)std::min<PetscInt>(a.eigenvalues, unknowns);
  if (count < a.eigenvalues && !quiet)
    PetscCall(PetscPrintf(comm, "msflex: %d modes asked for, but the model has %" PetscInt_FMT " unknowns: computing %d\n", a.eigenvalues, unknowns, count));
  if (a.preload) PetscCall(Preload(comm, model, integrator, quiet, &lambda));
  PetscCall(MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &K));
  PetscCall(MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &B));
  PetscCall(VecDuplicate(assembler.SolutionTemplate(), &weights));
  PetscCall(VecDuplicate(assembler.SolutionTemplate(), &shape));
  PetscCall(ModelLength(comm, model, map, &length));
  PetscCall(UnknownWeights(comm, model, map, integrator.GetState(), length, weights));
  PetscCall(EquilibriumTangent(system, lambda, K));
  if (!buckling) {
    PetscCall(MassMatrix(system, lambda, B));
    if (a.preload) {
      double asymmetry;
      PetscCall(RelativeAsymmetry(K, &asymmetry));
      PetscCheck(asymmetry <= kAsymmetryRefused, comm, PETSC_ERR_USER_INPUT,
                 "modes analysis: the tangent at the preload (load factor %.6g) is not symmetric (|K - K^T| = %.2g |K|), so the loads are not "
                 "conservative (a moment of fixed direction on a rotation the structure leaves free, or a loaded bushing) and the symmetric "
                 "eigenproblem would give wrong frequencies; analyse the modes without preload, or the motion by a dynamic analysis",
                 lambda, asymmetry);
    }
    PetscCall(ConvertForCholesky(&K, &B));
    PetscCall(SolveVibrationModes(K, B, count, a.shift, &pairs));
  } else {
    // The direction of the linear path, u' = K^{-1} q; K must be positive definite.
    TangentFactor  factor;
    TangentInertia inertia;
    Vec            residual, q, direction;
    PetscBool      ok;
    double         force_scale;
    PetscCall(VecDuplicate(weights, &residual));
    PetscCall(VecDuplicate(weights, &q));
    PetscCall(VecDuplicate(weights, &direction));
    PetscCall(factor.Factor(K, 1e-8, &inertia));
    PetscCheck(inertia.factored && (!inertia.symmetric || inertia.negative_pivots == 0), comm, PETSC_ERR_USER_INPUT,
               "buckling analysis: the tangent at load factor %.6g is %s, so the structure has buckled already (or is a mechanism)", lambda,
               inertia.factored ? "not positive definite" : "singular");
    PetscCall(StaticResidual(system, lambda, lambda, nullptr, residual, &ok, &force_scale));
    PetscCall(StaticLoadPattern(system, lambda, lambda, nullptr, residual, q));
    PetscCall(factor.Solve(q, direction));
    // A perturbation of 1e-4 of the model size, in translations or rotations times the size.
    PetscReal largest;
    PetscCall(VecCopy(weights, shape));
    PetscCall(VecSqrtAbs(shape));
    PetscCall(VecPointwiseMult(shape, shape, direction));
    PetscCall(VecNorm(shape, NORM_INFINITY, &largest));
    // u' = 0 (loads that deform nothing, as a weight above a hinge held by a spring): no strain rate,
    // but the loads' own stiffness (the weight's moment as its offset turns) may still buckle it.
    PetscCall(GeometricStiffness(system, model, map, lambda, direction, largest > 0 ? 1e-4 * length / largest : 1.0, B));
    // A K_sigma at K's round-off (a difference of two tangents that the loads do not change) is
    // none: it would end in "0 buckling loads found" rather than in this line.
    PetscReal load_stiffness, stiffness;
    PetscCall(MatNorm(B, NORM_INFINITY, &load_stiffness));
    PetscCall(MatNorm(K, NORM_INFINITY, &stiffness));
    PetscCheck(load_stiffness > 1e3 * std::numeric_limits<double>::epsilon() * stiffness, comm, PETSC_ERR_USER_INPUT,
               "buckling analysis: the loads neither deform the structure nor change its stiffness (no loads?)");
    double asymmetry_K, asymmetry_B;
    PetscCall(RelativeAsymmetry(K, &asymmetry_K));
    PetscCall(RelativeAsymmetry(B, &asymmetry_B));
    PetscCheck(asymmetry_K <= kAsymmetryRefused && asymmetry_B <= kAsymmetryRefused, comm, PETSC_ERR_USER_INPUT,
               "buckling analysis: the %s is not symmetric (|A - A^T| = %.2g |A|), so the loads are not conservative (a moment of fixed direction on a "
               "rotation the structure leaves free, or a loaded bushing) and the symmetric eigenproblem would give wrong load factors; follow the "
               "equilibrium path instead (type: static, control: arc_length), whose stability account finds the critical points",
               asymmetry_B > kAsymmetryRefused ? "load stiffness K_sigma" : "tangent", asymmetry_B > kAsymmetryRefused ? asymmetry_B : asymmetry_K);
    PetscCall(ConvertForCholesky(&K, &B));
    PetscCall(SolveBucklingModes(K, B, count, &pairs));
    PetscCall(VecDestroy(&residual));
    PetscCall(VecDestroy(&q));
    PetscCall(VecDestroy(&direction));
  }
  *stopped_by_signal = pairs.stopped_by_signal;
  if (!quiet && !buckling && pairs.ran_out)
    PetscCall(PetscPrintf(comm,
                          "msflex: %zu modes found of the %d asked for; the other eigenvalues are infinite (motions without mass: rotations without rhoJ)\n",
                          pairs.values.size(), count));
  if (!quiet && buckling && (int)pairs.values.size() < count && !pairs.stopped_by_signal)
    PetscCall(PetscPrintf(
        comm, "msflex: %zu buckling loads found of the %d asked for; the other eigenvalues give none (a load factor below zero, or none within round-off)\n",
        pairs.values.size(), count));
  if (!quiet) {
    PetscCall(PetscPrintf(comm, "msflex: %zu %s%s about the %s at load factor %.6g", pairs.values.size(), buckling ? "buckling modes" : "modes",
                          buckling
                              ? ""
                              : Format(" (%s at %.6g, %d solve%s)",
                                       pairs.transformation == "sinvert" ? "shift-and-invert" : ("spectral transformation " + pairs.transformation).c_str(),
                                       pairs.shift, pairs.solves, pairs.solves == 1 ? "" : "s")
                                    .c_str(),
                          a.preload ? "equilibrium" : "reference configuration (no preload)", lambda));
    PetscCall(PetscPrintf(comm, buckling ? "\n  mode  load factor          backward error\n"
                                         : "\n  mode  eigenvalue (rad/s)^2  frequency (Hz)       backward error\n"));
  }
  PetscCall(WriteShapeFrame(comm, model, map, integrator, output, lambda, nullptr, 0));
  int unstable = 0; // modes with a negative eigenvalue beyond the rigid level
  for (size_t k = 0; k < pairs.values.size(); ++k) {
    const int    number = (int)k + 1;
    const double value = pairs.values[k], error = pairs.backward_errors[k];
    // A rigid mode (a mechanism's free motion) has lambda at round-off.
    const bool   rigid = !buckling && std::abs(value) <= pairs.zero_levels[k];
    const double omega = !buckling && value > 0 && !rigid ? std::sqrt(value) : 0.0;
    unstable += !buckling && !rigid && value < 0;
    std::vector<std::string> names  = {"time", "step", "mode"};
    std::vector<double>      values = {(double)number, (double)number, (double)number};
    if (buckling) {
      names.insert(names.end(), {"load_factor", "eigenvalue", "backward_error"});
      values.insert(values.end(), {lambda + value, value, error});
    } else {
      names.insert(names.end(), {"eigenvalue", "angular_frequency", "frequency", "rigid_mode", "backward_error"});
      values.insert(values.end(), {value, omega, omega / (2.0 * M_PI), rigid ? 1.0 : 0.0, error});
    }
    if (!quiet) {
      if (buckling) PetscCall(PetscPrintf(comm, "  %4d  %-19.12g  %.2e\n", number, lambda + value, error));
      else
        PetscCall(PetscPrintf(comm, "  %4d  %-20.12g  %-19.12g  %.2e%s\n", number, value, omega / (2.0 * M_PI), error,
                              rigid       ? "  (rigid mode)"
                              : value < 0 ? "  (unstable: no frequency)"
                                          : ""));
    }
    PetscCall(DisplayShape(pairs.vectors[k], weights, length, shape));
    PetscCall(WriteShapeFrame(comm, model, map, integrator, output, lambda, shape, number));
    std::vector<ProbeSample> probes;
    PetscCall(SampleProbes(comm, model, map, integrator.GetState(), &probes));
    PetscCall(output.AppendHistory(names, values, probes));
  }
  // Negative eigenvalues beyond the rigid level: the state is not stable (a preload beyond a
  // critical load); their frequency is written as 0, which read like a rigid mode's.
  if (unstable > 0 && !quiet)
    PetscCall(PetscPrintf(comm,
                          "msflex: warning: %d mode(s) with a negative eigenvalue: the %s at load factor %.6g is unstable (a preload beyond a critical load?); "
                          "their frequency is written as 0 and rigid_mode as 0\n",
                          unstable, a.preload ? "equilibrium" : "reference configuration", lambda));
  PetscCall(assembler.BeginStep(StaticStep(lambda, lambda)));
  PetscCall(EigenPairsDestroy(&pairs));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&B));
  PetscCall(VecDestroy(&weights));
  PetscCall(VecDestroy(&shape));
  PetscCall(EigenFinalize());
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
