// expr_hello: the first rung of the ladder.
//
// The chained Rosenbrock function  f(x) = sum_{i<n-1} 100 (x_{i+1} - x_i^2)^2 + (1 - x_i)^2,
// built as an expression graph, evaluated on the tape, differentiated by reverse mode (gradient)
// and forward-over-reverse with graph colouring (sparse Hessian, tridiagonal), and checked
// against central finite differences.
#include <iostream>

#include "graybox/expr.h"

using namespace graybox::expr;

int main() {
  constexpr int kN = 6;
  const std::vector<Expr> x = Expr::Symbols("x", kN);
  Expr f = 0.0;
  for (int i = 0; i + 1 < kN; ++i) f += 100.0 * square(x[i + 1] - x[i] * x[i]) + square(1.0 - x[i]);
  const Function rosen("rosenbrock", {{"x", x}}, {{"f", {f}}});

  Eigen::VectorXd x0(kN);
  x0 << -1.2, 1.0, -1.2, 1.0, -1.2, 1.0;
  std::cout << "f(x0)           = " << rosen({x0})[0][0] << "\n";

  const Function grad = rosen.Gradient("f", "x");
  std::cout << "grad f(x0)      = " << grad({x0})[0].transpose() << "\n";

  const Function hess = rosen.Hessian("f", "x");
  std::cout << "Hessian sparsity (" << hess.OutputSparsity(0).nnz() << " nonzeros):\n"
            << hess.OutputSparsity(0).ToString();
  const Function lag = HessianOfLagrangian(rosen, "x", "f", "");
  std::cout << "Ipopt lower triangle: " << lag.OutputSparsity(0).nnz() << " nonzeros\n";
  std::cout << "tape: " << rosen.NumInstructions() << " instructions, " << rosen.NumRegisters()
            << " registers; Hessian tape: " << hess.NumInstructions() << " instructions\n";

  const DerivativeCheckResult check = CheckHessian(rosen, "f", "x", {x0});
  std::cout << check.BriefReport() << "\n";
  return check.ok ? 0 : 1;
}
