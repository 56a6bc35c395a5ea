#include "integrators/tangent_factor.hpp"
#include "core/dense_lu.hpp"

#include <petscblaslapack.h>

#include <Eigen/Eigenvalues>

#include <algorithm>

#include <cmath>

namespace msflex {

namespace {
// Lanczos steps before a restart from the Ritz vector, and the restarts before giving up.
constexpr int kLanczosSteps = 12, kLanczosRestarts = 8;
} // namespace

TangentFactor::~TangentFactor()
{
  MatDestroy(&factor_);
  VecDestroy(&work_[0]);
  VecDestroy(&work_[1]);
  if (basis_) VecDestroyVecs(kLanczosSteps + 1, &basis_);
  if (scaled_basis_) VecDestroyVecs(kLanczosSteps + 1, &scaled_basis_);
}

namespace {

// ||K - K^T||_F / ||K||_F. Collective. On one rank from the CSR arrays in place: each stored
// entry (i, j) meets its transpose by a binary search in row j; an entry whose transpose is not
// stored counts twice (K - K^T has -v at (j, i)). On more ranks by an explicit transpose.
PetscErrorCode Asymmetry(Mat K, double *asymmetry)
{
  PetscBool seqaij;
  PetscFunctionBeginUser;
  PetscCall(PetscObjectTypeCompare((PetscObject)K, MATSEQAIJ, &seqaij));
  if (seqaij) {
    const PetscInt    *row_start, *columns;
    const PetscScalar *values;
    PetscInt           n;
    PetscBool          done;
    double             norm2 = 0.0, difference2 = 0.0;
    PetscCall(MatGetRowIJ(K, 0, PETSC_FALSE, PETSC_FALSE, &n, &row_start, &columns, &done));
    PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_PLIB, "cannot read the tangent's rows");
    PetscCall(MatSeqAIJGetArrayRead(K, &values));
    for (PetscInt i = 0; i < n; ++i)
      for (PetscInt k = row_start[i]; k < row_start[i + 1]; ++k) {
        const PetscInt  j     = columns[k];
        const double    value = PetscRealPart(values[k]);
        const PetscInt *end   = columns + row_start[j + 1];
        const PetscInt *at    = std::lower_bound(columns + row_start[j], end, i);
        norm2 += value * value;
        if (at != end && *at == i) {
          const double difference = value - PetscRealPart(values[at - columns]);
          difference2 += difference * difference;
        } else difference2 += 2.0 * value * value;
      }
    PetscCall(MatSeqAIJRestoreArrayRead(K, &values));
    PetscCall(MatRestoreRowIJ(K, 0, PETSC_FALSE, PETSC_FALSE, &n, &row_start, &columns, &done));
    *asymmetry = norm2 > 0 ? std::sqrt(difference2 / norm2) : 0.0;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  Mat       transpose;
  PetscReal norm, difference;
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
  PetscBool is_aij, is_dense;
  Mat       converted = nullptr;
  PetscFunctionBeginUser;
  *inertia = TangentInertia{};
  if (!work_[0]) PetscCall(MatCreateVecs(tangent, &work_[0], &work_[1]));
  PetscCall(PetscObjectTypeCompare((PetscObject)tangent, MATSEQDENSE, &is_dense));
  if (is_dense) {
    // A small model's tangent: LAPACK, not a MUMPS instance per equilibrium (whose creation alone
    // cost 3.4 ms per load step of a 4-element cantilever).
    PetscCall(MatDestroy(&factor_));
    analysed_matrix_ = -1;
    PetscCall(FactorDense(tangent, symmetry_tolerance, inertia));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  dense_ = false;
  // MUMPS counts pivots of AIJ matrices only (a BAIJ -jacobian_mat_type is converted, a new
  // matrix every time, so its analysis is not kept).
  PetscCall(PetscObjectTypeCompareAny((PetscObject)tangent, &is_aij, MATSEQAIJ, MATMPIAIJ, ""));
  if (!is_aij) PetscCall(MatConvert(tangent, MATAIJ, MAT_INITIAL_MATRIX, &converted));
  const PetscErrorCode code = FactorAij(is_aij ? tangent : converted, symmetry_tolerance, is_aij, inertia);
  if (converted) analysed_matrix_ = -1;
  PetscCall(MatDestroy(&converted));
  PetscCall(code);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::FactorAij(Mat K, double symmetry_tolerance, bool may_reuse, TangentInertia *inertia)
{
  PetscObjectState pattern;
  PetscInt64       id;
  PetscFunctionBeginUser;
  PetscCall(Asymmetry(K, &inertia->asymmetry));
  inertia->symmetric = inertia->asymmetry <= symmetry_tolerance;
  PetscCall(MatGetNonzeroState(K, &pattern));
  PetscCall(PetscObjectGetId((PetscObject)K, &id));
  // MUMPS' analysis (ordering, symbolic factorisation) depends on the pattern and the kind only:
  // the next equilibrium's tangent of the same matrix and kind needs the numerical factorisation
  // alone. Where that fails, a fresh analysis decides before K is called singular.
  const bool reuse = may_reuse && factor_ && analysed_matrix_ == id && analysed_pattern_ == pattern && analysed_symmetric_ == inertia->symmetric;
  PetscCall(FactorMumps(K, reuse, inertia));
  if (!inertia->factored && reuse) PetscCall(FactorMumps(K, false, inertia));
  analysed_matrix_    = inertia->factored ? id : -1;
  analysed_pattern_   = pattern;
  analysed_symmetric_ = inertia->symmetric;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::FactorMumps(Mat K, bool reuse_analysis, TangentInertia *inertia)
{
  MatFactorInfo  info;
  IS             row_order = nullptr, column_order = nullptr;
  const bool     symmetric = inertia->symmetric;
  PetscErrorCode code      = PETSC_SUCCESS;
  PetscFunctionBeginUser;
  inertia->factored = false;
  PetscCall(MatFactorInfoInitialize(&info));
  if (!reuse_analysis) {
    PetscCall(MatDestroy(&factor_));
    PetscCall(MatGetFactor(K, MATSOLVERMUMPS, symmetric ? MAT_FACTOR_CHOLESKY : MAT_FACTOR_LU, &factor_));
    if (symmetric) {
      // No ScaLAPACK on the root front: MUMPS counts the negative pivots of every front only then.
      PetscCall(MatMumpsSetIcntl(factor_, 13, 1));
    } else {
      PetscCall(MatMumpsSetIcntl(factor_, 33, 1)); // the determinant
    }
    if (num_relays_ > 0) PetscCall(MatMumpsSetIcntl(factor_, 14, kRelayMumpsWorkspace));
    PetscCall(MatGetOrdering(K, MATORDERINGNATURAL, &row_order, &column_order));
  }
  // A singular tangent makes MUMPS fail (INFOG(1) < 0): that is an answer here, not an error.
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, nullptr));
  if (!reuse_analysis)
    code = symmetric ? MatCholeskyFactorSymbolic(factor_, K, row_order, &info) : MatLUFactorSymbolic(factor_, K, row_order, column_order, &info);
  if (code == PETSC_SUCCESS) code = symmetric ? MatCholeskyFactorNumeric(factor_, K, &info) : MatLUFactorNumeric(factor_, K, &info);
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
  symmetric_        = symmetric;
  if (symmetric) {
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

// A dense K (one rank): symmetric to the tolerance, LAPACK's Bunch-Kaufman LDL^T (sytrf), whose
// block-diagonal D has K's inertia (Sylvester): a 1x1 block d counts one negative pivot if d < 0, a
// 2x2 block [a b; b c] one if its determinant ac - b^2 < 0 (one eigenvalue of each sign), two if
// it is positive and a < 0; otherwise LU (getrf), det K = (-1)^(row swaps) prod U_ii. An exactly
// zero pivot (info > 0) is a singular K, not factored, as MUMPS' failure is.
PetscErrorCode TangentFactor::FactorDense(Mat K, double symmetry_tolerance, TangentInertia *inertia)
{
  const PetscScalar *a;
  PetscInt           n, lda;
  PetscBLASInt       info = 0;
  PetscFunctionBeginUser;
  dense_ = false;
  PetscCall(MatGetSize(K, &n, nullptr));
  PetscCall(MatDenseGetLDA(K, &lda));
  PetscCall(PetscBLASIntCast(n, &dense_n_));
  dense_factors_.resize((size_t)n * (size_t)n);
  dense_pivots_.resize((size_t)n);
  double norm2 = 0.0, difference2 = 0.0;
  PetscCall(MatDenseGetArrayRead(K, &a));
  for (PetscInt j = 0; j < n; ++j)
    for (PetscInt i = 0; i < n; ++i) {
      const double value = PetscRealPart(a[i + j * lda]), difference = value - PetscRealPart(a[j + i * lda]);
      norm2 += value * value;
      difference2 += difference * difference;
      dense_factors_[(size_t)(i + j * n)] = a[i + j * lda];
    }
  PetscCall(MatDenseRestoreArrayRead(K, &a));
  inertia->asymmetry = norm2 > 0 ? std::sqrt(difference2 / norm2) : 0.0;
  inertia->symmetric = inertia->asymmetry <= symmetry_tolerance;
  symmetric_         = inertia->symmetric;
  if (n == 0) { // nothing to factor: no pivots, a determinant of 1
    inertia->factored         = true;
    inertia->negative_pivots  = symmetric_ ? -6 * num_relays_ : -1;
    inertia->determinant_sign = 1;
    dense_                    = true;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (symmetric_) {
    if (dense_work_n_ != dense_n_) { // sytrf's optimal work space, asked once per size
      PetscScalar  optimal = 0.0, probe = 0.0;
      PetscBLASInt query = -1;
      PetscCallBLAS("LAPACKsytrf", LAPACKsytrf_("L", &dense_n_, &probe, &dense_n_, dense_pivots_.data(), &optimal, &query, &info));
      dense_work_.resize(std::max<size_t>((size_t)n, (size_t)PetscRealPart(optimal)));
      dense_work_n_ = dense_n_;
    }
    PetscBLASInt lwork;
    PetscCall(PetscBLASIntCast((PetscInt)dense_work_.size(), &lwork));
    PetscCallBLAS("LAPACKsytrf", LAPACKsytrf_("L", &dense_n_, dense_factors_.data(), &dense_n_, dense_pivots_.data(), dense_work_.data(), &lwork, &info));
  } else {
    PetscCallBLAS("LAPACKgetrf", LAPACKgetrf_(&dense_n_, &dense_n_, dense_factors_.data(), &dense_n_, dense_pivots_.data(), &info));
  }
  PetscCheck(info >= 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "LAPACK's dense factorisation of the tangent: illegal argument %d", (int)info);
  if (info > 0) PetscFunctionReturn(PETSC_SUCCESS); // an exactly zero pivot: singular
  const auto at = [&](PetscInt i, PetscInt j) { return PetscRealPart(dense_factors_[(size_t)(i + j * n)]); };
  if (symmetric_) {
    PetscInt negative = 0;
    for (PetscInt i = 0; i < n;) {
      if (dense_pivots_[(size_t)i] > 0) { // a 1x1 block
        negative += at(i, i) < 0.0;
        i += 1;
        continue;
      }
      const double determinant = at(i, i) * at(i + 1, i + 1) - at(i + 1, i) * at(i + 1, i);
      if (determinant == 0.0) PetscFunctionReturn(PETSC_SUCCESS); // not a pivot sytrf chooses: singular
      negative += determinant < 0.0 ? 1 : at(i, i) < 0.0 ? 2 : 0;
      i += 2;
    }
    inertia->negative_pivots  = negative - 6 * num_relays_;
    inertia->determinant_sign = inertia->negative_pivots % 2 == 0 ? 1 : -1;
  } else {
    int sign = 1;
    for (PetscInt i = 0; i < n; ++i) {
      if (dense_pivots_[(size_t)i] != (PetscBLASInt)(i + 1)) sign = -sign;
      if (at(i, i) < 0.0) sign = -sign;
    }
    inertia->determinant_sign = sign;
  }
  inertia->factored = true;
  dense_            = true;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::Solve(Vec b, Vec x)
{
  PetscFunctionBeginUser;
  PetscCheck(factor_ || dense_, PetscObjectComm((PetscObject)b), PETSC_ERR_ARG_WRONGSTATE, "the tangent has not been factored");
  if (!dense_) {
    PetscCall(MatSolve(factor_, b, x));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscScalar *values;
  PetscBLASInt one = 1, info = 0;
  PetscCall(VecCopy(b, x));
  if (dense_n_ == 0) PetscFunctionReturn(PETSC_SUCCESS); // no unknowns (everything prescribed): nothing to solve
  PetscCall(VecGetArray(x, &values));
  if (symmetric_)
    PetscCallBLAS("LAPACKsytrs", LAPACKsytrs_("L", &dense_n_, &one, dense_factors_.data(), &dense_n_, dense_pivots_.data(), values, &dense_n_, &info));
  else PetscCallBLAS("LAPACKgetrs", LAPACKgetrs_("N", &dense_n_, &one, dense_factors_.data(), &dense_n_, dense_pivots_.data(), values, &dense_n_, &info));
  PetscCall(VecRestoreArray(x, &values));
  PetscCheck(info == 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "LAPACK's dense solve with the tangent: illegal argument %d", (int)info);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode TangentFactor::LowestEigenvalue(Vec D, Vec mode, double *mu)
{
  PetscInt size;
  PetscFunctionBeginUser;
  PetscCall(VecGetSize(mode, &size));
  if (size == 0) { // no unknowns (everything prescribed): no mode, nothing that can lose stability
    *mu = INFINITY;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  if (symmetric_) PetscCall(LanczosLowestEigenvalue(D, mode, mu));
  else PetscCall(InverseIteration(D, mode, mu));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// Inverse iteration: v <- K^{-1} D v, 1/mu = (Dv)^T K^{-1} D v for v^T D v = 1. Converges at the
// rate |mu_1 / mu_2|, fast near a critical point where mu_1 -> 0.
PetscErrorCode TangentFactor::InverseIteration(Vec D, Vec mode, double *mu)
{
  Vec         Dv = work_[0], x = work_[1];
  PetscScalar vDv, theta;
  double      previous = 0.0;
  PetscFunctionBeginUser;
  *mu = NAN;
  PetscCall(VecPointwiseMult(Dv, D, mode));
  PetscCall(VecDot(mode, Dv, &vDv));
  // A start vector of no D-length (a scale that over- or underflowed: a user's EI of 1e308) leaves
  // the estimate unknown, NaN, as the caller reports an estimate that did not converge: it ended
  // the run with PETSc's trace and MPI_ABORT.
  if (!(PetscRealPart(vDv) > 0 && std::isfinite(PetscRealPart(vDv)))) {
    *mu = NAN;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecScale(mode, 1.0 / std::sqrt(PetscRealPart(vDv))));
  for (int iteration = 0; iteration < 100; ++iteration) {
    PetscCall(VecPointwiseMult(Dv, D, mode));
    PetscCall(Solve(Dv, x));
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

// Lanczos on A = K^{-1} D, self-adjoint in the D inner product <x, y> = x^T D y when K is
// symmetric: from v_1 = mode / |mode|_D, w = A v_j - alpha_j v_j - beta_{j-1} v_{j-1} with
// alpha_j = <v_j, A v_j>, beta_j = |w|_D, v_{j+1} = w / beta_j (each w orthogonalised again against
// every v_i, so the basis stays D-orthonormal in floating point). The eigenvalues theta of the
// tridiagonal T_m = tridiag(beta, alpha, beta) approximate those of A, 1/mu; the one of largest
// magnitude converges first, and its residual |A y - theta y|_D = beta_m |s_m| (s the eigenvector of
// T_m, y = V s) bounds the error. The inverse iteration it replaces needed 7-16 solves per
// equilibrium on the static examples, converging at |mu_1 / mu_2|; Lanczos converges at a rate set
// by the gap of mu_1 to the whole spectrum. Restarted from the Ritz vector y after kLanczosSteps.
PetscErrorCode TangentFactor::LanczosLowestEigenvalue(Vec D, Vec mode, double *mu)
{
  Vec         w = work_[1];
  PetscScalar dot;
  PetscFunctionBeginUser;
  *mu = NAN;
  if (!basis_) {
    PetscCall(VecDuplicateVecs(mode, kLanczosSteps + 1, &basis_));
    PetscCall(VecDuplicateVecs(mode, kLanczosSteps + 1, &scaled_basis_));
  }
  Vec *V = basis_, *DV = scaled_basis_;
  PetscCall(VecCopy(mode, V[0]));
  for (int restart = 0; restart < kLanczosRestarts; ++restart) {
    PetscCall(VecPointwiseMult(DV[0], D, V[0]));
    PetscCall(VecDot(V[0], DV[0], &dot));
    if (!(PetscRealPart(dot) > 0 && std::isfinite(PetscRealPart(dot)))) { // unknown, as in InverseIteration (a restart's 1/theta is no estimate)
      *mu = NAN;
      PetscFunctionReturn(PETSC_SUCCESS);
    }
    PetscCall(VecScale(V[0], 1.0 / std::sqrt(PetscRealPart(dot))));
    PetscCall(VecScale(DV[0], 1.0 / std::sqrt(PetscRealPart(dot))));
    double          alpha[kLanczosSteps] = {}, beta[kLanczosSteps] = {};
    int             steps = 0;
    double          theta = 0.0, residual = INFINITY;
    Eigen::VectorXd ritz;
    for (int j = 0; j < kLanczosSteps; ++j) {
      PetscCall(Solve(DV[j], w)); // w = K^{-1} D v_j
      PetscCall(VecDot(w, DV[j], &dot));
      alpha[j] = PetscRealPart(dot);
      PetscCall(VecAXPY(w, -alpha[j], V[j]));
      if (j > 0) PetscCall(VecAXPY(w, -beta[j - 1], V[j - 1]));
      for (int i = 0; i <= j; ++i) { // again against every v_i: what round-off left
        PetscCall(VecDot(w, DV[i], &dot));
        PetscCall(VecAXPY(w, -PetscRealPart(dot), V[i]));
      }
      PetscCall(VecPointwiseMult(DV[j + 1], D, w));
      PetscCall(VecDot(w, DV[j + 1], &dot));
      beta[j] = std::sqrt(std::max(0.0, (double)PetscRealPart(dot)));
      steps   = j + 1;
      // The Ritz value of largest magnitude of T_steps and its residual beta_j |s_j|.
      Eigen::MatrixXd T = Eigen::MatrixXd::Zero(steps, steps);
      for (int i = 0; i < steps; ++i) {
        T(i, i) = alpha[i];
        if (i + 1 < steps) T(i, i + 1) = T(i + 1, i) = beta[i];
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(T);
      Eigen::Index                                         largest;
      eigen.eigenvalues().cwiseAbs().maxCoeff(&largest);
      theta    = eigen.eigenvalues()(largest);
      ritz     = eigen.eigenvectors().col(largest);
      residual = beta[j] * std::abs(ritz(steps - 1));
      if (residual <= 1e-9 * std::abs(theta) || beta[j] <= 1e-14 * std::abs(theta)) break; // converged, or an invariant subspace
      PetscCall(VecCopy(w, V[j + 1]));
      PetscCall(VecScale(V[j + 1], 1.0 / beta[j]));
      PetscCall(VecScale(DV[j + 1], 1.0 / beta[j]));
    }
    // The Ritz vector y = V s (D-normalised, as the v_i are D-orthonormal and |s| = 1).
    PetscCall(VecSet(mode, 0.0));
    PetscCall(VecMAXPY(mode, steps, ritz.data(), V));
    if (theta != 0.0) *mu = 1.0 / theta;
    if (residual <= 1e-9 * std::abs(theta) || !(theta != 0.0)) break;
    PetscCall(VecCopy(mode, V[0]));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

} // namespace msflex
