// Symbolic differentiation of expression lists, and the Hessian of a Lagrangian for Ipopt.
//
// All routines return expressions built from the op table's local partials (ops.h), so forward,
// reverse, Jacobian and Hessian results agree to rounding. Shared subexpressions stay shared.
// `inputs` are always symbols (std::invalid_argument otherwise).
#pragma once

#include <string>
#include <vector>

#include "graybox/expr/expr.h"
#include "graybox/expr/function.h"
#include "graybox/expr/sparsity.h"

namespace graybox::expr {

/// Forward mode: for each direction d, returns J * seeds[d] (J = d outputs / d inputs).
/// seeds[d] has inputs.size() entries.
std::vector<std::vector<Expr>> ForwardDerivative(const std::vector<Expr>& outputs,
                                                 const std::vector<Expr>& inputs,
                                                 const std::vector<std::vector<Expr>>& seeds);

/// Reverse mode: for each direction d, returns J^T * seeds[d]; seeds[d] has outputs.size()
/// entries.
std::vector<std::vector<Expr>> ReverseDerivative(const std::vector<Expr>& outputs,
                                                 const std::vector<Expr>& inputs,
                                                 const std::vector<std::vector<Expr>>& seeds);

/// Structural sparsity of d outputs / d inputs (outputs.size() x inputs.size()), found by
/// propagating dependency bit sets through the graph in blocks of input columns.
Sparsity JacobianSparsity(const std::vector<Expr>& outputs, const std::vector<Expr>& inputs);

/// The structural nonzeros of d outputs / d inputs in CCS order of *pattern (set on return).
/// Uses graph colouring: one forward sweep per column colour or one reverse sweep per row
/// colour, whichever needs fewer.
std::vector<Expr> SparseJacobian(const std::vector<Expr>& outputs, const std::vector<Expr>& inputs,
                                 Sparsity* pattern);

/// The structural nonzeros (CCS order of *pattern, set on return; the pattern is symmetrised) of
/// the Hessian of a scalar function given its gradient `gradient` (from Gradient()). Uses a star
/// colouring (StarColorSymmetric) with direct recovery, or column colouring when that needs no
/// more colours; one forward-over-reverse sweep per colour.
std::vector<Expr> SparseHessian(const std::vector<Expr>& gradient, const std::vector<Expr>& inputs,
                                Sparsity* pattern);

/// Gradient of a scalar expression (one reverse sweep).
std::vector<Expr> Gradient(const Expr& f, const std::vector<Expr>& inputs);

/// Hessian of the Lagrangian  sigma * f(x, p) + lambda^T g(x, p)  with respect to the input `wrt`
/// of `fn`, as Ipopt wants it: the lower triangle (row >= col) in CCS order.
///   `objective`:   name of a one-entry output of fn (f).
///   `constraints`: name of an output of fn (g), or "" when there are none.
/// Returns a Function whose inputs are fn's inputs followed by "sigma" (1 entry) and "lambda"
/// (size of g), and whose single output "hess_lagrangian" has the lower-triangular pattern.
Function HessianOfLagrangian(const Function& fn, const std::string& wrt,
                             const std::string& objective, const std::string& constraints);

}  // namespace graybox::expr
