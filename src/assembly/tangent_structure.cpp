#include "assembly/tangent_structure.hpp"
#include "core/rcm_order.hpp"

#include <algorithm>
#include <cmath>

namespace msflex {

bool BlockPattern(const MatrixPattern &pattern, PetscInt first_row, PetscInt bs, std::vector<PetscInt> *diagonal, std::vector<PetscInt> *off_diagonal)
{
  const PetscInt rows = (PetscInt)pattern.diagonal_nonzeros.size();
  diagonal->clear();
  off_diagonal->clear();
  if (first_row % bs != 0 || rows % bs != 0) return false;
  for (PetscInt block = 0; block < rows / bs; ++block) {
    const PetscInt first = block * bs, begin = pattern.row_start[first], length = pattern.row_start[first + 1] - begin;
    if (length % bs != 0) return false;
    for (PetscInt r = first + 1; r < first + bs; ++r) {
      if (pattern.row_start[r + 1] - pattern.row_start[r] != length) return false;
      if (!std::equal(pattern.columns.begin() + begin, pattern.columns.begin() + begin + length, pattern.columns.begin() + pattern.row_start[r])) return false;
    }
    // Sorted columns (the CSR's) in runs of bs from multiples of bs.
    for (PetscInt k = 0; k < length; k += bs) {
      const PetscInt column = pattern.columns[begin + k];
      if (column % bs != 0) return false;
      for (PetscInt c = 1; c < bs; ++c)
        if (pattern.columns[begin + k + c] != column + c) return false;
    }
    diagonal->push_back(pattern.diagonal_nonzeros[first] / bs);
    off_diagonal->push_back(pattern.off_diagonal_nonzeros[first] / bs);
  }
  return true;
}

// envelope^2 = (1/n) sum_i (p(i) - min_{j in row i} p(j))^2, p the RCM position.
PetscErrorCode MeanSquaredRcmEnvelope(const MatrixPattern &pattern, double *mean_square)
{
  const PetscInt        n = (PetscInt)pattern.diagonal_nonzeros.size();
  std::vector<PetscInt> order, new_index(n);
  PetscFunctionBeginUser;
  *mean_square = 0.0;
  if (n == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(RcmOrder(n, pattern.row_start.data(), pattern.columns.data(), &order));
  for (PetscInt i = 0; i < n; ++i) new_index[order[i]] = i;
  double sum = 0.0;
  for (PetscInt i = 0; i < n; ++i) {
    PetscInt first = new_index[i];
    for (PetscInt k = pattern.row_start[i]; k < pattern.row_start[i + 1]; ++k) first = std::min(first, new_index[pattern.columns[k]]);
    sum += std::pow((double)(new_index[i] - first), 2);
  }
  *mean_square = sum / n;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
