// Generalised symmetric eigenproblems of the assembled system with SLEPc (docs/stability.md). The
// matrices come from the integrators layer (integrators/linearization.hpp); this layer knows
// nothing of the model. Every solver option of SLEPc (-eps_*, -st_*, -st_ksp_*, -st_pc_*,
// -st_mat_mumps_*) is honoured: they are read after the defaults below are set.
//
//  modes      K phi = lambda M phi, lambda = omega^2: Krylov-Schur on the shift-and-invert
//             operator (K - sigma M)^{-1} M, factored by MUMPS Cholesky, the eigenvalues nearest
//             sigma. K is singular where the model can move as a mechanism (rigid modes at
//             lambda = 0), so sigma must then be negative, not tiny: without a given shift a first
//             solve at sigma = 0 estimates the first elastic eigenvalue lambda_1, and if it finds
//             rigid modes (|lambda| <= 1e-6 max |lambda|) or inaccurate pairs a second solve at
//             sigma = -1e-2 lambda_1 gives the answer. M may be singular (massless DOFs): their
//             eigenvalues are infinite and never wanted; SLEPc's purification keeps the vectors
//             free of them.
//  buckling   K phi = -mu K_sigma phi, as (-K_sigma) phi = nu K phi with nu = 1/mu and K
//             positive definite: the largest nu are the smallest positive mu (Krylov-Schur with
//             K^{-1} by MUMPS Cholesky); negative mu (buckling under the reversed loads) are not
//             reported.
#pragma once

#include <petscmat.h>

#include <string>
#include <vector>

namespace msflex {

struct EigenPairs {
  std::vector<double> values;          // ascending (modes: lambda; buckling: mu)
  std::vector<double> backward_errors; // ||A x - lambda B x|| / ((||A|| + |lambda| ||B||) ||x||)
  std::vector<Vec>    vectors;         // owned by the caller (EigenPairsDestroy); B-normalised
  double              shift = 0.0;     // the shift of the final solve (modes)
  // Modes, per pair: the magnitude below which its eigenvalue is zero within round-off, a rigid
  // mode: max(1e-6 |shift|, 3 eps max_i |K_ii| |phi|^2) with phi M-normalised. A backward-stable
  // solve perturbs K by about eps ||K||, which moves lambda = phi^T K phi by eps ||K|| |phi|^2: the
  // level of the mode's own round-off (3: eigen_solver.cpp says why). (One level for all modes,
  // 1e3 eps max_i K_ii / M_ii, took the bending modes of a slender wire, whose tiny rotary inertia
  // makes that ratio huge, for rigid ones; a factor 1e3 here took the sway mode of a portal frame
  // near buckling for one.)
  std::vector<double> zero_levels;
  int                 solves = 0;                // 1, or 2 when a first solve only estimated the spectrum
  std::string         transformation;            // the spectral transformation of the final solve (sinvert, or what -st_type chose)
  bool                ran_out           = false; // modes: fewer found than asked, the others infinite (motions without mass)
  bool                stopped_by_signal = false; // the solve ended early on a stop signal, with the pairs converged by then
};

// SLEPc is initialised on first use, PETSc being initialised already; EigenFinalize ends it.
PetscErrorCode EigenInitialize();
PetscErrorCode EigenFinalize();
// The eigensolver options (-eps_*, -st_*, ...) read as the eigenanalyses read them, when any is
// given: a bad value is one line before any file is created or replaced, not an error after the
// result file was replaced. Collective.
PetscErrorCode CheckEigenOptions(MPI_Comm comm);
PetscErrorCode EigenPairsDestroy(EigenPairs *pairs);

// The `count` lowest eigenpairs of K phi = lambda M phi. `shift`: the shift of shift-and-invert,
// NaN to choose it (see above). Collective.
PetscErrorCode SolveVibrationModes(Mat K, Mat M, int count, double shift, EigenPairs *pairs);
// The `count` smallest positive mu of K phi = -mu K_sigma phi. Collective.
PetscErrorCode SolveBucklingModes(Mat K, Mat K_sigma, int count, EigenPairs *pairs);

} // namespace msflex
