// The block envelope LU (core/block_envelope_lu.hpp) against LAPACK's dense LU of the same
// matrices: chains (block tridiagonal), trees and random graphs of 6x6 blocks, with a pattern
// that is not symmetric, blocks listed twice and the block rows in several orders (fill inside
// the envelope); the inverse of one block; the first exactly singular diagonal block reported.
// Then the preconditioner built on it (core/block_envelope_pc.hpp) against PETSc's LU of SEQBAIJ
// matrices: new values and new patterns, and a singular diagonal block as a failed set-up.
#include "core/block_envelope_lu.hpp"
#include "core/block_envelope_pc.hpp"

#include <gtest/gtest.h>
#include <petscksp.h>

#include <petscblaslapack.h> // after petscsys.h, which it needs

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

using namespace msflex;

namespace {

constexpr int B = kEnvelopeBlock;

// A block-sparse matrix: block CSR and its values, and the same matrix dense (column-major).
struct BlockMatrix {
  int                 n = 0;
  std::vector<int>    row_start, columns;
  std::vector<double> values;
  std::vector<double> Dense() const
  {
    const int           size = B * n;
    std::vector<double> dense((size_t)size * size, 0.0);
    for (int row = 0; row < n; ++row)
      for (int k = row_start[row]; k < row_start[row + 1]; ++k)
        for (int c = 0; c < B; ++c)
          for (int r = 0; r < B; ++r)
            dense[(size_t)(B * row + r) + (size_t)size * (B * columns[k] + c)] += values[(size_t)k * kEnvelopeBlockEntries + r + B * c];
    return dense;
  }
};

// Random values on the pattern `blocks` (pairs (row, column), in that order in the CSR), the
// diagonal blocks made dominant by `diagonal` (0: none).
BlockMatrix MakeMatrix(int n, const std::vector<std::pair<int, int>> &blocks, double diagonal, std::mt19937 *generator)
{
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  BlockMatrix                            m;
  m.n = n;
  m.row_start.assign(n + 1, 0);
  std::vector<std::pair<int, int>> sorted = blocks;
  std::stable_sort(sorted.begin(), sorted.end(), [](auto a, auto b) { return a.first < b.first; });
  for (auto [row, column] : sorted) {
    ++m.row_start[row + 1];
    m.columns.push_back(column);
    for (int e = 0; e < kEnvelopeBlockEntries; ++e) m.values.push_back(entry(*generator));
    if (row == column)
      for (int d = 0; d < B; ++d) m.values[m.values.size() - kEnvelopeBlockEntries + d + B * d] += diagonal;
  }
  for (int i = 0; i < n; ++i) m.row_start[i + 1] += m.row_start[i];
  return m;
}

std::vector<std::pair<int, int>> Chain(int n)
{
  std::vector<std::pair<int, int>> blocks;
  for (int i = 0; i < n; ++i) {
    blocks.push_back({i, i});
    if (i > 0) blocks.push_back({i, i - 1});
    if (i + 1 < n) blocks.push_back({i, i + 1});
  }
  return blocks;
}

// A tree (each block row coupled to a random earlier one) or a random graph, with symmetric
// pattern; `one_sided` drops the upper blocks of some couplings (a pattern that is not symmetric).
std::vector<std::pair<int, int>> RandomPattern(int n, int extra_couplings, bool one_sided, std::mt19937 *generator)
{
  std::set<std::pair<int, int>> couplings;
  for (int i = 1; i < n; ++i) couplings.insert({std::uniform_int_distribution<int>(0, i - 1)(*generator), i});
  for (int e = 0; e < extra_couplings; ++e) {
    const int a = std::uniform_int_distribution<int>(0, n - 1)(*generator), b = std::uniform_int_distribution<int>(0, n - 1)(*generator);
    if (a != b) couplings.insert({std::min(a, b), std::max(a, b)});
  }
  std::vector<std::pair<int, int>> blocks;
  for (int i = 0; i < n; ++i) blocks.push_back({i, i});
  int count = 0;
  for (auto [a, b] : couplings) {
    blocks.push_back({b, a});
    if (!one_sided || ++count % 3 != 0) blocks.push_back({a, b});
  }
  return blocks;
}

// max_i |A x - b|_i / (|A| |x| + |b|)_i with x from the envelope LU, and the same for LAPACK's.
void ExpectSolvesAsLapack(const BlockMatrix &m, const std::vector<int> &order, const char *what)
{
  BlockEnvelopeLU lu;
  lu.Analyse(m.n, m.row_start.data(), m.columns.data(), order);
  ASSERT_EQ(lu.Factor(m.values.data()), 0) << what;
  const int                              size = B * m.n;
  std::mt19937                           generator(3);
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  std::vector<double>                    b(size), x(size);
  for (double &value : b) value = entry(generator);
  lu.Solve(b.data(), x.data());
  std::vector<double>       dense = m.Dense(), lapack = b;
  std::vector<double>       factors = dense;
  std::vector<PetscBLASInt> pivots(size);
  PetscBLASInt              n = size, one = 1, info = 0;
  LAPACKgetrf_(&n, &n, factors.data(), &n, pivots.data(), &info);
  ASSERT_EQ(info, 0) << what;
  LAPACKgetrs_("N", &n, &one, factors.data(), &n, pivots.data(), lapack.data(), &n, &info);
  double worst = 0.0, difference = 0.0, scale = 0.0;
  for (int r = 0; r < size; ++r) {
    double residual = -b[r], magnitude = std::fabs(b[r]);
    for (int c = 0; c < size; ++c) {
      residual += dense[r + (size_t)size * c] * x[c];
      magnitude += std::fabs(dense[r + (size_t)size * c] * x[c]);
    }
    worst      = std::max(worst, std::fabs(residual) / magnitude);
    difference = std::max(difference, std::fabs(x[r] - lapack[r]));
    scale      = std::max(scale, std::fabs(lapack[r]));
  }
  EXPECT_LT(worst, 1e-12) << what;             // componentwise backward error at round-off (n u)
  EXPECT_LT(difference, 1e-9 * scale) << what; // well conditioned: the two solutions agree
  // In place (x = b).
  std::vector<double> in_place = b;
  lu.Solve(in_place.data(), in_place.data());
  EXPECT_EQ(in_place, x) << what;
}

std::vector<int> Identity(int n)
{
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  return order;
}

} // namespace

TEST(BlockEnvelopeLU, InvertsOneBlockWithRowInterchanges)
{
  std::mt19937                           generator(11);
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    double a[kEnvelopeBlockEntries], inverse[kEnvelopeBlockEntries];
    for (double &value : a) value = entry(generator);
    if (trial == 0)
      for (int r = 0; r < B; ++r) a[r] = r == B - 1 ? 1.0 : 0.0; // a zero leading pivot: a row swap is needed
    std::copy(a, a + kEnvelopeBlockEntries, inverse);
    ASSERT_TRUE(InvertEnvelopeBlock(inverse));
    for (int r = 0; r < B; ++r)
      for (int c = 0; c < B; ++c) {
        double product = 0.0;
        for (int k = 0; k < B; ++k) product += a[r + B * k] * inverse[k + B * c];
        EXPECT_NEAR(product, r == c ? 1.0 : 0.0, 1e-11) << "trial " << trial;
      }
  }
  double singular[kEnvelopeBlockEntries];
  for (int e = 0; e < kEnvelopeBlockEntries; ++e) singular[e] = e % B == 2 ? 0.0 : entry(generator); // row 2 is zero
  EXPECT_FALSE(InvertEnvelopeBlock(singular));
}

TEST(BlockEnvelopeLU, ChainInAnyOrderSolvesAsLapack)
{
  std::mt19937      generator(5);
  const int         n     = 40;
  const BlockMatrix m     = MakeMatrix(n, Chain(n), 2.0, &generator);
  std::vector<int>  order = Identity(n), reversed = Identity(n), shuffled = Identity(n);
  std::reverse(reversed.begin(), reversed.end());
  std::shuffle(shuffled.begin(), shuffled.end(), generator);
  ExpectSolvesAsLapack(m, order, "chain, natural order");
  ExpectSolvesAsLapack(m, reversed, "chain, reversed");
  ExpectSolvesAsLapack(m, shuffled, "chain, shuffled (fill)");
  BlockEnvelopeLU lu;
  lu.Analyse(n, m.row_start.data(), m.columns.data(), order);
  EXPECT_EQ(lu.NumStoredBlocks(), (size_t)(3 * n - 2)); // block tridiagonal: no fill
}

TEST(BlockEnvelopeLU, TreesAndGraphsSolveAsLapack)
{
  std::mt19937 generator(9);
  for (int trial = 0; trial < 6; ++trial) {
    const int  n         = 5 + 7 * trial;
    const bool one_sided = trial % 2 == 1;
    auto       blocks    = RandomPattern(n, trial < 3 ? 0 : n / 2, one_sided, &generator);
    if (trial == 5) blocks.push_back({n - 1, 0}); // a block listed twice is summed
    const BlockMatrix m        = MakeMatrix(n, blocks, 4.0, &generator);
    std::vector<int>  shuffled = Identity(n);
    std::shuffle(shuffled.begin(), shuffled.end(), generator);
    ExpectSolvesAsLapack(m, Identity(n), "random pattern, natural order");
    ExpectSolvesAsLapack(m, shuffled, "random pattern, shuffled");
  }
}

TEST(BlockEnvelopeLU, GeneralDiagonalBlocksNeedOnlyRowInterchangesInside)
{
  // No dominance: the diagonal blocks are general (row interchanges inside them), the matrix still
  // has regular leading block minors with probability one.
  std::mt19937      generator(13);
  const int         n = 12;
  const BlockMatrix m = MakeMatrix(n, Chain(n), 0.0, &generator);
  ExpectSolvesAsLapack(m, Identity(n), "chain, general blocks");
}

TEST(BlockEnvelopeLU, ReportsTheFirstSingularDiagonalBlock)
{
  std::mt19937     generator(17);
  const int        n        = 8;
  BlockMatrix      m        = MakeMatrix(n, Chain(n), 2.0, &generator);
  std::vector<int> reversed = Identity(n);
  std::reverse(reversed.begin(), reversed.end());
  // Block row 5 and its couplings zero: singular wherever it is factored.
  for (int k = m.row_start[5]; k < m.row_start[6]; ++k)
    std::fill(m.values.begin() + (long)k * kEnvelopeBlockEntries, m.values.begin() + (long)(k + 1) * kEnvelopeBlockEntries, 0.0);
  BlockEnvelopeLU lu;
  lu.Analyse(n, m.row_start.data(), m.columns.data(), Identity(n));
  EXPECT_EQ(lu.Factor(m.values.data()), 5 + 1);
  lu.Analyse(n, m.row_start.data(), m.columns.data(), reversed);
  EXPECT_EQ(lu.Factor(m.values.data()), 5 + 1);
  // The values refactored after a failure: the factors start afresh.
  const BlockMatrix regular = MakeMatrix(n, Chain(n), 2.0, &generator);
  EXPECT_EQ(lu.Factor(regular.values.data()), 0);
}

// The envelope and the fill of CountBlockEnvelope against an elimination of the symmetrised
// pattern written out (a boolean matrix, row i's fill from the rows before it that it couples to).
TEST(BlockEnvelopeLU, CountsEnvelopeAndFillAsAnEliminationDoes)
{
  std::mt19937 generator(31);
  for (int trial = 0; trial < 40; ++trial) {
    const int         n      = 1 + trial % 23;
    auto              blocks = trial % 3 == 0 ? Chain(n) : RandomPattern(n, trial % 4 * n / 3, trial % 2 == 1, &generator);
    const BlockMatrix m      = MakeMatrix(n, blocks, 1.0, &generator);
    std::vector<int>  order  = Identity(n);
    if (trial % 5 != 0) std::shuffle(order.begin(), order.end(), generator);
    std::vector<int> position(n);
    for (int i = 0; i < n; ++i) position[order[i]] = i;
    std::vector<std::vector<char>> coupled(n, std::vector<char>(n, 0));
    for (int row = 0; row < n; ++row)
      for (int k = m.row_start[row]; k < m.row_start[row + 1]; ++k) {
        const int i = position[row], j = position[m.columns[k]];
        coupled[i][j] = coupled[j][i] = 1;
      }
    size_t envelope = 0, fill = 0;
    for (int i = 0; i < n; ++i) {
      int first = i;
      for (int j = 0; j < i; ++j)
        if (coupled[i][j]) first = std::min(first, j);
      envelope += (size_t)(i - first);
    }
    // Eliminating k couples every pair of its later neighbours.
    for (int k = 0; k < n; ++k)
      for (int i = k + 1; i < n; ++i)
        if (coupled[i][k])
          for (int j = k + 1; j < n; ++j)
            if (coupled[j][k]) coupled[i][j] = 1;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < i; ++j) fill += coupled[i][j];
    const BlockEnvelopeCount count = CountBlockEnvelope(n, m.row_start.data(), m.columns.data(), order);
    EXPECT_EQ(count.envelope, envelope) << "trial " << trial;
    EXPECT_EQ(count.fill, fill) << "trial " << trial;
    EXPECT_LE(count.fill, count.envelope) << "trial " << trial; // fill stays inside the envelope
  }
}

// ---- The preconditioner (core/block_envelope_pc.hpp) on PETSc matrices -------------------------

namespace {

// `m` as SEQBAIJ with blocks of 6 (PETSc keeps blocks column-major, as the CSR values here are).
Mat ToBaij(const BlockMatrix &m)
{
  Mat                   A;
  std::vector<PetscInt> nonzeros(m.n);
  for (int i = 0; i < m.n; ++i) nonzeros[i] = m.row_start[i + 1] - m.row_start[i];
  PetscCallAbort(PETSC_COMM_SELF, MatCreateSeqBAIJ(PETSC_COMM_SELF, B, B * m.n, B * m.n, 0, nonzeros.data(), &A));
  PetscCallAbort(PETSC_COMM_SELF, MatSetOption(A, MAT_ROW_ORIENTED, PETSC_FALSE));
  for (PetscInt i = 0; i < m.n; ++i)
    for (int k = m.row_start[i]; k < m.row_start[i + 1]; ++k) {
      const PetscInt column = m.columns[k];
      PetscCallAbort(PETSC_COMM_SELF, MatSetValuesBlocked(A, 1, &i, 1, &column, m.values.data() + (size_t)k * kEnvelopeBlockEntries, ADD_VALUES));
    }
  PetscCallAbort(PETSC_COMM_SELF, MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCallAbort(PETSC_COMM_SELF, MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  return A;
}

// A solver of `A` by the block LU (or by PETSc's LU), as Newton's: preonly with the PC.
KSP MakeSolver(Mat A, bool block_lu)
{
  KSP ksp;
  PC  pc;
  PetscCallAbort(PETSC_COMM_SELF, KSPCreate(PETSC_COMM_SELF, &ksp));
  PetscCallAbort(PETSC_COMM_SELF, KSPSetType(ksp, KSPPREONLY));
  PetscCallAbort(PETSC_COMM_SELF, KSPSetOperators(ksp, A, A));
  PetscCallAbort(PETSC_COMM_SELF, KSPGetPC(ksp, &pc));
  if (block_lu) PetscCallAbort(PETSC_COMM_SELF, PCSetBlockLU(pc));
  else {
    PetscCallAbort(PETSC_COMM_SELF, PCSetType(pc, PCLU));
    PetscCallAbort(PETSC_COMM_SELF, PCFactorSetMatSolverType(pc, MATSOLVERPETSC));
  }
  return ksp;
}

// max |x_block - x_petsc| / max |x_petsc| for one right-hand side.
double SolutionDifference(KSP block, KSP petsc, int size)
{
  Vec b, x, y;
  PetscCallAbort(PETSC_COMM_SELF, VecCreateSeq(PETSC_COMM_SELF, size, &b));
  PetscCallAbort(PETSC_COMM_SELF, VecDuplicate(b, &x));
  PetscCallAbort(PETSC_COMM_SELF, VecDuplicate(b, &y));
  for (PetscInt i = 0; i < size; ++i) PetscCallAbort(PETSC_COMM_SELF, VecSetValue(b, i, std::sin(1.0 + i), INSERT_VALUES));
  PetscCallAbort(PETSC_COMM_SELF, VecAssemblyBegin(b));
  PetscCallAbort(PETSC_COMM_SELF, VecAssemblyEnd(b));
  PetscCallAbort(PETSC_COMM_SELF, KSPSolve(block, b, x));
  PetscCallAbort(PETSC_COMM_SELF, KSPSolve(petsc, b, y));
  PetscReal scale, difference;
  PetscCallAbort(PETSC_COMM_SELF, VecNorm(y, NORM_INFINITY, &scale));
  PetscCallAbort(PETSC_COMM_SELF, VecAXPY(x, -1.0, y));
  PetscCallAbort(PETSC_COMM_SELF, VecNorm(x, NORM_INFINITY, &difference));
  PetscCallAbort(PETSC_COMM_SELF, VecDestroy(&b));
  PetscCallAbort(PETSC_COMM_SELF, VecDestroy(&x));
  PetscCallAbort(PETSC_COMM_SELF, VecDestroy(&y));
  return difference / scale;
}

} // namespace

TEST(BlockLUPreconditioner, FitsSeqBaijWithBlocksOfSixOnly)
{
  std::mt19937 generator(21);
  Mat          baij = ToBaij(MakeMatrix(4, Chain(4), 2.0, &generator)), aij, baij1;
  bool         fits;
  ASSERT_EQ(BlockLUFits(baij, &fits), PETSC_SUCCESS);
  EXPECT_TRUE(fits);
  ASSERT_EQ(MatConvert(baij, MATSEQAIJ, MAT_INITIAL_MATRIX, &aij), PETSC_SUCCESS);
  ASSERT_EQ(BlockLUFits(aij, &fits), PETSC_SUCCESS);
  EXPECT_FALSE(fits);
  ASSERT_EQ(MatCreateSeqBAIJ(PETSC_COMM_SELF, 1, 24, 24, 1, nullptr, &baij1), PETSC_SUCCESS);
  ASSERT_EQ(BlockLUFits(baij1, &fits), PETSC_SUCCESS);
  EXPECT_FALSE(fits);
  MatDestroy(&baij);
  MatDestroy(&aij);
  MatDestroy(&baij1);
}

// Solves as PETSc's LU; refactors new values of the same matrix (its state changes); analyses a
// new matrix of another pattern given to the same solver.
TEST(BlockLUPreconditioner, SolvesAsPetscLUAndFollowsValuesAndPatterns)
{
  std::mt19937 generator(23);
  const int    n      = 30;
  auto         blocks = RandomPattern(n, 6, false, &generator);
  Mat          A      = ToBaij(MakeMatrix(n, blocks, 4.0, &generator));
  KSP          block = MakeSolver(A, true), petsc = MakeSolver(A, false);
  EXPECT_LT(SolutionDifference(block, petsc, B * n), 1e-12);
  // New values, same pattern.
  const BlockMatrix other = MakeMatrix(n, blocks, 3.0, &generator);
  for (PetscInt i = 0; i < n; ++i)
    for (int k = other.row_start[i]; k < other.row_start[i + 1]; ++k) {
      const PetscInt column = other.columns[k];
      ASSERT_EQ(MatSetValuesBlocked(A, 1, &i, 1, &column, other.values.data() + (size_t)k * kEnvelopeBlockEntries, INSERT_VALUES), PETSC_SUCCESS);
    }
  ASSERT_EQ(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY), PETSC_SUCCESS);
  ASSERT_EQ(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY), PETSC_SUCCESS);
  EXPECT_LT(SolutionDifference(block, petsc, B * n), 1e-12);
  // Another matrix of another pattern (a chain), then one of another size after a reset (as
  // Newton resets its solver after a failure), in the same solvers.
  Mat C = ToBaij(MakeMatrix(n, Chain(n), 2.0, &generator));
  ASSERT_EQ(KSPSetOperators(block, C, C), PETSC_SUCCESS);
  ASSERT_EQ(KSPSetOperators(petsc, C, C), PETSC_SUCCESS);
  MatDestroy(&A);
  EXPECT_LT(SolutionDifference(block, petsc, B * n), 1e-12);
  Mat D = ToBaij(MakeMatrix(n + 5, RandomPattern(n + 5, 3, true, &generator), 4.0, &generator));
  ASSERT_EQ(KSPReset(block), PETSC_SUCCESS);
  ASSERT_EQ(KSPReset(petsc), PETSC_SUCCESS);
  ASSERT_EQ(KSPSetOperators(block, D, D), PETSC_SUCCESS);
  ASSERT_EQ(KSPSetOperators(petsc, D, D), PETSC_SUCCESS);
  EXPECT_LT(SolutionDifference(block, petsc, B * (n + 5)), 1e-12);
  KSPDestroy(&block);
  KSPDestroy(&petsc);
  MatDestroy(&C);
  MatDestroy(&D);
}

// A singular diagonal block fails the preconditioner (no error raised), names its unknowns, and
// the solution is not finite; regular values afterwards factor again.
TEST(BlockLUPreconditioner, ReportsASingularDiagonalBlockAsAFailedSetUp)
{
  std::mt19937 generator(29);
  const int    n = 6;
  BlockMatrix  m = MakeMatrix(n, Chain(n), 2.0, &generator);
  for (int k = m.row_start[3]; k < m.row_start[4]; ++k) std::fill_n(m.values.begin() + (long)k * kEnvelopeBlockEntries, kEnvelopeBlockEntries, 0.0);
  Mat A   = ToBaij(m);
  KSP ksp = MakeSolver(A, true);
  PC  pc;
  Vec b, x;
  ASSERT_EQ(KSPGetPC(ksp, &pc), PETSC_SUCCESS);
  ASSERT_EQ(MatCreateVecs(A, &x, &b), PETSC_SUCCESS);
  ASSERT_EQ(VecSet(b, 1.0), PETSC_SUCCESS);
  ASSERT_EQ(KSPSolve(ksp, b, x), PETSC_SUCCESS);
  KSPConvergedReason reason;
  ASSERT_EQ(KSPGetConvergedReason(ksp, &reason), PETSC_SUCCESS);
  EXPECT_EQ(reason, KSP_DIVERGED_PC_FAILED);
  PCFailedReason failed;
  ASSERT_EQ(PCGetFailedReason(pc, &failed), PETSC_SUCCESS);
  EXPECT_EQ(failed, PC_FACTOR_NUMERIC_ZEROPIVOT);
  bool        is_block_lu;
  std::string detail;
  ASSERT_EQ(BlockLUDescribeFailure(pc, &is_block_lu, &detail), PETSC_SUCCESS);
  EXPECT_TRUE(is_block_lu);
  EXPECT_EQ(detail, "zero pivot in the diagonal block of unknowns 18..23 of the block LU");
  PetscReal norm;
  ASSERT_EQ(VecNorm(x, NORM_INFINITY, &norm), PETSC_SUCCESS);
  EXPECT_FALSE(std::isfinite(norm));
  // The block made regular again: the next solve factors and succeeds.
  for (PetscInt row = 18; row < 24; ++row) ASSERT_EQ(MatSetValue(A, row, row, 1.0, INSERT_VALUES), PETSC_SUCCESS);
  ASSERT_EQ(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY), PETSC_SUCCESS);
  ASSERT_EQ(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY), PETSC_SUCCESS);
  ASSERT_EQ(KSPSolve(ksp, b, x), PETSC_SUCCESS);
  ASSERT_EQ(KSPGetConvergedReason(ksp, &reason), PETSC_SUCCESS);
  EXPECT_GT(reason, 0);
  ASSERT_EQ(BlockLUDescribeFailure(pc, &is_block_lu, &detail), PETSC_SUCCESS);
  EXPECT_TRUE(detail.empty());
  VecDestroy(&b);
  VecDestroy(&x);
  KSPDestroy(&ksp);
  MatDestroy(&A);
}

// The block LU suits a chain, not a comb whose long branches RCM interleaves (its envelope holds
// several times the LU's fill), nor a matrix for which an option names PETSc's PC or one of its
// factorisation settings under the same prefix.
TEST(BlockLUPreconditioner, SuitsChainsNotCombsNorMatricesWhosePCAnOptionNames)
{
  std::mt19937 generator(37);
  Mat          chain = ToBaij(MakeMatrix(60, Chain(60), 2.0, &generator));
  // A comb: a spine of 12 nodes with a branch of 9 at each.
  std::vector<std::pair<int, int>> comb;
  const int                        spine = 12, branch = 9, n = spine * (1 + branch);
  for (int i = 0; i < n; ++i) comb.push_back({i, i});
  for (int s = 0; s < spine; ++s) {
    if (s > 0) comb.push_back({(s - 1) * (1 + branch), s * (1 + branch)}), comb.push_back({s * (1 + branch), (s - 1) * (1 + branch)});
    for (int k = 1; k <= branch; ++k) {
      const int a = s * (1 + branch) + k - 1, b = a + 1;
      comb.push_back({a, b}), comb.push_back({b, a});
    }
  }
  Mat    comb_matrix = ToBaij(MakeMatrix(n, comb, 4.0, &generator));
  double chain_ratio, comb_ratio;
  ASSERT_EQ(BlockLUEnvelopeOverFill(chain, &chain_ratio), PETSC_SUCCESS);
  ASSERT_EQ(BlockLUEnvelopeOverFill(comb_matrix, &comb_ratio), PETSC_SUCCESS);
  EXPECT_DOUBLE_EQ(chain_ratio, 1.0);
  EXPECT_GT(comb_ratio, kBlockLUEnvelopeOverFill);
  bool suits;
  ASSERT_EQ(BlockLUSuits(chain, "probe_", &suits), PETSC_SUCCESS);
  EXPECT_TRUE(suits);
  ASSERT_EQ(BlockLUSuits(comb_matrix, "probe_", &suits), PETSC_SUCCESS);
  EXPECT_FALSE(suits);
  for (const char *option : {"-probe_pc_type", "-probe_pc_factor_shift_type", "-probe_pc_factor_zeropivot"}) {
    ASSERT_EQ(PetscOptionsSetValue(nullptr, option, "1"), PETSC_SUCCESS);
    ASSERT_EQ(BlockLUSuits(chain, "probe_", &suits), PETSC_SUCCESS);
    EXPECT_FALSE(suits) << option;
    ASSERT_EQ(BlockLUSuits(chain, "other_", &suits), PETSC_SUCCESS); // another prefix's option
    EXPECT_TRUE(suits) << option;
    ASSERT_EQ(PetscOptionsClearValue(nullptr, option), PETSC_SUCCESS);
  }
  Mat aij;
  ASSERT_EQ(MatConvert(chain, MATSEQAIJ, MAT_INITIAL_MATRIX, &aij), PETSC_SUCCESS);
  ASSERT_EQ(BlockLUSuits(aij, "probe_", &suits), PETSC_SUCCESS);
  EXPECT_FALSE(suits);
  MatDestroy(&aij);
  MatDestroy(&chain);
  MatDestroy(&comb_matrix);
}

// PCSetBlockLU on a PC that is a block LU already starts afresh (no context left behind).
TEST(BlockLUPreconditioner, SetTwiceSolvesAsOnce)
{
  std::mt19937 generator(41);
  const int    n     = 10;
  Mat          A     = ToBaij(MakeMatrix(n, Chain(n), 2.0, &generator));
  KSP          block = MakeSolver(A, true), petsc = MakeSolver(A, false);
  PC           pc;
  ASSERT_EQ(KSPGetPC(block, &pc), PETSC_SUCCESS);
  ASSERT_EQ(PCSetBlockLU(pc), PETSC_SUCCESS);
  EXPECT_LT(SolutionDifference(block, petsc, B * n), 1e-12);
  KSPDestroy(&block);
  KSPDestroy(&petsc);
  MatDestroy(&A);
}
