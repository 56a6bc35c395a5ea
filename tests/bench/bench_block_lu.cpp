// Micro-benchmark of the direct solvers of a banded tangent: a chain of N 6x6 blocks (a beam of N
// - 1 two-node elements, block tridiagonal, diagonally dominant random values), factored and
// solved by msflex's block envelope LU (core/block_envelope_lu.hpp) and by PETSc's LU of the same
// matrix stored as SEQBAIJ with blocks of 6, natural order (which PETSc factors with its
// unrolled block kernels). Prints the median and minimum over rounds of wall time per
// factorisation and per solve, and the largest difference of the two solutions; asserts nothing.
// Usage: bench_block_lu [blocks (1001)] [rounds (9)]   (run through scripts/bench-kernel --lu)
#include "core/block_envelope_lu.hpp"

#include <petscksp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

using namespace msflex;

namespace {

double Seconds() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

void Report(const char *what, std::vector<double> times, int repeats)
{
  std::sort(times.begin(), times.end());
  std::printf("%-34s median %8.2f us   min %8.2f us\n", what, 1e6 * times[times.size() / 2] / repeats, 1e6 * times.front() / repeats);
}

} // namespace

int main(int argc, char **argv)
{
  const int blocks = argc > 1 ? std::atoi(argv[1]) : 1001, rounds = argc > 2 ? std::atoi(argv[2]) : 9, repeats = 50;
  PetscCall(PetscInitialize(nullptr, nullptr, nullptr, nullptr));
  // Block tridiagonal pattern, block CSR with sorted columns.
  std::vector<int>                       row_start{0}, columns;
  std::vector<double>                    values;
  std::mt19937                           generator(1);
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  for (int i = 0; i < blocks; ++i) {
    for (int j = std::max(0, i - 1); j <= std::min(blocks - 1, i + 1); ++j) {
      columns.push_back(j);
      for (int e = 0; e < kEnvelopeBlockEntries; ++e) values.push_back(entry(generator) + (i == j && e % 7 == 0 ? 8.0 : 0.0));
    }
    row_start.push_back((int)columns.size());
  }
  const int           n = kEnvelopeBlock * blocks;
  std::vector<double> b(n), x(n);
  for (double &value : b) value = entry(generator);

  BlockEnvelopeLU  lu;
  std::vector<int> order(blocks);
  for (int i = 0; i < blocks; ++i) order[i] = i;
  lu.Analyse(blocks, row_start.data(), columns.data(), order);
  std::vector<double> factor_times, solve_times;
  for (int r = 0; r < rounds; ++r) {
    double start = Seconds();
    for (int k = 0; k < repeats; ++k)
      if (lu.Factor(values.data()) != 0) std::abort();
    factor_times.push_back(Seconds() - start);
    start = Seconds();
    for (int k = 0; k < repeats; ++k) lu.Solve(b.data(), x.data());
    solve_times.push_back(Seconds() - start);
  }
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::printf("%d blocks of 6 (block tridiagonal), %d rounds of %d\n", blocks, rounds, repeats);
  Report("block envelope LU: factor", factor_times, repeats);
  Report("block envelope LU: solve", solve_times, repeats);

  // PETSc: the same matrix as SEQBAIJ (PETSc's blocks are column-major too).
  Mat A, F;
  IS  row_order, column_order;
  PetscCall(MatCreateSeqBAIJ(PETSC_COMM_SELF, kEnvelopeBlock, n, n, 3, nullptr, &A));
  PetscCall(MatSetOption(A, MAT_ROW_ORIENTED, PETSC_FALSE)); // the blocks are column-major
  for (PetscInt i = 0; i < blocks; ++i)
    for (int k = row_start[i]; k < row_start[i + 1]; ++k) {
      const PetscInt column = columns[k];
      PetscCall(MatSetValuesBlocked(A, 1, &i, 1, &column, values.data() + (size_t)k * kEnvelopeBlockEntries, INSERT_VALUES));
    }
  PetscCall(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatGetOrdering(A, MATORDERINGNATURAL, &row_order, &column_order));
  PetscCall(MatGetFactor(A, MATSOLVERPETSC, MAT_FACTOR_LU, &F));
  MatFactorInfo info;
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatLUFactorSymbolic(F, A, row_order, column_order, &info));
  Vec bv, xv;
  PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n, b.data(), &bv));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, n, &xv));
  factor_times.clear();
  solve_times.clear();
  for (int r = 0; r < rounds; ++r) {
    double start = Seconds();
    for (int k = 0; k < repeats; ++k) PetscCall(MatLUFactorNumeric(F, A, &info));
    factor_times.push_back(Seconds() - start);
    start = Seconds();
    for (int k = 0; k < repeats; ++k) PetscCall(MatSolve(F, bv, xv));
    solve_times.push_back(Seconds() - start);
  }
  Report("PETSc BAIJ LU: factor", factor_times, repeats);
  Report("PETSc BAIJ LU: solve", solve_times, repeats);
  const PetscScalar *petsc_x;
  PetscCall(VecGetArrayRead(xv, &petsc_x));
  double difference = 0.0, scale = 0.0;
  for (int i = 0; i < n; ++i) {
    difference = std::max(difference, std::abs(petsc_x[i] - x[i]));
    scale      = std::max(scale, std::abs(x[i]));
  }
  std::printf("largest difference of the solutions: %.2e (largest entry %.2e)\n", difference, scale);
  PetscCall(VecRestoreArrayRead(xv, &petsc_x));
  PetscCall(VecDestroy(&bv));
  PetscCall(VecDestroy(&xv));
  PetscCall(ISDestroy(&row_order));
  PetscCall(ISDestroy(&column_order));
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&A));
  PetscCall(PetscFinalize());
  return 0;
}
