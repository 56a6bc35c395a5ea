#include "core/rcm_order.hpp"

namespace msflex {

PetscErrorCode RcmOrder(PetscInt n, const PetscInt *row_start, const PetscInt *columns, std::vector<PetscInt> *order)
{
  Mat             wrapper;
  IS              row_permutation, column_permutation;
  const PetscInt *indices;
  PetscFunctionBeginUser;
  order->clear();
  if (n == 0) PetscFunctionReturn(PETSC_SUCCESS);
  // MatCreateSeqAIJWithArrays takes non-const arrays.
  std::vector<PetscInt> starts(row_start, row_start + n + 1), cols(columns, columns + row_start[n]);
  std::vector<double>   zeros(cols.size(), 0.0);
  PetscCall(MatCreateSeqAIJWithArrays(PETSC_COMM_SELF, n, n, starts.data(), cols.data(), zeros.data(), &wrapper));
  PetscCall(MatGetOrdering(wrapper, MATORDERINGRCM, &row_permutation, &column_permutation));
  PetscCall(MatDestroy(&wrapper));
  PetscCall(ISGetIndices(row_permutation, &indices));
  order->assign(indices, indices + n);
  PetscCall(ISRestoreIndices(row_permutation, &indices));
  PetscCall(ISDestroy(&row_permutation));
  PetscCall(ISDestroy(&column_permutation));
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
