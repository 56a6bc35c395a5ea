// Gaussian elimination with partial pivoting, column by column (right-looking, as LAPACK's getf2):
//   for k = 0 .. n-1:  p = argmax_{i >= k} |a_ik| (first of equals);  swap rows k and p;
//                      l_ik = a_ik / a_kk (i > k);  a_ij -= l_ik a_kj (i, j > k)
// and the solve P A x = L U x = P b as y = L^{-1} P b (forward, unit diagonal), x = U^{-1} y (back).
#include "core/small_lu.hpp"

#include <cmath>
#include <utility>

namespace msflex {

int FactorSmallLU(int n, double *a, int *pivots)
{
  int first_zero = 0;
  for (int k = 0; k < n; ++k) {
    double *column  = a + (long)k * n;
    int     pivot   = k;
    double  largest = std::fabs(column[k]);
    for (int i = k + 1; i < n; ++i) {
      const double size = std::fabs(column[i]);
      if (size > largest) largest = size, pivot = i;
    }
    pivots[k] = pivot;
    if (column[pivot] == 0.0) { // nothing to eliminate with: U(k,k) = 0
      if (first_zero == 0) first_zero = k + 1;
      continue;
    }
    if (pivot != k)
      for (int j = 0; j < n; ++j) std::swap(a[k + (long)j * n], a[pivot + (long)j * n]);
    const double inverse = 1.0 / column[k];
    for (int i = k + 1; i < n; ++i) column[i] *= inverse;
    for (int j = k + 1; j < n; ++j) {
      double      *target = a + (long)j * n;
      const double factor = target[k];
      if (factor == 0.0) continue;
      for (int i = k + 1; i < n; ++i) target[i] -= factor * column[i];
    }
  }
  return first_zero;
}

void SolveSmallLU(int n, const double *a, const int *pivots, double *b)
{
  for (int k = 0; k < n; ++k)
    if (pivots[k] != k) std::swap(b[k], b[pivots[k]]);
  for (int j = 0; j < n; ++j) { // L y = P b, column by column
    const double  y      = b[j];
    const double *column = a + (long)j * n;
    if (y != 0.0)
      for (int i = j + 1; i < n; ++i) b[i] -= y * column[i];
  }
  for (int j = n - 1; j >= 0; --j) { // U x = y
    const double *column = a + (long)j * n;
    b[j] /= column[j];
    const double x = b[j];
    if (x != 0.0)
      for (int i = 0; i < j; ++i) b[i] -= x * column[i];
  }
}

} // namespace msflex
