// Block LU of a sparse matrix of 6x6 blocks (a beam network's tangent, one block per node) within
// its envelope, in a given order of the block rows (RCM: a chain's tangent is then block
// tridiagonal):
//   A(p, p) = L U,   L unit lower by blocks, U upper by blocks, fill only inside the envelope
//   first(i) = min { j : A_ij != 0 or A_ji != 0 },  (L_ij, U_ji) for first(i) <= j < i.
// Pivoting is by rows inside each 6x6 diagonal block only (as PETSc's own BAIJ LU pivots), so
// the factorisation exists when every leading block minor is regular; a diagonal block that is
// exactly singular is reported as a failure, never raised. The diagonal blocks are kept inverted:
// L_ij = T_ij D_j^{-1} and x_i = D_i^{-1} y_i are then 6x6 products, the fastest form at this size
// (a 1000-block chain factors in 0.55 of PETSc's BAIJ time: docs/performance.md).
// Blocks are column-major (entry (r, c) at r + 6 c), as PETSc's BAIJ stores them. Pure: no PETSc,
// no MPI.
#pragma once

#include <cstddef>
#include <vector>

namespace msflex {

constexpr int kEnvelopeBlock        = 6; // unknowns per block
constexpr int kEnvelopeBlockEntries = kEnvelopeBlock * kEnvelopeBlock;

class BlockEnvelopeLU {
public:
  // The pattern, as block CSR (row_start[n + 1], columns: block columns of each block row, in any
  // order), and the order of the factorisation: order[i] is the block row factored i-th. Fixes the
  // envelope and where each stored block of the CSR goes in it.
  void Analyse(int num_block_rows, const int *row_start, const int *columns, const std::vector<int> &order);

  // Factors the values of the pattern given to Analyse (block k of the CSR at values + 36 k).
  // Returns 0, or i + 1 for the block row i (numbered as in the CSR) of the first diagonal block,
  // in factorisation order, that is exactly singular once updated by the rows before it (nothing
  // can be solved then).
  int Factor(const double *values);

  // x = A^{-1} b with the factors of a successful Factor (x and b may be the same array).
  void Solve(const double *b, double *x) const;

  int NumBlockRows() const { return num_block_rows_; }
  // Blocks held (L, U and the diagonal): the fill inside the envelope included.
  size_t NumStoredBlocks() const { return factors_.size() / kEnvelopeBlockEntries; }

private:
  int                         num_block_rows_ = 0;
  std::vector<int>            order_;         // position -> block row
  std::vector<int>            first_;         // position -> first position of its envelope
  std::vector<size_t>         offset_;        // position i -> its L_i,first..i-1, U_first..i-1,i, D_i^{-1} (blocks)
  std::vector<size_t>         destination_;   // CSR block k -> its block in factors_ (first entry)
  std::vector<char>           first_in_slot_; // CSR block k is the first to reach its block (copied, not added)
  std::vector<size_t>         fill_;          // blocks of factors_ no CSR block reaches (first entries)
  std::vector<double>         factors_;
  mutable std::vector<double> work_; // the permuted right-hand side of Solve
};

// Blocks below the diagonal, for a pattern and an order as Analyse takes them: those the envelope
// holds (sum of i - first(i)) and those an LU with fill only where elimination creates it holds
// (the symbolic factorisation of the symmetrised pattern in that order, row by row along its
// elimination tree). Their ratio tells whether the envelope wastes work: 1 for a chain, about
// 1-1.5 for slender frames and strips, far more for trees and combs, whose branches RCM
// interleaves.
struct BlockEnvelopeCount {
  size_t envelope = 0, fill = 0;
};
BlockEnvelopeCount CountBlockEnvelope(int num_block_rows, const int *row_start, const int *columns, const std::vector<int> &order);

// Inverts a 6x6 column-major block in place by Gauss-Jordan elimination with row pivoting (the
// largest entry of the column at or below the diagonal). Returns false, leaving `a` undefined, when
// a pivot is exactly zero.
bool InvertEnvelopeBlock(double *a);

} // namespace msflex
