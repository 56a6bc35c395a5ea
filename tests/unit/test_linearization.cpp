// The linearised system (integrators/linearization.hpp) and the factorisation of the tangent
// (integrators/tangent_factor.hpp), on any number of ranks:
//  - the inertia of MUMPS' LDL^T factorisation (sparse) and of LAPACK's (dense, one rank): the
//    negative pivots of A - sigma I for a matrix with known eigenvalues are the eigenvalues below
//    sigma; an LU factorisation of a nonsymmetric matrix gives the sign of the determinant;
//    inverse iteration finds the eigenvalue nearest zero; a refactorisation of new values of the
//    same pattern (MUMPS' analysis kept) is that of the new values; an exactly singular matrix is
//    not factored;
//  - the mass matrix: symmetric, a uniform unit velocity has the model's total mass (beams, a
//    rigid body, through a joint), massless DOFs have zero rows, and it is the initial-acceleration
//    tangent without that problem's identity rows;
//  - the load pattern q = -dR/dlambda is the nodal loads (exact for linear loads);
//  - the geometric stiffness of linearised buckling is symmetric under a dead force and linear in
//    the loads.
#include "integrators/linearization.hpp"
#include "integrators/tangent_factor.hpp"
#include "io/input_reader.hpp"
#include "parallel/partition.hpp"

#include <gtest/gtest.h>
#include <petscmat.h>

#include <cmath>
#include <string>
#include <vector>

using namespace msflex;

namespace {

// The n x n matrix tridiag(-1, 2, -1) - sigma I plus skew * (upper - lower); eigenvalues without
// skew: 2 - 2 cos(k pi / (n + 1)).
Mat Laplacian(PetscInt n, double sigma, double skew)
{
  Mat      A;
  PetscInt first, last;
  MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, n, n, 3, nullptr, 2, nullptr, &A);
  MatGetOwnershipRange(A, &first, &last);
  for (PetscInt i = first; i < last; ++i) {
    MatSetValue(A, i, i, 2.0 - sigma, INSERT_VALUES);
    if (i > 0) MatSetValue(A, i, i - 1, -1.0 - skew, INSERT_VALUES);
    if (i + 1 < n) MatSetValue(A, i, i + 1, -1.0 + skew, INSERT_VALUES);
  }
  MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY);
  return A;
}

// The formats TangentFactor factors: AIJ (MUMPS) on any number of ranks, dense (LAPACK) on one.
std::vector<bool> Formats()
{
  PetscMPIInt size;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  return size == 1 ? std::vector<bool>{false, true} : std::vector<bool>{false};
}

// A as a dense matrix (one rank) when `dense`, else A itself.
Mat InFormat(Mat A, bool dense)
{
  if (!dense) return A;
  Mat D;
  MatConvert(A, MATSEQDENSE, MAT_INITIAL_MATRIX, &D);
  MatDestroy(&A);
  return D;
}

TEST(TangentFactor, NegativePivotsAreTheEigenvaluesBelowTheShift)
{
  const PetscInt n = 60;
  for (const bool dense : Formats())
    for (int below : {0, 1, 7, 30, 59}) {
      // sigma between eigenvalues number below and below + 1 (1-based), nearer the first, so that
      // one eigenvalue of A is the nearest zero (inverse iteration converges at the ratio 3/7).
      auto           eigenvalue = [n](int k) { return 2.0 - 2.0 * std::cos(k * M_PI / (n + 1)); };
      const double   sigma      = below == 0 ? 0.5 * eigenvalue(1) : eigenvalue(below) + 0.3 * (eigenvalue(below + 1) - eigenvalue(below));
      Mat            A          = InFormat(Laplacian(n, sigma, 0.0), dense);
      TangentFactor  factor;
      TangentInertia inertia;
      ASSERT_EQ(factor.Factor(A, 1e-8, &inertia), PETSC_SUCCESS);
      EXPECT_TRUE(inertia.factored);
      EXPECT_TRUE(inertia.symmetric);
      EXPECT_EQ(inertia.negative_pivots, below) << "sigma " << sigma << (dense ? ", dense" : ", aij");
      EXPECT_EQ(inertia.determinant_sign, below % 2 == 0 ? 1 : -1);
      // The eigenvalue of A nearest zero, by inverse iteration (D = I).
      Vec D, mode;
      MatCreateVecs(A, &D, &mode);
      VecSet(D, 1.0);
      VecSet(mode, 1.0);
      VecSetValue(mode, 0, 2.0, INSERT_VALUES); // not orthogonal to any mode
      VecAssemblyBegin(mode);
      VecAssemblyEnd(mode);
      double mu;
      ASSERT_EQ(factor.LowestEigenvalue(D, mode, &mu), PETSC_SUCCESS);
      double nearest = INFINITY;
      for (int k = 1; k <= n; ++k)
        if (std::abs(eigenvalue(k) - sigma) < std::abs(nearest)) nearest = eigenvalue(k) - sigma;
      EXPECT_NEAR(mu, nearest, 1e-8 * std::abs(nearest)) << (dense ? "dense" : "aij");
      VecDestroy(&D);
      VecDestroy(&mode);
      MatDestroy(&A);
    }
}

TEST(TangentFactor, NonsymmetricTangentGivesTheDeterminantSign)
{
  // A small skew part keeps the eigenvalues real and their count below sigma: the sign of the
  // determinant is (-1)^below.
  const PetscInt n          = 40;
  auto           eigenvalue = [n](int k) { return 2.0 - 2.0 * std::cos(k * M_PI / (n + 1)); };
  for (const bool dense : Formats())
    for (int below : {2, 3}) {
      Mat            A = InFormat(Laplacian(n, 0.5 * (eigenvalue(below) + eigenvalue(below + 1)), 1e-4), dense);
      TangentFactor  factor;
      TangentInertia inertia;
      ASSERT_EQ(factor.Factor(A, 1e-8, &inertia), PETSC_SUCCESS);
      EXPECT_TRUE(inertia.factored);
      EXPECT_FALSE(inertia.symmetric);
      // ||K - K^T||_F^2 = 2 (n - 1) (2 skew)^2, ||K||_F^2 = n (2 - sigma)^2 + (n - 1) ((1 + skew)^2 + (1 - skew)^2)
      const double sigma = 0.5 * (eigenvalue(below) + eigenvalue(below + 1)), skew = 1e-4;
      const double expected =
          std::sqrt(2.0 * (n - 1) * 4.0 * skew * skew / (n * (2.0 - sigma) * (2.0 - sigma) + (n - 1) * ((1 + skew) * (1 + skew) + (1 - skew) * (1 - skew))));
      EXPECT_NEAR(inertia.asymmetry, expected, 1e-12 * expected) << (dense ? "dense" : "aij");
      EXPECT_EQ(inertia.negative_pivots, -1);
      EXPECT_EQ(inertia.determinant_sign, below % 2 == 0 ? 1 : -1) << (dense ? "dense" : "aij");
      MatDestroy(&A);
    }
}

// Two eigenvalues nearly as close to zero (|mu_1 / mu_2| = 0.97, where inverse iteration would need
// hundreds of solves), a start vector far from the mode, and a non-uniform scaling D: the eigenvalue
// of K phi = mu D phi nearest zero and its mode, through Lanczos' restarts.
TEST(TangentFactor, LowestEigenvalueOfCloseEigenvaluesWithAScaling)
{
  const PetscInt n          = 200;
  auto           eigenvalue = [n](int k) { return 2.0 - 2.0 * std::cos(k * M_PI / (n + 1)); };
  const int      below      = 40;
  const double   gap = eigenvalue(below + 1) - eigenvalue(below), sigma = eigenvalue(below) + 0.4925 * gap; // mu = -0.4925 gap, next +0.5075 gap
  for (const bool dense : Formats()) {
    Mat A = InFormat(Laplacian(n, sigma, 0.0), dense);
    // D = diag(d): K phi = mu D phi is A' psi = mu psi with A' = D^{-1/2} A D^{-1/2}; compared with
    // the residual of the returned mode instead of a closed form.
    Vec D, mode, Kv, Dv;
    MatCreateVecs(A, &D, &mode);
    VecDuplicate(D, &Kv);
    VecDuplicate(D, &Dv);
    PetscInt first, last;
    VecGetOwnershipRange(D, &first, &last);
    for (PetscInt i = first; i < last; ++i) {
      VecSetValue(D, i, 1.0 + 0.5 * std::sin(0.37 * i), INSERT_VALUES);
      VecSetValue(mode, i, 1.0 + (i % 7), INSERT_VALUES);
    }
    VecAssemblyBegin(D), VecAssemblyEnd(D), VecAssemblyBegin(mode), VecAssemblyEnd(mode);
    TangentFactor  factor;
    TangentInertia inertia;
    ASSERT_EQ(factor.Factor(A, 1e-8, &inertia), PETSC_SUCCESS);
    ASSERT_TRUE(inertia.symmetric);
    double mu;
    ASSERT_EQ(factor.LowestEigenvalue(D, mode, &mu), PETSC_SUCCESS);
    MatMult(A, mode, Kv);
    VecPointwiseMult(Dv, D, mode);
    VecAXPY(Kv, -mu, Dv);
    PetscReal residual, scale;
    VecNorm(Kv, NORM_2, &residual);
    VecNorm(Dv, NORM_2, &scale);
    EXPECT_LT(residual, 1e-6 * std::abs(mu) * scale) << (dense ? "dense" : "aij") << ", mu " << mu;
    // The eigenvalue nearest zero: its magnitude is below half the gap (A's spectrum scaled by D
    // within [0.5, 1.5] keeps the smallest |mu| of the pencil near that of A: between 1/1.5 and
    // 1/0.5 of 0.4925 gap) and one negative pivot count agrees with its sign.
    EXPECT_LT(std::abs(mu), 2.0 * 0.4925 * gap);
    EXPECT_GT(std::abs(mu), 0.4925 * gap / 1.5);
    VecDestroy(&D), VecDestroy(&mode), VecDestroy(&Kv), VecDestroy(&Dv);
    MatDestroy(&A);
  }
}

// |A x - b| / |b| for x = factor.Solve(b), b random: whether the factors are A's.
static double RelativeSolveResidual(TangentFactor &factor, Mat A)
{
  Vec x, b, r;
  MatCreateVecs(A, &x, &b);
  VecDuplicate(b, &r);
  VecSetRandom(b, nullptr);
  if (factor.Solve(b, x) != PETSC_SUCCESS) return INFINITY;
  MatMult(A, x, r);
  VecAXPY(r, -1.0, b);
  PetscReal residual, size;
  VecNorm(r, NORM_2, &residual);
  VecNorm(b, NORM_2, &size);
  VecDestroy(&x), VecDestroy(&b), VecDestroy(&r);
  return residual / size;
}

// One TangentFactor along a path: new values of the same matrix (MUMPS' analysis kept), then a
// nonsymmetric one (a new analysis), then symmetric again; each factorisation is that of its
// values, and its solve solves with them.
TEST(TangentFactor, RefactoringNewValuesOfTheSamePattern)
{
  const PetscInt n          = 50;
  auto           eigenvalue = [n](int k) { return 2.0 - 2.0 * std::cos(k * M_PI / (n + 1)); };
  for (const bool dense : Formats()) {
    TangentFactor factor;
    Mat           A = nullptr;
    for (const auto &[below, skew] : std::vector<std::pair<int, double>>{{0, 0.0}, {4, 0.0}, {9, 0.0}, {3, 1e-4}, {6, 0.0}}) {
      const double sigma = below == 0 ? 0.5 * eigenvalue(1) : 0.5 * (eigenvalue(below) + eigenvalue(below + 1));
      Mat          next  = InFormat(Laplacian(n, sigma, skew), dense);
      if (!A) A = next;
      else { // the same matrix object refilled: its pattern is unchanged
        MatCopy(next, A, SAME_NONZERO_PATTERN);
        MatDestroy(&next);
      }
      TangentInertia inertia;
      ASSERT_EQ(factor.Factor(A, 1e-8, &inertia), PETSC_SUCCESS);
      EXPECT_TRUE(inertia.factored);
      EXPECT_EQ(inertia.symmetric, skew == 0.0);
      if (skew == 0.0) EXPECT_EQ(inertia.negative_pivots, below) << (dense ? "dense" : "aij") << ", sigma " << sigma;
      EXPECT_EQ(inertia.determinant_sign, below % 2 == 0 ? 1 : -1);
      EXPECT_LT(RelativeSolveResidual(factor, A), 1e-9) << (dense ? "dense" : "aij") << ", sigma " << sigma;
    }
    MatDestroy(&A);
    // A new matrix of another pattern (pentadiagonal), maybe at the old one's address: a new
    // analysis, not the old one's.
    Mat      B;
    PetscInt first, last;
    MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, n, n, 5, nullptr, 4, nullptr, &B);
    MatGetOwnershipRange(B, &first, &last);
    for (PetscInt i = first; i < last; ++i) {
      MatSetValue(B, i, i, 5.0, INSERT_VALUES);
      for (PetscInt j : {i - 2, i - 1, i + 1, i + 2})
        if (j >= 0 && j < n) MatSetValue(B, i, j, -1.0, INSERT_VALUES);
    }
    MatAssemblyBegin(B, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(B, MAT_FINAL_ASSEMBLY);
    B = InFormat(B, dense);
    TangentInertia inertia;
    ASSERT_EQ(factor.Factor(B, 1e-8, &inertia), PETSC_SUCCESS);
    EXPECT_EQ(inertia.negative_pivots, 0); // diagonally dominant, positive
    EXPECT_LT(RelativeSolveResidual(factor, B), 1e-12) << (dense ? "dense" : "aij") << ", a new pattern";
    MatDestroy(&B);
  }
}

// An entry whose transpose is not stored: K - K^T has it twice, ||K - K^T||_F^2 = 2 v^2.
TEST(TangentFactor, AsymmetryCountsEntriesWithoutTheirTranspose)
{
  const PetscInt n = 12;
  const double   v = 0.5;
  for (const bool dense : Formats()) {
    Mat A = Laplacian(n, 0.2, 0.0), B;
    // A copy with room for the corner entry (0, n - 1), whose transpose (n - 1, 0) stays unstored.
    MatDuplicate(A, MAT_COPY_VALUES, &B);
    MatSetOption(B, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
    PetscInt first, last;
    MatGetOwnershipRange(B, &first, &last);
    if (first == 0) MatSetValue(B, 0, n - 1, v, INSERT_VALUES);
    MatAssemblyBegin(B, MAT_FINAL_ASSEMBLY);
    MatAssemblyEnd(B, MAT_FINAL_ASSEMBLY);
    MatDestroy(&A);
    B                    = InFormat(B, dense);
    const double   norm2 = n * (2.0 - 0.2) * (2.0 - 0.2) + 2.0 * (n - 1) + v * v;
    TangentFactor  factor;
    TangentInertia inertia;
    ASSERT_EQ(factor.Factor(B, 1e-8, &inertia), PETSC_SUCCESS);
    EXPECT_NEAR(inertia.asymmetry, std::sqrt(2.0 * v * v / norm2), 1e-14) << (dense ? "dense" : "aij");
    EXPECT_FALSE(inertia.symmetric);
    MatDestroy(&B);
  }
}

// An exactly singular matrix (a zero row and column) is reported as not factored, in either
// format, symmetric or not.
TEST(TangentFactor, ExactlySingularIsNotFactored)
{
  const PetscInt n = 20;
  for (const bool dense : Formats())
    for (const double skew : {0.0, 1e-3}) {
      Mat      A    = Laplacian(n, 0.3, skew);
      PetscInt zero = n / 2;
      MatZeroRowsColumns(A, 1, &zero, 0.0, nullptr, nullptr);
      A = InFormat(A, dense);
      TangentFactor  factor;
      TangentInertia inertia;
      ASSERT_EQ(factor.Factor(A, 1e-8, &inertia), PETSC_SUCCESS);
      EXPECT_FALSE(inertia.factored) << (dense ? "dense" : "aij") << ", skew " << skew;
      MatDestroy(&A);
    }
}

// A free beam with a rigid body, and a second beam hinged to it: no supports (an eigenanalysis
// model), so that a uniform velocity moves everything.
const char *kFreeModel = R"(
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5}
  - {name: light, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 0.5, rhoJ: [0.01, 0.02, 0.03]}
nodes:
  a: [0, 0, 0]
  b: [2, 0.5, 0]
  c: [2, 0.5, 0]
  d: [2.5, 1.5, 1]
beams:
  - {name: main, section: s, from: a, to: b, elements: 3, order: 2}
  - {name: arm, section: light, from: c, to: d, elements: 2}
joints:
  - {name: hinge, type: revolute, master: b, slave: c, axis: [0, 0, 1]}
rigid_bodies:
  - {node: main.2, mass: 2.5, inertia: [0.4, 0.3, 0.5], offset: [0.2, -0.1, 0.15]}
analysis: {type: modes}
)";

// A cantilever with a dead tip load and gravity (a linear load pattern).
const char *kLoadedModel = R"(
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5}
nodes:
  a: [0, 0, 0]
  b: [2, 0, 0]
beams:
  - {name: rod, section: s, from: a, to: b, elements: 4, order: 2}
supports:
  - {nodes: a, fix: all}
loads:
  - {nodes: b, force: [-30, 5, 2], moment: [0, 0, 1]}
)";

// The same with a conservative load only (a dead force).
const char *kForceModel = R"(
sections:
  - {name: s, EA: 3.0e3, GA2: 1.2e3, GA3: 9.0e2, GJ: 40, EI2: 60, EI3: 80, rhoA: 1.5}
nodes:
  a: [0, 0, 0]
  b: [2, 0, 0]
beams:
  - {name: rod, section: s, from: a, to: b, elements: 4, order: 2}
supports:
  - {nodes: a, fix: all}
loads:
  - {nodes: b, force: [-30, 5, 2]}
)";

struct System {
  Model            model;
  DofMap           map;
  MechanicalSystem system;
};

PetscErrorCode Build(const std::string &text, System *s)
{
  InputError       error;
  std::vector<int> node_rank;
  MatrixPattern    pattern;
  NodalMass        mass;
  PetscFunctionBeginUser;
  PetscCheck(ReadModelString(text, "test_linearization", &s->model, &error), PETSC_COMM_WORLD, PETSC_ERR_USER_INPUT, "%s", error.Format().c_str());
  PetscCall(PartitionNodes(PETSC_COMM_WORLD, s->model, PartitionerType::Simple, &node_rank));
  PetscCall(DofMapCreate(PETSC_COMM_WORLD, s->model, node_rank, &s->map));
  PetscCall(MechanicalSystemPrepare(s->model, s->map, &pattern, &mass));
  PetscCall(s->system.Setup(PETSC_COMM_WORLD, s->model, s->map, std::move(pattern), std::move(mass)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

// The vector with `value` at DOF d of every independent node (0 elsewhere, joint coordinates 0).
Vec NodalField(System &s, int d, double value)
{
  Vec v;
  VecDuplicate(s.system.GetAssembler().SolutionTemplate(), &v);
  VecZeroEntries(v);
  for (PetscInt l = 0; l < s.map.num_owned_nodes; ++l) {
    const PetscInt row = s.map.node_dofs[s.map.local_nodes[l]][d];
    if (row >= 0) VecSetValue(v, row, value, INSERT_VALUES);
  }
  VecAssemblyBegin(v);
  VecAssemblyEnd(v);
  return v;
}

double Asymmetry(Mat A)
{
  Mat       T;
  PetscReal norm, difference;
  MatNorm(A, NORM_FROBENIUS, &norm);
  MatTranspose(A, MAT_INITIAL_MATRIX, &T);
  MatAXPY(T, -1.0, A, DIFFERENT_NONZERO_PATTERN);
  MatNorm(T, NORM_FROBENIUS, &difference);
  MatDestroy(&T);
  return difference / norm;
}

TEST(Linearization, MassMatrixHasTheTotalMassAndZeroRowsForMasslessDofs)
{
  System s;
  ASSERT_EQ(Build(kFreeModel, &s), PETSC_SUCCESS);
  Assembler &assembler = s.system.GetAssembler();
  Mat        M, A;
  MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &M);
  MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &A);
  ASSERT_EQ(MassMatrix(s.system, 0.0, M), PETSC_SUCCESS);
  EXPECT_LT(Asymmetry(M), 1e-14);
  const double total = 1.5 * std::hypot(2.0, 0.5) + 0.5 * std::sqrt(0.25 + 1.0 + 1.0) + 2.5;
  for (int d = 0; d < 3; ++d) {
    Vec         v = NodalField(s, d, 1.0), Mv;
    PetscScalar vMv;
    VecDuplicate(v, &Mv);
    MatMult(M, v, Mv);
    VecDot(v, Mv, &vMv);
    EXPECT_NEAR(PetscRealPart(vMv), total, 1e-12 * total) << "direction " << d;
    VecDestroy(&v);
    VecDestroy(&Mv);
  }
  // The beam `main` has no rotary inertia: the rotation rows of its nodes (but the one with the
  // rigid body and the joint's master) are zero in M and the identity in the initial-acceleration
  // tangent; otherwise the two agree.
  PetscBool ok;
  ASSERT_EQ(assembler.BeginStep(InitialAccelerationProblem(0.0)), PETSC_SUCCESS);
  ASSERT_EQ(assembler.AssembleJacobian(assembler.Jacobian(), &ok), PETSC_SUCCESS);
  MatCopy(assembler.Jacobian(), A, SAME_NONZERO_PATTERN);
  MatAXPY(A, -1.0, M, SAME_NONZERO_PATTERN);
  Vec identity_rows = NodalField(s, 3, 0.0), diagonal;
  VecDuplicate(identity_rows, &diagonal);
  int massless = 0;
  for (const char *name : {"a", "main.1", "main.3", "main.4", "main.5"}) {
    for (size_t node = 0; node < s.model.nodes.size(); ++node)
      if (s.model.nodes[node].name == name)
        for (int d = 3; d < 6; ++d) {
          const PetscInt row = s.map.node_dofs[node][d];
          if (row >= s.map.first_owned && row < s.map.first_owned + s.map.num_owned) VecSetValue(identity_rows, row, 1.0, INSERT_VALUES);
          ++massless;
        }
  }
  VecAssemblyBegin(identity_rows);
  VecAssemblyEnd(identity_rows);
  MatGetDiagonal(A, diagonal);
  VecAXPY(diagonal, -1.0, identity_rows);
  PetscReal norm_diagonal, norm_A;
  VecNorm(diagonal, NORM_INFINITY, &norm_diagonal);
  MatNorm(A, NORM_FROBENIUS, &norm_A);
  EXPECT_EQ(massless, 15);
  EXPECT_LT(norm_diagonal, 1e-15);
  EXPECT_NEAR(norm_A, std::sqrt((double)massless), 1e-12); // only those identity entries
  VecDestroy(&identity_rows);
  VecDestroy(&diagonal);
  MatDestroy(&A);
  MatDestroy(&M);
}

TEST(Linearization, LoadPatternIsTheNodalLoads)
{
  System s;
  ASSERT_EQ(Build(kLoadedModel, &s), PETSC_SUCCESS);
  Vec       residual, q;
  PetscBool ok;
  double    force_scale;
  VecDuplicate(s.system.GetAssembler().SolutionTemplate(), &residual);
  VecDuplicate(residual, &q);
  for (double lambda : {0.0, 0.7}) {
    ASSERT_EQ(StaticResidual(s.system, lambda, lambda, nullptr, residual, &ok, &force_scale), PETSC_SUCCESS);
    ASSERT_EQ(StaticLoadPattern(s.system, lambda, lambda, nullptr, residual, q), PETSC_SUCCESS);
    const double expected[6] = {-30, 5, 2, 0, 0, 1};
    for (size_t node = 0; node < s.model.nodes.size(); ++node)
      for (int d = 0; d < 6; ++d) {
        double value;
        ASSERT_EQ(VecEntry(q, s.map.node_dofs[node][d], &value), PETSC_SUCCESS);
        if (s.map.node_dofs[node][d] < 0) continue;
        EXPECT_NEAR(value, s.model.nodes[node].name == "b" ? expected[d] : 0.0, 1e-7) << s.model.nodes[node].name << " dof " << d << " lambda " << lambda;
      }
  }
  VecDestroy(&residual);
  VecDestroy(&q);
}

TEST(Linearization, GeometricStiffnessIsSymmetricAndLinearInTheLoads)
{
  Mat K_sigma[2];
  for (int run = 0; run < 2; ++run) {
    System            s;
    std::string       text = kForceModel;
    const std::string once = "force: [-30, 5, 2]";
    if (run == 1) text.replace(text.find(once), once.size(), "force: [-60, 10, 4]");
    ASSERT_EQ(Build(text, &s), PETSC_SUCCESS);
    Assembler     &assembler = s.system.GetAssembler();
    Mat            K;
    Vec            residual, q, direction;
    PetscBool      ok;
    double         force_scale;
    TangentFactor  factor;
    TangentInertia inertia;
    MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &K);
    MatDuplicate(assembler.Jacobian(), MAT_DO_NOT_COPY_VALUES, &K_sigma[run]);
    VecDuplicate(assembler.SolutionTemplate(), &residual);
    VecDuplicate(residual, &q);
    VecDuplicate(residual, &direction);
    ASSERT_EQ(EquilibriumTangent(s.system, 0.0, K), PETSC_SUCCESS);
    ASSERT_EQ(factor.Factor(K, 1e-8, &inertia), PETSC_SUCCESS);
    ASSERT_EQ(StaticResidual(s.system, 0.0, 0.0, nullptr, residual, &ok, &force_scale), PETSC_SUCCESS);
    ASSERT_EQ(StaticLoadPattern(s.system, 0.0, 0.0, nullptr, residual, q), PETSC_SUCCESS);
    ASSERT_EQ(factor.Solve(q, direction), PETSC_SUCCESS);
    ASSERT_EQ(GeometricStiffness(s.system, s.model, s.map, 0.0, direction, 1e-3, K_sigma[run]), PETSC_SUCCESS);
    // A dead force is conservative: the geometric stiffness is symmetric (to the central
    // difference of the strain rates).
    EXPECT_LT(Asymmetry(K_sigma[run]), 1e-6);
    VecDestroy(&residual);
    VecDestroy(&q);
    VecDestroy(&direction);
    MatDestroy(&K);
  }
  PetscReal norm, difference;
  MatNorm(K_sigma[1], NORM_FROBENIUS, &norm);
  MatAXPY(K_sigma[1], -2.0, K_sigma[0], SAME_NONZERO_PATTERN);
  MatNorm(K_sigma[1], NORM_FROBENIUS, &difference);
  EXPECT_LT(difference / norm, 1e-7);
  MatDestroy(&K_sigma[0]);
  MatDestroy(&K_sigma[1]);
}

} // namespace
