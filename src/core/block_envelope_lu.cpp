// Block Doolittle elimination inside the envelope, row i after row i - 1 (f = first(i)):
//   L_ij = (A_ij - sum_{k = max(f, first(j))}^{j-1} L_ik U_kj) D_j^{-1},  f <= j < i
//   U_ji =  A_ji - sum_{k = max(f, first(j))}^{j-1} L_jk U_ki,            f <= j < i
//   D_i  =  A_ii - sum_{k = f}^{i-1} L_ik U_ki,  kept as D_i^{-1}.
// Solve: y = L^{-1} P b by rows, then x_i = D_i^{-1} (y_i - sum_{k > i} U_ik x_k) by columns.
#include "core/block_envelope_lu.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace msflex {

namespace {

constexpr int B = kEnvelopeBlock;

// c -= a b (6x6, column-major). Each column of c is summed in a local array the compiler keeps in
// registers (restrict: c does not alias a or b); without it GCC emitted scalar code.
inline void SubtractProduct(const double *__restrict a, const double *__restrict b, double *__restrict c)
{
  for (int col = 0; col < B; ++col) {
    double sum[B];
    for (int r = 0; r < B; ++r) sum[r] = c[r + B * col];
    for (int k = 0; k < B; ++k) {
      const double bk = b[k + B * col];
      for (int r = 0; r < B; ++r) sum[r] -= a[r + B * k] * bk;
    }
    for (int r = 0; r < B; ++r) c[r + B * col] = sum[r];
  }
}

// c = a b (6x6, column-major).
inline void Product(const double *__restrict a, const double *__restrict b, double *__restrict c)
{
  for (int col = 0; col < B; ++col) {
    double sum[B] = {};
    for (int k = 0; k < B; ++k) {
      const double bk = b[k + B * col];
      for (int r = 0; r < B; ++r) sum[r] += a[r + B * k] * bk;
    }
    for (int r = 0; r < B; ++r) c[r + B * col] = sum[r];
  }
}

// y -= a x (6x6 times 6).
inline void SubtractProductVector(const double *__restrict a, const double *__restrict x, double *__restrict y)
{
  double sum[B];
  for (int r = 0; r < B; ++r) sum[r] = y[r];
  for (int k = 0; k < B; ++k)
    for (int r = 0; r < B; ++r) sum[r] -= a[r + B * k] * x[k];
  for (int r = 0; r < B; ++r) y[r] = sum[r];
}

// y = a x (6x6 times 6).
inline void ProductVector(const double *__restrict a, const double *__restrict x, double *__restrict y)
{
  double sum[B] = {};
  for (int k = 0; k < B; ++k)
    for (int r = 0; r < B; ++r) sum[r] += a[r + B * k] * x[k];
  for (int r = 0; r < B; ++r) y[r] = sum[r];
}

// Gauss-Jordan step K (unrolled by the template: constant strides, the factors in registers).
template <int K> inline bool GaussJordanSteps(double *__restrict a, int *swapped_with)
{
  if constexpr (K == B) return true;
  else {
    int    p       = K;
    double largest = std::abs(a[K + B * K]);
    for (int r = K + 1; r < B; ++r)
      if (std::abs(a[r + B * K]) > largest) {
        largest = std::abs(a[r + B * K]);
        p       = r;
      }
    if (!(largest > 0.0)) return false; // zero (or NaN) pivot
    swapped_with[K] = p;
    if (p != K)
      for (int c = 0; c < B; ++c) std::swap(a[K + B * c], a[p + B * c]);
    // Column K becomes e_K times the pivot's inverse after the row operations below.
    double factor[B];
    for (int r = 0; r < B; ++r) factor[r] = a[r + B * K];
    factor[K]          = 0.0;
    const double pivot = 1.0 / a[K + B * K];
    for (int r = 0; r < B; ++r) a[r + B * K] = 0.0;
    a[K + B * K] = 1.0;
    for (int c = 0; c < B; ++c) {
      const double row_k = a[K + B * c] * pivot;
      a[K + B * c]       = row_k;
      for (int r = 0; r < B; ++r) a[r + B * c] -= factor[r] * row_k;
    }
    return GaussJordanSteps<K + 1>(a, swapped_with);
  }
}

// Position of each block row in `order`, and the first position of each position's envelope in
// the pattern made symmetric: first[i] = min(i, j : (i, j) or (j, i) stored).
void SymmetricEnvelope(int n, const int *row_start, const int *columns, const std::vector<int> &order, std::vector<int> *position, std::vector<int> *first)
{
  position->resize(n);
  first->resize(n);
  for (int i = 0; i < n; ++i) (*position)[order[i]] = i, (*first)[i] = i;
  for (int row = 0; row < n; ++row)
    for (int k = row_start[row]; k < row_start[row + 1]; ++k) {
      const int i = (*position)[row], j = (*position)[columns[k]], later = std::max(i, j);
      (*first)[later] = std::min((*first)[later], std::min(i, j));
    }
}

} // namespace

bool InvertEnvelopeBlock(double *a)
{
  // Row pivoting turns A into P A; (P A)^{-1} P = A^{-1}, i.e. the inverse's columns swapped back
  // in the reverse order of the row swaps.
  int swapped_with[B];
  if (!GaussJordanSteps<0>(a, swapped_with)) return false;
  for (int k = B - 1; k >= 0; --k)
    if (swapped_with[k] != k)
      for (int r = 0; r < B; ++r) std::swap(a[r + B * k], a[r + B * swapped_with[k]]);
  return true;
}

BlockEnvelopeCount CountBlockEnvelope(int num_block_rows, const int *row_start, const int *columns, const std::vector<int> &order)
{
  const int        n = num_block_rows;
  std::vector<int> position, first;
  SymmetricEnvelope(n, row_start, columns, order, &position, &first);
  // The symmetrised pattern's lower part in factorisation order: lower[i] holds the j < i coupled to i.
  std::vector<int> lower_start(n + 1, 0), lower;
  for (int row = 0; row < n; ++row)
    for (int k = row_start[row]; k < row_start[row + 1]; ++k) {
      const int i = position[row], j = position[columns[k]];
      if (i != j) ++lower_start[std::max(i, j) + 1];
    }
  for (int i = 0; i < n; ++i) lower_start[i + 1] += lower_start[i];
  lower.resize(lower_start[n]);
  std::vector<int> next(lower_start.begin(), lower_start.end() - 1);
  for (int row = 0; row < n; ++row)
    for (int k = row_start[row]; k < row_start[row + 1]; ++k) {
      const int i = position[row], j = position[columns[k]];
      if (i != j) lower[next[std::max(i, j)]++] = std::min(i, j);
    }
  BlockEnvelopeCount count;
  // Elimination tree (Liu: the root of j's subtree so far, with path compression), then row i of L
  // is the union of the tree paths from its pattern's columns up to i (each node marked once).
  std::vector<int> parent(n, -1), ancestor(n, -1), mark(n, -1);
  for (int i = 0; i < n; ++i) {
    count.envelope += (size_t)(i - first[i]);
    for (int k = lower_start[i]; k < lower_start[i + 1]; ++k)
      for (int r = lower[k]; r != i;) {
        const int up = ancestor[r];
        ancestor[r]  = i;
        if (up == -1) {
          parent[r] = i;
          break;
        }
        r = up;
      }
    mark[i] = i;
    for (int k = lower_start[i]; k < lower_start[i + 1]; ++k)
      for (int r = lower[k]; mark[r] != i; r = parent[r]) {
        mark[r] = i;
        ++count.fill;
      }
  }
  return count;
}

void BlockEnvelopeLU::Analyse(int num_block_rows, const int *row_start, const int *columns, const std::vector<int> &order)
{
  const int n     = num_block_rows;
  num_block_rows_ = n;
  order_          = order;
  // The envelope of the pattern made symmetric: row i's first column and column i's first row
  // alike, so that L's row i and U's column i have the same extent.
  std::vector<int> position;
  SymmetricEnvelope(n, row_start, columns, order, &position, &first_);
  offset_.resize(n + 1);
  offset_[0] = 0;
  for (int i = 0; i < n; ++i) offset_[i + 1] = offset_[i] + 2 * (size_t)(i - first_[i]) + 1;
  factors_.assign(offset_[n] * kEnvelopeBlockEntries, 0.0);
  destination_.resize(row_start[n]);
  for (int row = 0; row < n; ++row)
    for (int k = row_start[row]; k < row_start[row + 1]; ++k) {
      const int    i = position[row], j = position[columns[k]];
      const size_t band_i = (size_t)(i - first_[i]), band_j = (size_t)(j - first_[j]);
      size_t       block;
      if (j < i) block = offset_[i] + (size_t)(j - first_[i]);               // L_ij
      else if (j > i) block = offset_[j] + band_j + (size_t)(i - first_[j]); // U_ij, in column j
      else block = offset_[i] + 2 * band_i;                                  // D_i
      destination_[k] = block * kEnvelopeBlockEntries;
    }
  // Which CSR block reaches its slot first (copied there), and the slots none reaches (fill).
  std::vector<char> reached(offset_[n], 0);
  first_in_slot_.resize(destination_.size());
  for (size_t k = 0; k < destination_.size(); ++k) {
    char &slot        = reached[destination_[k] / kEnvelopeBlockEntries];
    first_in_slot_[k] = !slot;
    slot              = 1;
  }
  fill_.clear();
  for (size_t block = 0; block < offset_[n]; ++block)
    if (!reached[block]) fill_.push_back(block * kEnvelopeBlockEntries);
  work_.resize((size_t)n * B);
}

int BlockEnvelopeLU::Factor(const double *values)
{
  const int n = num_block_rows_;
  // The pattern's blocks copied (a block listed again added), the fill set to zero.
  for (size_t block : fill_) std::fill_n(factors_.data() + block, kEnvelopeBlockEntries, 0.0);
  for (size_t k = 0; k < destination_.size(); ++k) {
    double       *to   = factors_.data() + destination_[k];
    const double *from = values + k * kEnvelopeBlockEntries;
    // Loops, not memcpy: a copy of 288 bytes became `rep movsq`, a quarter of the factorisation.
    if (first_in_slot_[k])
      for (int e = 0; e < kEnvelopeBlockEntries; ++e) to[e] = from[e];
    else
      for (int e = 0; e < kEnvelopeBlockEntries; ++e) to[e] += from[e];
  }
  double sum[kEnvelopeBlockEntries];
  for (int i = 0; i < n; ++i) {
    const int f = first_[i], band = i - f;
    double   *lower_row = factors_.data() + offset_[i] * kEnvelopeBlockEntries; // L_i,f..i-1
    double   *upper_col = lower_row + (size_t)band * kEnvelopeBlockEntries;     // U_f..i-1,i
    double   *diagonal  = upper_col + (size_t)band * kEnvelopeBlockEntries;     // D_i
    for (int j = f; j < i; ++j) {
      const int     fj = first_[j], k0 = std::max(f, fj), band_j = j - fj;
      const double *lower_row_j = factors_.data() + offset_[j] * kEnvelopeBlockEntries;
      const double *upper_col_j = lower_row_j + (size_t)band_j * kEnvelopeBlockEntries;
      const double *inverse_j   = upper_col_j + (size_t)band_j * kEnvelopeBlockEntries;
      double       *lower_ij    = lower_row + (size_t)(j - f) * kEnvelopeBlockEntries;
      double       *upper_ji    = upper_col + (size_t)(j - f) * kEnvelopeBlockEntries;
      for (int k = k0; k < j; ++k) {
        SubtractProduct(lower_row + (size_t)(k - f) * kEnvelopeBlockEntries, upper_col_j + (size_t)(k - fj) * kEnvelopeBlockEntries, lower_ij);
        SubtractProduct(lower_row_j + (size_t)(k - fj) * kEnvelopeBlockEntries, upper_col + (size_t)(k - f) * kEnvelopeBlockEntries, upper_ji);
      }
      for (int e = 0; e < kEnvelopeBlockEntries; ++e) sum[e] = lower_ij[e];
      Product(sum, inverse_j, lower_ij);
    }
    for (int k = f; k < i; ++k)
      SubtractProduct(lower_row + (size_t)(k - f) * kEnvelopeBlockEntries, upper_col + (size_t)(k - f) * kEnvelopeBlockEntries, diagonal);
    if (!InvertEnvelopeBlock(diagonal)) return order_[i] + 1;
  }
  return 0;
}

void BlockEnvelopeLU::Solve(const double *b, double *x) const
{
  // y in factorisation order: b read in that order by the forward sweep (which uses all of b before
  // the backward sweep writes x, so x may be b), x written back in the original order.
  const int n = num_block_rows_;
  double   *y = work_.data();
  for (int i = 0; i < n; ++i) {
    const int     f         = first_[i];
    const double *lower_row = factors_.data() + offset_[i] * kEnvelopeBlockEntries;
    const double *bi        = b + (size_t)B * order_[i];
    double        yi[B];
    for (int r = 0; r < B; ++r) yi[r] = bi[r];
    for (int j = f; j < i; ++j) SubtractProductVector(lower_row + (size_t)(j - f) * kEnvelopeBlockEntries, y + (size_t)B * j, yi);
    for (int r = 0; r < B; ++r) y[(size_t)B * i + r] = yi[r];
  }
  for (int i = n - 1; i >= 0; --i) {
    const int     f = first_[i], band = i - f;
    const double *upper_col = factors_.data() + (offset_[i] + (size_t)band) * kEnvelopeBlockEntries;
    const double *inverse   = upper_col + (size_t)band * kEnvelopeBlockEntries;
    double        xi[B];
    ProductVector(inverse, y + (size_t)B * i, xi);
    double *out = x + (size_t)B * order_[i];
    for (int r = 0; r < B; ++r) out[r] = xi[r];
    for (int j = f; j < i; ++j) SubtractProductVector(upper_col + (size_t)(j - f) * kEnvelopeBlockEntries, xi, y + (size_t)B * j);
  }
}

} // namespace msflex
