#include "assembly/tangent_structure.hpp"

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

// envelope^2 = (1/n) sum_i (p(i) - min_{j in row i} p(j))^2, p the RCM position. PETSc orders
// matrices, not patterns: the pattern is wrapped (no copy) in a sequential AIJ matrix of zeros.
PetscErrorCode MeanSquaredRcmEnvelope(const MatrixPattern &pattern, double *mean_square)
{
  const PetscInt        n = (PetscInt)pattern.diagonal_nonzeros.size();
  Mat                   wrapper;
  IS                    row_permutation, column_permutation, inverse;
  const PetscInt       *new_index;
  std::vector<PetscInt> row_start(pattern.row_start), columns(pattern.columns); // MatCreateSeqAIJWithArrays takes non-const arrays
  std::vector<double>   zeros(columns.size(), 0.0);
  PetscFunctionBeginUser;
  *mean_square = 0.0;
  if (n == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MatCreateSeqAIJWithArrays(PETSC_COMM_SELF, n, n, row_start.data(), columns.data(), zeros.data(), &wrapper));
  PetscCall(MatGetOrdering(wrapper, MATORDERINGRCM, &row_permutation, &column_permutation));
  PetscCall(MatDestroy(&wrapper));
  PetscCall(ISInvertPermutation(row_permutation, PETSC_DECIDE, &inverse));
  PetscCall(ISGetIndices(inverse, &new_index));
  double sum = 0.0;
  for (PetscInt i = 0; i < n; ++i) {
    PetscInt first = new_index[i];
    for (PetscInt k = row_start[i]; k < row_start[i + 1]; ++k) first = std::min(first, new_index[columns[k]]);
    sum += std::pow((double)(new_index[i] - first), 2);
  }
  *mean_square = sum / n;
  PetscCall(ISRestoreIndices(inverse, &new_index));
  PetscCall(ISDestroy(&inverse));
  PetscCall(ISDestroy(&row_permutation));
  PetscCall(ISDestroy(&column_permutation));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
