// The eigenanalyses (analysis.type modes and buckling; docs/stability.md): about the reference
// configuration, or with analysis.preload about the static equilibrium under the loads at
// end_time (computed first by load-controlled steps), the matrices of the condensed system (joints
// condensed exactly as in assembly) go to SLEPc (eigen/eigen_solver.hpp):
//
//   modes      K phi = omega^2 M phi, K the tangent at the equilibrium (with its geometric
//              stiffness: pre-stress shifts the frequencies), M the mass matrix
//   buckling   K phi = -mu K_sigma phi, K_sigma = dK/dlambda along the linear path direction
//              K^{-1} q; the critical load factors are lambda_0 + mu
//
// Output: frame 0 is the equilibrium, frame k the k-th mode added to it (scaled so that its
// largest translation, or rotation times the model size, is a tenth of the model size), and one
// history row per mode (time = mode number) with its eigenvalue and frequency or load factor.
#pragma once

#include "dofs/dof_map.hpp"
#include "integrators/integrator.hpp"
#include "model/model.hpp"
#include "output/output_file.hpp"

namespace msflex {

// *stopped_by_signal: a stop signal ended the eigensolver early; the modes converged by then are
// written.
PetscErrorCode RunEigenAnalysis(MPI_Comm comm, const Model &model, const DofMap &map, Integrator &integrator, OutputFile &output, bool quiet,
                                bool *stopped_by_signal);

} // namespace msflex
