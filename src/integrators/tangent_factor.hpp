// The factorisation of the tangent at an equilibrium and what it tells about its stability
// (docs/stability.md).
//
// The tangent K is the one at the converged state taken as the start of a new step (omega = 0,
// so H(omega) = I and K is the spin-form tangent condensed through the joints). Under conservative
// loads it is symmetric at equilibrium, and by Sylvester's law of inertia the number of negative
// pivots of its LDL^T factorisation is the number of its negative eigenvalues: 0 on a stable
// path, changing by one wherever the path passes a simple critical point. A tangent that is not
// symmetric (follower loads, moments of fixed direction about free rotations) is factored by LU;
// then only the sign of its determinant, (-1)^(negative eigenvalues), is known.
//
// The lowest eigenvalue mu of the pencil (K, D), D = |diag K_0| of the first tangent (a scaling
// that makes the eigenvalue independent of the units of translations and rotations), by inverse
// iteration with the factors: v <- K^{-1} D v, 1/mu = (Dv)^T K^{-1} D v for v^T D v = 1. It passes
// through zero at a critical point, where it locates the point by interpolation.
#pragma once

#include <petscmat.h>

#include <vector>

namespace msflex {

struct TangentInertia {
  bool     factored         = false; // false: the factorisation failed (a singular tangent)
  bool     symmetric        = false; // factored by Cholesky (LDL^T) rather than LU
  double   asymmetry        = 0.0;   // ||K - K^T||_F / ||K||_F
  PetscInt negative_pivots  = -1;    // -1 when not symmetric
  int      determinant_sign = 0;     // +1 or -1; 0 when not factored
};

class TangentFactor {
public:
  TangentFactor()                                 = default;
  TangentFactor(const TangentFactor &)            = delete;
  TangentFactor &operator=(const TangentFactor &) = delete;
  ~TangentFactor();

  // Factors K (Cholesky with the inertia if K is symmetric to `symmetry_tolerance`, else LU with
  // the determinant sign), keeping the factors for Solve and LowestEigenvalue. K must stay
  // unchanged while they are used. A dense K (a small model on one rank) is factored by LAPACK's
  // symmetric-indefinite LDL^T (sytrf) or LU (getrf); a sparse one by MUMPS, whose analysis is
  // kept for the next K of the same pattern and kind. Collective.
  PetscErrorCode Factor(Mat K, double symmetry_tolerance, TangentInertia *inertia);
  // x = K^{-1} b with the last factors. Collective.
  PetscErrorCode Solve(Vec b, Vec x);
  // The eigenvalue mu of smallest magnitude of K phi = mu D phi from *mode (in: the start vector,
  // e.g. the last mode; out: the mode, v^T D v = 1): for a symmetric K by Lanczos on K^{-1} D in
  // the D inner product, for a nonsymmetric one by inverse iteration. Collective.
  PetscErrorCode LowestEigenvalue(Vec D, Vec mode, double *mu);
  // A tangent with relay nodes (DofMap): MUMPS gets the work space their pivoting needs
  // (kRelayMumpsWorkspace), and the inertia is the condensed tangent's. Each relay's saddle-point
  // rows (its increments and its force, which its joint eliminates) add 6 negative and 6 positive
  // pivots (the inertia of a KKT matrix with a full-rank constraint block) and nothing to the
  // determinant's sign.
  void SetRelays(PetscInt num_relays) { num_relays_ = num_relays; }

private:
  PetscErrorCode FactorAij(Mat K, double symmetry_tolerance, bool may_reuse, TangentInertia *inertia);
  PetscErrorCode FactorMumps(Mat K, bool reuse_analysis, TangentInertia *inertia);
  PetscErrorCode FactorDense(Mat K, double symmetry_tolerance, TangentInertia *inertia);
  PetscErrorCode LanczosLowestEigenvalue(Vec D, Vec mode, double *mu);
  PetscErrorCode InverseIteration(Vec D, Vec mode, double *mu);
  Mat            factor_     = nullptr;
  PetscInt       num_relays_ = 0;
  Vec            work_[2]    = {nullptr, nullptr};
  bool           symmetric_  = false; // the last factorisation was (or, dense, is being) LDL^T
  // Lanczos: the basis V and D V (kLanczosSteps + 1 vectors each), made at the first use.
  Vec *basis_ = nullptr, *scaled_basis_ = nullptr;
  // What MUMPS' analysis in factor_ was made for: the matrix (by its id, which no later matrix
  // takes, unlike its address), its nonzero pattern and the kind; -1: none.
  PetscInt64       analysed_matrix_    = -1;
  PetscObjectState analysed_pattern_   = 0;
  bool             analysed_symmetric_ = false;
  // The dense factors (column major), LAPACK's pivots and sytrf's work space.
  bool                      dense_   = false;
  PetscBLASInt              dense_n_ = 0;
  std::vector<PetscScalar>  dense_factors_, dense_work_; // dense_work_ sized for dense_work_n_
  PetscBLASInt              dense_work_n_ = -1;
  std::vector<PetscBLASInt> dense_pivots_;
};

} // namespace msflex
