#include "graybox/expr/derivatives.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <unordered_map>

#include "node.h"

namespace graybox::expr {

using internal::Node;

namespace {

void CheckSymbols(const std::vector<Expr>& inputs, const char* who) {
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!inputs[i].IsSymbol()) {
      throw std::invalid_argument(std::string(who) + ": expected input " + std::to_string(i) +
                                  " to be a symbol, got " + inputs[i].ToString());
    }
  }
}

// The graph below `outputs`, restricted to nodes that depend on symbols, with local partials
// computed once and shared by every sweep direction.
struct Linearization {
  std::vector<const Node*> order;  // topological, symbol-dependent nodes only
  std::unordered_map<const Node*, int> index;
  std::vector<std::array<Expr, 3>> partials;
  std::vector<Expr> handles;  // keeps nodes alive and gives Expr access

  Linearization(const std::vector<Expr>& outputs) {
    for (const Node* n : internal::TopologicalOrder(internal::Roots(outputs))) {
      if (!n->depends_on_symbols) continue;
      index[n] = static_cast<int>(order.size());
      order.push_back(n);
    }
    partials.resize(order.size());
    handles.reserve(order.size());
    for (std::size_t k = 0; k < order.size(); ++k) {
      handles.push_back(internal::Share(order[k]));
      internal::LocalPartials(handles[k], partials[k].data());
    }
  }
  int Find(const Node* n) const {
    auto it = index.find(n);
    return it == index.end() ? -1 : it->second;
  }
};

}  // namespace

std::vector<std::vector<Expr>> ForwardDerivative(const std::vector<Expr>& outputs,
                                                 const std::vector<Expr>& inputs,
                                                 const std::vector<std::vector<Expr>>& seeds) {
  CheckSymbols(inputs, "ForwardDerivative");
  const Linearization lin(outputs);
  std::vector<std::vector<Expr>> result;
  result.reserve(seeds.size());
  std::vector<Expr> tangent(lin.order.size());
  for (std::size_t d = 0; d < seeds.size(); ++d) {
    if (seeds[d].size() != inputs.size()) {
      throw std::invalid_argument("ForwardDerivative: expected seed " + std::to_string(d) +
                                  " of size " + std::to_string(inputs.size()) + ", got " +
                                  std::to_string(seeds[d].size()));
    }
    std::fill(tangent.begin(), tangent.end(), Expr(0.0));
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const int k = lin.Find(inputs[i].node());
      if (k >= 0) tangent[k] = tangent[k] + seeds[d][i];
    }
    for (std::size_t k = 0; k < lin.order.size(); ++k) {
      const Node* n = lin.order[k];
      if (n->op == Op::kSymbol) continue;
      Expr t(0.0);
      for (int a = 0; a < Arity(n->op); ++a) {
        const int ka = lin.Find(n->args[a].get());
        if (ka < 0 || tangent[ka].IsZero()) continue;
        const Expr& p = lin.partials[k][a];
        t = p.IsOne() ? t + tangent[ka]
                      : (p.IsConstant(-1.0) ? t - tangent[ka] : t + p * tangent[ka]);
      }
      tangent[k] = t;
    }
    std::vector<Expr> out;
    out.reserve(outputs.size());
    for (const Expr& o : outputs) {
      const int k = lin.Find(o.node());
      out.push_back(k < 0 ? Expr(0.0) : tangent[k]);
    }
    result.push_back(std::move(out));
  }
  return result;
}

std::vector<std::vector<Expr>> ReverseDerivative(const std::vector<Expr>& outputs,
                                                 const std::vector<Expr>& inputs,
                                                 const std::vector<std::vector<Expr>>& seeds) {
  CheckSymbols(inputs, "ReverseDerivative");
  const Linearization lin(outputs);
  std::vector<std::vector<Expr>> result;
  result.reserve(seeds.size());
  std::vector<Expr> adjoint(lin.order.size());
  for (std::size_t d = 0; d < seeds.size(); ++d) {
    if (seeds[d].size() != outputs.size()) {
      throw std::invalid_argument("ReverseDerivative: expected seed " + std::to_string(d) +
                                  " of size " + std::to_string(outputs.size()) + ", got " +
                                  std::to_string(seeds[d].size()));
    }
    std::fill(adjoint.begin(), adjoint.end(), Expr(0.0));
    for (std::size_t j = 0; j < outputs.size(); ++j) {
      const int k = lin.Find(outputs[j].node());
      if (k >= 0) adjoint[k] = adjoint[k] + seeds[d][j];
    }
    for (std::size_t k = lin.order.size(); k-- > 0;) {
      const Node* n = lin.order[k];
      if (n->op == Op::kSymbol || adjoint[k].IsZero()) continue;
      for (int a = 0; a < Arity(n->op); ++a) {
        const int ka = lin.Find(n->args[a].get());
        if (ka < 0) continue;
        const Expr& p = lin.partials[k][a];
        adjoint[ka] = p.IsOne() ? adjoint[ka] + adjoint[k]
                                : (p.IsConstant(-1.0) ? adjoint[ka] - adjoint[k]
                                                      : adjoint[ka] + p * adjoint[k]);
      }
    }
    std::vector<Expr> out;
    out.reserve(inputs.size());
    for (const Expr& in : inputs) {
      const int k = lin.Find(in.node());
      out.push_back(k < 0 ? Expr(0.0) : adjoint[k]);
    }
    result.push_back(std::move(out));
  }
  return result;
}

Sparsity JacobianSparsity(const std::vector<Expr>& outputs, const std::vector<Expr>& inputs) {
  CheckSymbols(inputs, "JacobianSparsity");
  const int nin = static_cast<int>(inputs.size());
  const int nout = static_cast<int>(outputs.size());
  std::vector<const Node*> order;
  std::unordered_map<const Node*, int> index;
  for (const Node* n : internal::TopologicalOrder(internal::Roots(outputs))) {
    if (!n->depends_on_symbols) continue;
    index[n] = static_cast<int>(order.size());
    order.push_back(n);
  }
  std::vector<std::pair<int, int>> entries;
  constexpr int kWords = 4;  // 256 input columns per block
  constexpr int kBlock = 64 * kWords;
  std::vector<std::uint64_t> bits;
  for (int begin = 0; begin < nin; begin += kBlock) {
    const int end = std::min(nin, begin + kBlock);
    bits.assign(order.size() * kWords, 0);
    for (int i = begin; i < end; ++i) {
      auto it = index.find(inputs[i].node());
      if (it == index.end()) continue;
      const int c = i - begin;
      bits[it->second * kWords + c / 64] |= std::uint64_t{1} << (c % 64);
    }
    for (std::size_t k = 0; k < order.size(); ++k) {
      const Node* n = order[k];
      const int arity = Arity(n->op);
      // Comparisons, sign, logic: zero derivative, so no dependency propagates. if_else
      // propagates from its branches only.
      switch (n->op) {
        case Op::kSymbol:
        case Op::kLt:
        case Op::kLe:
        case Op::kEq:
        case Op::kNe:
        case Op::kAnd:
        case Op::kOr:
        case Op::kNot:
        case Op::kSign:
          continue;
        default:
          break;
      }
      for (int a = (n->op == Op::kIfElse ? 1 : 0); a < arity; ++a) {
        auto it = index.find(n->args[a].get());
        if (it == index.end()) continue;
        for (int w = 0; w < kWords; ++w) bits[k * kWords + w] |= bits[it->second * kWords + w];
      }
    }
    for (int j = 0; j < nout; ++j) {
      auto it = index.find(outputs[j].node());
      if (it == index.end()) continue;
      for (int c = 0; c < end - begin; ++c) {
        if (bits[it->second * kWords + c / 64] >> (c % 64) & 1) entries.push_back({j, begin + c});
      }
    }
  }
  return Sparsity::FromTriplets(nout, nin, entries);
}

std::vector<Expr> SparseJacobian(const std::vector<Expr>& outputs, const std::vector<Expr>& inputs,
                                 Sparsity* pattern) {
  const Sparsity sp = JacobianSparsity(outputs, inputs);
  int ncol_colors = 0, nrow_colors = 0;
  const std::vector<int> col_color = ColorColumns(sp, &ncol_colors);
  const Sparsity spt = sp.Transpose();
  const std::vector<int> row_color = ColorColumns(spt, &nrow_colors);
  std::vector<Expr> nz(sp.nnz());
  const std::vector<int> nz_col = sp.ColumnOfNonzeros();
  if (ncol_colors <= nrow_colors) {
    std::vector<std::vector<Expr>> seeds(ncol_colors, std::vector<Expr>(inputs.size(), Expr(0.0)));
    for (std::size_t j = 0; j < inputs.size(); ++j) seeds[col_color[j]][j] = Expr(1.0);
    const auto dirs = ForwardDerivative(outputs, inputs, seeds);
    for (int k = 0; k < sp.nnz(); ++k) nz[k] = dirs[col_color[nz_col[k]]][sp.row()[k]];
  } else {
    std::vector<std::vector<Expr>> seeds(nrow_colors, std::vector<Expr>(outputs.size(), Expr(0.0)));
    for (std::size_t i = 0; i < outputs.size(); ++i) seeds[row_color[i]][i] = Expr(1.0);
    const auto dirs = ReverseDerivative(outputs, inputs, seeds);
    for (int k = 0; k < sp.nnz(); ++k) nz[k] = dirs[row_color[sp.row()[k]]][nz_col[k]];
  }
  if (pattern) *pattern = sp;
  return nz;
}

std::vector<Expr> SparseHessian(const std::vector<Expr>& gradient, const std::vector<Expr>& inputs,
                                Sparsity* pattern) {
  const int n = static_cast<int>(inputs.size());
  if (gradient.size() != inputs.size()) {
    throw std::invalid_argument("SparseHessian: expected a gradient of size " + std::to_string(n) +
                                ", got " + std::to_string(gradient.size()));
  }
  const Sparsity detected = JacobianSparsity(gradient, inputs);
  std::vector<std::pair<int, int>> entries;
  const std::vector<int> detected_col = detected.ColumnOfNonzeros();
  for (int k = 0; k < detected.nnz(); ++k) {
    entries.push_back({detected.row()[k], detected_col[k]});
    entries.push_back({detected_col[k], detected.row()[k]});
  }
  const Sparsity sp = Sparsity::FromTriplets(n, n, entries);
  int num_star = 0, num_columns = 0;
  const std::vector<int> star = StarColorSymmetric(sp, &num_star);
  ColorColumns(sp, &num_columns);
  if (num_columns <= num_star) {
    Sparsity jac_pattern;
    std::vector<Expr> nz = SparseJacobian(gradient, inputs, &jac_pattern);
    if (jac_pattern == sp) {
      if (pattern) *pattern = sp;
      return nz;
    }
    // The detected pattern was not symmetric: fall through to the symmetric recovery.
  }
  std::vector<std::vector<Expr>> seeds(num_star, std::vector<Expr>(n, Expr(0.0)));
  for (int j = 0; j < n; ++j) seeds[star[j]][j] = Expr(1.0);
  const auto dirs = ForwardDerivative(gradient, inputs, seeds);
  // hits[(row, colour)]: how many columns of that colour have a nonzero in that row.
  std::unordered_map<std::int64_t, int> hits;
  const std::vector<int> col = sp.ColumnOfNonzeros();
  auto key = [&](int row, int colour) { return std::int64_t{row} * num_star + colour; };
  for (int k = 0; k < sp.nnz(); ++k) ++hits[key(sp.row()[k], star[col[k]])];
  std::vector<Expr> nz(sp.nnz());
  for (int k = 0; k < sp.nnz(); ++k) {
    const int i = sp.row()[k], j = col[k];
    if (hits[key(i, star[j])] == 1) {
      nz[k] = dirs[star[j]][i];
    } else if (hits[key(j, star[i])] == 1) {
      nz[k] = dirs[star[i]][j];
    } else {
      throw std::logic_error("SparseHessian: star colouring does not determine entry (" +
                             std::to_string(i) + ", " + std::to_string(j) + ")");
    }
  }
  if (pattern) *pattern = sp;
  return nz;
}

std::vector<Expr> Gradient(const Expr& f, const std::vector<Expr>& inputs) {
  return ReverseDerivative({f}, inputs, {{Expr(1.0)}})[0];
}

Function HessianOfLagrangian(const Function& fn, const std::string& wrt,
                             const std::string& objective, const std::string& constraints) {
  const int iobj = fn.OutputIndex(objective);
  if (fn.OutputSize(iobj) != 1) {
    throw std::invalid_argument("HessianOfLagrangian: expected objective '" + objective +
                                "' with 1 entry, got " + std::to_string(fn.OutputSize(iobj)));
  }
  const std::vector<Expr>& x = fn.InputSymbols(fn.InputIndex(wrt));
  const Expr sigma = Expr::Symbol("sigma");
  Expr lagrangian = sigma * fn.OutputExprs(iobj)[0];
  std::vector<Expr> lambda;
  if (!constraints.empty()) {
    const std::vector<Expr>& g = fn.OutputExprs(fn.OutputIndex(constraints));
    lambda = Expr::Symbols("lambda", static_cast<int>(g.size()));
    for (std::size_t i = 0; i < g.size(); ++i) lagrangian = lagrangian + lambda[i] * g[i];
  }
  const std::vector<Expr> grad = Gradient(lagrangian, x);
  Sparsity full;
  const std::vector<Expr> nz = SparseHessian(grad, x, &full);
  const Sparsity lower = full.LowerTriangle();
  std::vector<Expr> lower_nz;
  lower_nz.reserve(lower.nnz());
  const std::vector<int> col = lower.ColumnOfNonzeros();
  for (int k = 0; k < lower.nnz(); ++k) lower_nz.push_back(nz[full.Find(lower.row()[k], col[k])]);
  std::vector<FunctionIo> ins;
  for (int i = 0; i < fn.NumInputs(); ++i) ins.emplace_back(fn.InputName(i), fn.InputSymbols(i));
  ins.emplace_back("sigma", std::vector<Expr>{sigma});
  ins.emplace_back("lambda", lambda);
  return Function(fn.name() + "_hess_lagrangian", std::move(ins),
                  {FunctionIo("hess_lagrangian", std::move(lower_nz), lower)});
}

}  // namespace graybox::expr
