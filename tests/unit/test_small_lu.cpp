// The small dense LU (core/small_lu.hpp) against LAPACK's getrf/getrs on the same matrices: the
// same row interchanges and factors to round-off, solutions with residuals at round-off, and the
// same first zero pivot of an exactly singular matrix.
#include "core/small_lu.hpp"

#include <gtest/gtest.h>
#include <petscsys.h>

#include <petscblaslapack.h> // after petscsys.h, which it needs

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

using namespace msflex;

namespace {

// A random n x n matrix, column-major, entries in [-1, 1], with `diagonal` added on the diagonal
// (0: a general matrix that needs row interchanges).
std::vector<double> RandomMatrix(int n, double diagonal, std::mt19937 *generator)
{
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  std::vector<double>                    a((size_t)n * n);
  for (double &value : a) value = entry(*generator);
  for (int i = 0; i < n; ++i) a[i + (size_t)n * i] += diagonal;
  return a;
}

double MaxAbs(const std::vector<double> &v)
{
  double largest = 0.0;
  for (double x : v) largest = std::max(largest, std::fabs(x));
  return largest;
}

} // namespace

TEST(SmallLU, FactorsAndSolvesAsLapackDoes)
{
  std::mt19937 generator(7);
  for (int n : {1, 2, 3, 5, 9, 13, 24, 49, kSmallLUMaxSize}) {
    for (double diagonal : {0.0, 2.0}) {
      const std::vector<double> a    = RandomMatrix(n, diagonal, &generator);
      std::vector<double>       mine = a, lapack = a;
      std::vector<int>          pivots(n);
      std::vector<PetscBLASInt> lapack_pivots(n);
      PetscBLASInt              size = n, info = 0;
      EXPECT_EQ(FactorSmallLU(n, mine.data(), pivots.data()), 0) << "n = " << n;
      LAPACKgetrf_(&size, &size, lapack.data(), &size, lapack_pivots.data(), &info);
      ASSERT_EQ(info, 0);
      for (int k = 0; k < n; ++k) EXPECT_EQ(pivots[k] + 1, (int)lapack_pivots[k]) << "n = " << n << ", column " << k;
      double difference = 0.0;
      for (size_t i = 0; i < a.size(); ++i) difference = std::max(difference, std::fabs(mine[i] - lapack[i]));
      EXPECT_LT(difference, 1e-12 * n * MaxAbs(a)) << "n = " << n; // growth of a few orders at most
      // A x = b: the residual at round-off of |A| |x|.
      std::uniform_real_distribution<double> entry(-1.0, 1.0);
      std::vector<double>                    b(n), x(n);
      for (double &value : b) value = entry(generator);
      x = b;
      SolveSmallLU(n, mine.data(), pivots.data(), x.data());
      std::vector<double> residual(b);
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) residual[i] -= a[i + (size_t)n * j] * x[j];
      EXPECT_LT(MaxAbs(residual), 1e-13 * n * MaxAbs(a) * MaxAbs(x)) << "n = " << n;
      // And the same solution as getrs.
      std::vector<double> y   = b;
      PetscBLASInt        one = 1;
      LAPACKgetrs_("N", &size, &one, lapack.data(), &size, lapack_pivots.data(), y.data(), &size, &info);
      ASSERT_EQ(info, 0);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(x[i], y[i], 1e-11 * MaxAbs(y)) << "n = " << n;
    }
  }
}

// A column that is a combination of earlier ones (here equal to column 1) makes a later pivot
// exactly zero in exact arithmetic; a column of zeros does so in floating point too. The first such
// column is reported 1-based, as getrf's info, and the factorisation goes on past it.
TEST(SmallLU, ReportsTheFirstZeroPivotAsLapackDoes)
{
  std::mt19937 generator(11);
  for (int n : {2, 4, 7, 12}) {
    for (int zero_column = 0; zero_column < n; ++zero_column) {
      std::vector<double> a = RandomMatrix(n, 0.0, &generator);
      for (int i = 0; i < n; ++i) a[i + (size_t)n * zero_column] = 0.0;
      std::vector<double>       mine = a, lapack = a;
      std::vector<int>          pivots(n);
      std::vector<PetscBLASInt> lapack_pivots(n);
      PetscBLASInt              size = n, info = 0;
      const int                 zero = FactorSmallLU(n, mine.data(), pivots.data());
      LAPACKgetrf_(&size, &size, lapack.data(), &size, lapack_pivots.data(), &info);
      EXPECT_EQ(zero, zero_column + 1) << "n = " << n;
      EXPECT_EQ(zero, (int)info) << "n = " << n;
    }
  }
  std::vector<double> empty;
  std::vector<int>    no_pivots;
  EXPECT_EQ(FactorSmallLU(0, empty.data(), no_pivots.data()), 0);
}
