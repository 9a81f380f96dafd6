// Sparsity: validation of CCS arrays with its messages, Dense, FromTriplets, Transpose,
// LowerTriangle, Find/Has and rendering.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;

constexpr std::uint32_t kSeed = 31337;

TEST(SparsityConstruction, ValidArraysAreKept) {
  // [* . *]
  // [. . *]
  // [* . .]
  const Sparsity sp(3, 3, {0, 2, 2, 4}, {0, 2, 0, 1});
  EXPECT_EQ(sp.rows(), 3);
  EXPECT_EQ(sp.cols(), 3);
  EXPECT_EQ(sp.nnz(), 4);
  EXPECT_FALSE(sp.IsDense());
  EXPECT_EQ(sp.colind(), (std::vector<int>{0, 2, 2, 4}));
  EXPECT_EQ(sp.row(), (std::vector<int>{0, 2, 0, 1}));
  EXPECT_EQ(sp.ColumnOfNonzeros(), (std::vector<int>{0, 0, 2, 2}));
  EXPECT_EQ(sp.ToString(), "*.*\n..*\n*..\n");
  const Sparsity empty;
  EXPECT_EQ(empty.rows(), 0);
  EXPECT_EQ(empty.nnz(), 0);
  EXPECT_EQ(empty.colind(), std::vector<int>{0});
  EXPECT_EQ(Sparsity(0, 0, {0}, {}), empty);
  EXPECT_EQ(Sparsity(4, 0, {0}, {}).rows(), 4);
}

TEST(SparsityConstruction, InconsistentArraysAreRejectedWithTheIndex) {
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(-1, 2, {0, 0, 0}, {});
      },
      {"expected nonnegative sizes, got -1x2"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(2, 2, {0, 0}, {});
      },
      {"expected colind of size ncol+1 = 3, got 2"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(2, 1, {1, 1}, {0});
      },
      {"expected colind[0] = 0", "got 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(2, 1, {0, 2}, {0});
      },
      {"colind[ncol] = nnz = 1", "got 0 and 2"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 2, {0, 2, 1}, {0});
      },
      {"expected nondecreasing colind", "colind[2] < colind[1]"});
  // colind overshoots nnz before coming back down: must be rejected before any row is read
  // (the sanitizer build catches an out-of-bounds read here).
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 2, {0, 5, 2}, {0, 1});
      },
      {"expected nondecreasing colind"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 3, {0, 1, 9, 2}, {0, 1});
      },
      {"expected nondecreasing colind"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 2, {0, 1, 2}, {0, 3});
      },
      {"expected row in [0, 3), got 3 at row[1]"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 2, {0, 1, 2}, {-1, 0});
      },
      {"got -1 at row[0]"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 1, {0, 2}, {1, 1});
      },
      {"expected strictly ascending rows within column 0", "row[1] = 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity(3, 2, {0, 1, 3}, {0, 2, 0});
      },
      {"within column 1", "row[2] = 0"});
}

TEST(SparsityConstruction, Dense) {
  const Sparsity d = Sparsity::Dense(2, 3);
  EXPECT_TRUE(d.IsDense());
  EXPECT_EQ(d.nnz(), 6);
  EXPECT_EQ(d.colind(), (std::vector<int>{0, 2, 4, 6}));
  EXPECT_EQ(d.row(), (std::vector<int>{0, 1, 0, 1, 0, 1}));
  EXPECT_EQ(Sparsity::Dense(5, 1).nnz(), 5);
  EXPECT_EQ(Sparsity::Dense(0, 3).nnz(), 0);
  EXPECT_TRUE(Sparsity::Dense(0, 0).IsDense());
  ExpectThrowsWith<std::invalid_argument>([] { Sparsity::Dense(-1, 2); },
                                          {"expected nonnegative sizes, got -1x2"});
  ExpectThrowsWith<std::invalid_argument>([] { Sparsity::Dense(2, -3); },
                                          {"expected nonnegative sizes, got 2x-3"});
}

TEST(SparsityConstruction, FromTripletsSortsAndMerges) {
  const Sparsity sp = Sparsity::FromTriplets(3, 3, {{2, 0}, {0, 2}, {0, 0}, {1, 2}, {0, 2}});
  EXPECT_EQ(sp, Sparsity(3, 3, {0, 2, 2, 4}, {0, 2, 0, 1}));
  EXPECT_EQ(Sparsity::FromTriplets(2, 4, {}), Sparsity(2, 4, {0, 0, 0, 0, 0}, {}));
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity::FromTriplets(3, 2, {{0, 0}, {1, 1}, {5, 0}});
      },
      {"entry 2 = (5, 0) outside a 3x2 matrix"});
  ExpectThrowsWith<std::invalid_argument>(
      [] {
        Sparsity::FromTriplets(3, 2, {{0, -1}});
      },
      {"entry 0 = (0, -1)"});
  ExpectThrowsWith<std::invalid_argument>([] { Sparsity::FromTriplets(-2, -5, {}); },
                                          {"expected nonnegative sizes, got -2x-5"});
}

// A random pattern and the set of its entries.
Sparsity RandomPattern(std::mt19937* rng, std::set<std::pair<int, int>>* entries) {
  const int rows = std::uniform_int_distribution<int>(1, 12)(*rng);
  const int cols = std::uniform_int_distribution<int>(1, 12)(*rng);
  std::vector<std::pair<int, int>> rc;
  for (int i = 0; i < rows; ++i) {
    for (int j = 0; j < cols; ++j) {
      if (std::uniform_real_distribution<double>(0, 1)(*rng) < 0.3) {
        rc.push_back({i, j});
        entries->insert({i, j});
      }
    }
  }
  std::shuffle(rc.begin(), rc.end(), *rng);
  return Sparsity::FromTriplets(rows, cols, rc);
}

TEST(SparsityQueries, FindHasTransposeOnRandomPatterns) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (int t = 0; t < 50; ++t) {
    std::set<std::pair<int, int>> entries;
    const Sparsity sp = RandomPattern(&rng, &entries);
    EXPECT_EQ(sp.nnz(), static_cast<int>(entries.size()));
    const std::vector<int> col = sp.ColumnOfNonzeros();
    for (int k = 0; k < sp.nnz(); ++k) EXPECT_EQ(sp.Find(sp.row()[k], col[k]), k);
    const Sparsity tr = sp.Transpose();
    EXPECT_EQ(tr.rows(), sp.cols());
    EXPECT_EQ(tr.cols(), sp.rows());
    EXPECT_EQ(tr.nnz(), sp.nnz());
    for (int i = 0; i < sp.rows(); ++i) {
      for (int j = 0; j < sp.cols(); ++j) {
        const bool in = entries.count({i, j}) > 0;
        EXPECT_EQ(sp.Has(i, j), in);
        EXPECT_EQ(sp.Find(i, j) >= 0, in);
        EXPECT_EQ(tr.Has(j, i), in);
      }
    }
    EXPECT_EQ(tr.Transpose(), sp);
  }
}

TEST(SparsityQueries, FindOutsideTheMatrixIsMinusOne) {
  const Sparsity sp = Sparsity::Dense(2, 2);
  EXPECT_EQ(sp.Find(1, 1), 3);
  EXPECT_EQ(sp.Find(-1, 0), -1);
  EXPECT_EQ(sp.Find(2, 0), -1);
  EXPECT_EQ(sp.Find(0, -1), -1);
  EXPECT_EQ(sp.Find(0, 2), -1);
  EXPECT_FALSE(sp.Has(5, 5));
}

TEST(SparsityQueries, LowerTriangle) {
  const Sparsity full = Sparsity::Dense(3, 3);
  const Sparsity lower = full.LowerTriangle();
  EXPECT_EQ(lower, Sparsity::FromTriplets(3, 3, {{0, 0}, {1, 0}, {2, 0}, {1, 1}, {2, 1}, {2, 2}}));
  EXPECT_EQ(lower.ToString(), "*..\n**.\n***\n");
  // Entries above the diagonal vanish, a rectangular pattern keeps its shape.
  const Sparsity upper = Sparsity::FromTriplets(2, 4, {{0, 1}, {0, 3}, {1, 2}});
  EXPECT_EQ(upper.LowerTriangle().nnz(), 0);
  EXPECT_EQ(upper.LowerTriangle().cols(), 4);
  const Sparsity rect = Sparsity::FromTriplets(4, 2, {{0, 0}, {0, 1}, {3, 1}, {1, 1}});
  EXPECT_EQ(rect.LowerTriangle(), Sparsity::FromTriplets(4, 2, {{0, 0}, {3, 1}, {1, 1}}));
  EXPECT_NE(rect, rect.LowerTriangle());
}

}  // namespace
}  // namespace graybox::expr
