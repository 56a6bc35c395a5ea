// LU factorisation with partial pivoting of a small dense matrix, written out: a model of a few
// unknowns factors its tangent at every Newton iteration, and LAPACK's getrf (with getrs) spends
// more on its blocked machinery than on the arithmetic there (0.54 against 1.08 us at 13
// unknowns). Pure: no PETSc, no MPI.
#pragma once

namespace msflex {

// Above this many unknowns LAPACK's blocked getrf is the faster (msflex's dense LU switches to it).
constexpr int kSmallLUMaxSize = 64;

// P A = L U, A n x n column-major (a[i + n j]), overwritten by L (unit lower, below the diagonal)
// and U (on and above). Column k's pivot is the first row i >= k with the largest |a_ik| (LAPACK
// getf2's rule); pivots[k] = that row (0-based), swapped with row k across the whole matrix.
// Returns 0, or k + 1 for the first column whose pivot is exactly zero: U is then singular, and
// that column is left uneliminated as getrf leaves it.
int FactorSmallLU(int n, double *a, int *pivots);

// Solves A x = b with the factors of FactorSmallLU (no zero pivot): b is overwritten by
// x = U^{-1} L^{-1} P b.
void SolveSmallLU(int n, const double *a, const int *pivots, double *b);

} // namespace msflex
