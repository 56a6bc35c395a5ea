#include "integrators/tangent_factor.hpp"
#include "core/dense_lu.hpp"

#include <cmath>

namespace msflex {

TangentFactor::~TangentFactor()
{
  MatDestroy(&factor_);
  VecDestroy(&work_[0]);
  VecDestroy(&work_[1]);
}

namespace {

// ||K - K^T||_F / ||K||_F. Collective.
PetscErrorCode Asymmetry(Mat K, double *asymmetry)
{
  Mat       transpose;
  PetscReal norm, difference;
  PetscFunctionBeginUser;
  PetscCall(MatNorm(K, NORM_FROBENIUS, &norm));
  PetscCall(MatTranspose(K, MAT_INITIAL_MATRIX, &transpose));
  PetscCall(MatAXPY(transpose, -1.0, K, DIFFERENT_NONZERO_PATTERN));
  PetscCall(MatNorm(transpose, NORM_FROBENIUS, &difference));
  PetscCall(MatDestroy(&transpose));
  *asymmetry = norm > 0 ? difference / norm : 0.0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace

PetscErrorCode TangentFactor::Factor(Mat tangent, double symmetry_tolerance, TangentInertia *inertia)
{
  PetscBool is_aij;
  Mat       K = tangent, converted = nullptr;
  PetscFunctionBeginUser;
  // MUMPS counts pivots of AIJ matrices only (a BAIJ or dense -jacobian_mat_type is converted).
  PetscCall(PetscObjectTypeCompareAny((PetscObject)tangent, &is_aij, MATSEQAIJ, MATMPIAIJ, ""));
  if (!is_aij) {
    PetscCall(MatConvert(tangent, MATAIJ, MAT_INITIAL_MATRIX, &converted));
    K = converted;
  }
  const PetscErrorCode code = FactorAij(K, symmetry_tolerance, inertia);
  PetscCall(MatDestroy(&converted));
  PetscCall(code);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::FactorAij(Mat K, double symmetry_tolerance, TangentInertia *inertia)
{
  MatFactorInfo info;
  IS            row_order, column_order;
  PetscFunctionBeginUser;
  *inertia = TangentInertia{};
  PetscCall(MatDestroy(&factor_));
  if (!work_[0]) {
    PetscCall(MatCreateVecs(K, &work_[0], &work_[1]));
  }
  PetscCall(Asymmetry(K, &inertia->asymmetry));
  inertia->symmetric = inertia->asymmetry <= symmetry_tolerance;
  PetscCall(MatGetFactor(K, MATSOLVERMUMPS, inertia->symmetric ? MAT_FACTOR_CHOLESKY : MAT_FACTOR_LU, &factor_));
  if (inertia->symmetric) {
    // No ScaLAPACK on the root front: MUMPS counts the negative pivots of every front only then.
    PetscCall(MatMumpsSetIcntl(factor_, 13, 1));
  } else {
    PetscCall(MatMumpsSetIcntl(factor_, 33, 1)); // the determinant
  }
  if (num_relays_ > 0) PetscCall(MatMumpsSetIcntl(factor_, 14, kRelayMumpsWorkspace));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatGetOrdering(K, MATORDERINGNATURAL, &row_order, &column_order));
  // A singular tangent makes MUMPS fail (INFOG(1) < 0): that is an answer here, not an error.
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  PetscErrorCode code =
      inertia->symmetric ? MatCholeskyFactorSymbolic(factor_, K, row_order, &info) : MatLUFactorSymbolic(factor_, K, row_order, column_order, &info);
  if (code == PETSC_SUCCESS) code = inertia->symmetric ? MatCholeskyFactorNumeric(factor_, K, &info) : MatLUFactorNumeric(factor_, K, &info);
  PetscCall(PetscPopErrorHandler());
  PetscCall(ISDestroy(&row_order));
  PetscCall(ISDestroy(&column_order));
  MatFactorError error = MAT_FACTOR_NOERROR;
  if (code == PETSC_SUCCESS) PetscCall(MatFactorGetError(factor_, &error));
  int local_ok = code == PETSC_SUCCESS && error == MAT_FACTOR_NOERROR, ok;
  PetscCall(MPIU_Allreduce(&local_ok, &ok, 1, MPI_INT, MPI_LAND, PetscObjectComm((PetscObject)K)));
  if (!ok) {
    PetscCall(MatDestroy(&factor_));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  inertia->factored = true;
  if (inertia->symmetric) {
    PetscCall(MatMumpsGetInfog(factor_, 12, &inertia->negative_pivots));
    inertia->negative_pivots -= 6 * num_relays_;
    inertia->determinant_sign = inertia->negative_pivots % 2 == 0 ? 1 : -1;
  } else {
    PetscReal mantissa;
    PetscCall(MatMumpsGetRinfog(factor_, 12, &mantissa));
    inertia->determinant_sign = mantissa > 0 ? 1 : mantissa < 0 ? -1 : 0;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::Solve(Vec b, Vec x)
{
  PetscFunctionBeginUser;
  PetscCheck(factor_, PetscObjectComm((PetscObject)b), PETSC_ERR_ARG_WRONGSTATE, "the tangent has not been factored");
  PetscCall(MatSolve(factor_, b, x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::LowestEigenvalue(Vec D, Vec mode, double *mu)
{
  Vec         Dv = work_[0], x = work_[1];
  PetscScalar vDv, theta;
  double      previous = 0.0;
  PetscFunctionBeginUser;
  *mu = NAN;
  PetscCall(VecPointwiseMult(Dv, D, mode));
  PetscCall(VecDot(mode, Dv, &vDv));
  PetscCheck(PetscRealPart(vDv) > 0, PetscObjectComm((PetscObject)mode), PETSC_ERR_ARG_WRONG, "the start vector of the inverse iteration is zero");
  PetscCall(VecScale(mode, 1.0 / std::sqrt(PetscRealPart(vDv))));
  // Converges at the rate |mu_1 / mu_2|, fast near a critical point where mu_1 -> 0.
  for (int iteration = 0; iteration < 100; ++iteration) {
    PetscCall(VecPointwiseMult(Dv, D, mode));
    PetscCall(MatSolve(factor_, Dv, x));
    PetscCall(VecDot(x, Dv, &theta));
    if (PetscRealPart(theta) == 0.0) break;
    *mu = 1.0 / PetscRealPart(theta);
    PetscCall(VecPointwiseMult(Dv, D, x));
    PetscCall(VecDot(x, Dv, &vDv));
    PetscCall(VecCopy(x, mode));
    PetscCall(VecScale(mode, 1.0 / std::sqrt(PetscRealPart(vDv))));
    if (iteration > 0 && std::abs(*mu - previous) <= 1e-10 * std::abs(*mu)) break;
    previous = *mu;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
