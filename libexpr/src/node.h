// Private: the node layout and graph traversal helpers.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "graybox/expr/expr.h"

namespace graybox::expr::internal {

struct Node : std::enable_shared_from_this<Node> {
  Node() = default;
  Node(Node&&) = default;
  Node& operator=(Node&&) = default;
  Op op = Op::kConstant;
  bool depends_on_symbols = false;
  double value = 0.0;  // constants only
  std::uint64_t id = 0;
  std::array<std::shared_ptr<const Node>, 3> args;
  std::string name;  // symbols only

  ~Node();
};

/// Topological order (arguments before users) of all nodes reachable from `roots`.
/// Iterative, so arbitrarily deep graphs do not overflow the stack.
std::vector<const Node*> TopologicalOrder(const std::vector<const Node*>& roots);

std::vector<const Node*> Roots(const std::vector<Expr>& exprs);

/// Builds an Expr handle that shares ownership of an existing node.
Expr Share(const Node* node);

/// The symbolic local partials of node `n` with respect to each of its arguments.
/// `d[i]` is left untouched for arguments that do not depend on symbols.
void LocalPartials(const Expr& n, Expr* d);

}  // namespace graybox::expr::internal
