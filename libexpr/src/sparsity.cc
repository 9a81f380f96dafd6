#include "graybox/expr/sparsity.h"

#include <algorithm>
#include <stdexcept>

namespace graybox::expr {

namespace {
std::string Where(const char* what, int index) {
  return std::string(what) + "[" + std::to_string(index) + "]";
}
}  // namespace

Sparsity::Sparsity(int nrow, int ncol, std::vector<int> colind, std::vector<int> row)
    : nrow_(nrow), ncol_(ncol), colind_(std::move(colind)), row_(std::move(row)) {
  if (nrow < 0 || ncol < 0) {
    throw std::invalid_argument("Sparsity: expected nonnegative sizes, got " +
                                std::to_string(nrow) + "x" + std::to_string(ncol));
  }
  if (static_cast<int>(colind_.size()) != ncol + 1) {
    throw std::invalid_argument(
        "Sparsity: expected colind of size ncol+1 = " + std::to_string(ncol + 1) + ", got " +
        std::to_string(colind_.size()));
  }
  if (colind_[0] != 0 || colind_[ncol] != static_cast<int>(row_.size())) {
    throw std::invalid_argument(
        "Sparsity: expected colind[0] = 0 and colind[ncol] = nnz = " + std::to_string(row_.size()) +
        ", got " + std::to_string(colind_[0]) + " and " + std::to_string(colind_[ncol]));
  }
  // All of colind first: with colind[0] = 0 and colind[ncol] = nnz, a nondecreasing colind keeps
  // every column's range inside row, so the row checks below cannot read out of bounds.
  for (int j = 0; j < ncol; ++j) {
    if (colind_[j + 1] < colind_[j]) {
      throw std::invalid_argument("Sparsity: expected nondecreasing colind, got " +
                                  Where("colind", j + 1) + " < " + Where("colind", j));
    }
  }
  for (int j = 0; j < ncol; ++j) {
    for (int k = colind_[j]; k < colind_[j + 1]; ++k) {
      if (row_[k] < 0 || row_[k] >= nrow) {
        throw std::invalid_argument("Sparsity: expected row in [0, " + std::to_string(nrow) +
                                    "), got " + std::to_string(row_[k]) + " at " + Where("row", k));
      }
      if (k > colind_[j] && row_[k] <= row_[k - 1]) {
        throw std::invalid_argument("Sparsity: expected strictly ascending rows within column " +
                                    std::to_string(j) + ", got " + Where("row", k) + " = " +
                                    std::to_string(row_[k]));
      }
    }
  }
}

namespace {
void CheckSizes(const char* who, int nrow, int ncol) {
  if (nrow < 0 || ncol < 0) {
    throw std::invalid_argument(std::string(who) + ": expected nonnegative sizes, got " +
                                std::to_string(nrow) + "x" + std::to_string(ncol));
  }
}
}  // namespace

Sparsity Sparsity::Dense(int nrow, int ncol) {
  CheckSizes("Sparsity::Dense", nrow, ncol);
  std::vector<int> colind(ncol + 1), row;
  row.reserve(static_cast<std::size_t>(nrow) * ncol);
  for (int j = 0; j < ncol; ++j) {
    colind[j] = j * nrow;
    for (int i = 0; i < nrow; ++i) row.push_back(i);
  }
  colind[ncol] = nrow * ncol;
  return Sparsity(nrow, ncol, std::move(colind), std::move(row));
}

Sparsity Sparsity::FromTriplets(int nrow, int ncol, const std::vector<std::pair<int, int>>& rc) {
  CheckSizes("Sparsity::FromTriplets", nrow, ncol);
  std::vector<std::pair<int, int>> cr;
  cr.reserve(rc.size());
  for (std::size_t k = 0; k < rc.size(); ++k) {
    const auto [i, j] = rc[k];
    if (i < 0 || i >= nrow || j < 0 || j >= ncol) {
      throw std::invalid_argument("Sparsity::FromTriplets: entry " + std::to_string(k) + " = (" +
                                  std::to_string(i) + ", " + std::to_string(j) + ") outside a " +
                                  std::to_string(nrow) + "x" + std::to_string(ncol) + " matrix");
    }
    cr.push_back({j, i});
  }
  std::sort(cr.begin(), cr.end());
  cr.erase(std::unique(cr.begin(), cr.end()), cr.end());
  std::vector<int> colind(ncol + 1, 0), row;
  row.reserve(cr.size());
  for (const auto& [j, i] : cr) {
    ++colind[j + 1];
    row.push_back(i);
  }
  for (int j = 0; j < ncol; ++j) colind[j + 1] += colind[j];
  return Sparsity(nrow, ncol, std::move(colind), std::move(row));
}

std::vector<int> Sparsity::ColumnOfNonzeros() const {
  std::vector<int> col(row_.size());
  for (int j = 0; j < ncol_; ++j) {
    for (int k = colind_[j]; k < colind_[j + 1]; ++k) col[k] = j;
  }
  return col;
}

int Sparsity::Find(int i, int j) const {
  if (j < 0 || j >= ncol_) return -1;
  const auto begin = row_.begin() + colind_[j];
  const auto end = row_.begin() + colind_[j + 1];
  const auto it = std::lower_bound(begin, end, i);
  return (it != end && *it == i) ? static_cast<int>(it - row_.begin()) : -1;
}

bool Sparsity::Has(int i, int j) const { return Find(i, j) >= 0; }

Sparsity Sparsity::Transpose() const {
  std::vector<std::pair<int, int>> rc;
  rc.reserve(row_.size());
  const auto col = ColumnOfNonzeros();
  for (std::size_t k = 0; k < row_.size(); ++k) rc.push_back({col[k], row_[k]});
  return FromTriplets(ncol_, nrow_, rc);
}

Sparsity Sparsity::LowerTriangle() const {
  std::vector<std::pair<int, int>> rc;
  const auto col = ColumnOfNonzeros();
  for (std::size_t k = 0; k < row_.size(); ++k) {
    if (row_[k] >= col[k]) rc.push_back({row_[k], col[k]});
  }
  return FromTriplets(nrow_, ncol_, rc);
}

std::string Sparsity::ToString() const {
  std::string s;
  for (int i = 0; i < nrow_; ++i) {
    for (int j = 0; j < ncol_; ++j) s += Has(i, j) ? '*' : '.';
    s += '\n';
  }
  return s;
}

std::vector<int> ColorColumns(const Sparsity& pattern, int* num_colors) {
  const int ncol = pattern.cols();
  std::vector<int> order(ncol);
  for (int j = 0; j < ncol; ++j) order[j] = j;
  const auto& colind = pattern.colind();
  const auto& row = pattern.row();
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return colind[a + 1] - colind[a] > colind[b + 1] - colind[b];
  });
  // Rows of each colour seen so far: row_color_stamp[r] == c+1 marks row r as used by colour c
  // during the test of one column; colour_rows keeps, per colour, a bitmap of its rows.
  std::vector<std::vector<char>> color_rows;
  std::vector<int> color(ncol, -1);
  for (int j : order) {
    int chosen = -1;
    for (int c = 0; c < static_cast<int>(color_rows.size()) && chosen < 0; ++c) {
      bool clash = false;
      for (int k = colind[j]; k < colind[j + 1] && !clash; ++k) clash = color_rows[c][row[k]];
      if (!clash) chosen = c;
    }
    if (chosen < 0) {
      chosen = static_cast<int>(color_rows.size());
      color_rows.emplace_back(pattern.rows(), 0);
    }
    for (int k = colind[j]; k < colind[j + 1]; ++k) color_rows[chosen][row[k]] = 1;
    color[j] = chosen;
  }
  if (num_colors) *num_colors = static_cast<int>(color_rows.size());
  return color;
}

std::vector<int> StarColorSymmetric(const Sparsity& pattern, int* num_colors) {
  if (pattern.rows() != pattern.cols()) {
    throw std::invalid_argument("StarColorSymmetric: expected a square pattern, got " +
                                std::to_string(pattern.rows()) + "x" +
                                std::to_string(pattern.cols()));
  }
  const int n = pattern.cols();
  // Adjacency lists without the diagonal, symmetrised.
  std::vector<std::vector<int>> adj(n);
  const std::vector<int> col = pattern.ColumnOfNonzeros();
  for (int k = 0; k < pattern.nnz(); ++k) {
    const int i = pattern.row()[k], j = col[k];
    if (i == j) continue;
    adj[i].push_back(j);
    adj[j].push_back(i);
  }
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
  }
  std::vector<int> order(n);
  for (int v = 0; v < n; ++v) order[v] = v;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return adj[a].size() > adj[b].size(); });
  std::vector<int> color(n, -1);
  std::vector<int> forbidden;  // forbidden[c] == v marks colour c as unusable for vertex v
  int ncolors = 0;
  for (int v : order) {
    for (int w : adj[v]) {
      if (color[w] >= 0) forbidden[color[w]] = v;
    }
    for (int w : adj[v]) {
      for (int x : adj[w]) {
        if (x == v || color[x] < 0) continue;
        if (color[w] < 0) {
          forbidden[color[x]] = v;  // v-w-x with w still uncoloured: keep v and x apart
        } else {
          for (int y : adj[x]) {
            if (y != w && color[y] >= 0 && color[y] == color[w]) {
              forbidden[color[x]] = v;  // v-w-x-y would be two-coloured
              break;
            }
          }
        }
      }
    }
    int c = 0;
    while (c < ncolors && forbidden[c] == v) ++c;
    if (c == ncolors) {
      ++ncolors;
      forbidden.push_back(-1);
    }
    color[v] = c;
  }
  if (num_colors) *num_colors = ncolors;
  return color;
}

}  // namespace graybox::expr
