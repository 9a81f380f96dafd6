#include "graybox/expr/ops.h"

#include <stdexcept>

#include "node.h"
#include "op_defs.h"

namespace graybox::expr {

int Arity(Op op) {
  switch (op) {
#define GRAYBOX_EXPR_CASE(e, n, s) \
  case Op::e:                      \
    return n;
    GRAYBOX_EXPR_OPS(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
  }
  return 0;
}

const char* OpName(Op op) {
  switch (op) {
#define GRAYBOX_EXPR_CASE(e, n, s) \
  case Op::e:                      \
    return s;
    GRAYBOX_EXPR_OPS(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
  }
  return "?";
}

bool IsCommutative(Op op) {
  switch (op) {
    case Op::kAdd:
    case Op::kMul:
    case Op::kEq:
    case Op::kNe:
    case Op::kAnd:
    case Op::kOr:
      return true;
    default:
      return false;
  }
}

double EvaluateOp(Op op, const double* a) {
  switch (op) {
    case Op::kConstant:
    case Op::kSymbol:
      throw std::logic_error("EvaluateOp: constants and symbols have no operation to evaluate");
#define GRAYBOX_EXPR_CASE(e, n, s) \
  case Op::e:                      \
    return internal::OpDef<Op::e>::F(a);
      GRAYBOX_EXPR_OPS_NO_LEAVES(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
  }
  return 0.0;
}

namespace internal {

void LocalPartials(const Expr& n, Expr* d) {
  Expr a[3];
  const int arity = n.NumArgs();
  for (int i = 0; i < arity; ++i) a[i] = n.Arg(i);
  switch (n.op()) {
    case Op::kConstant:
    case Op::kSymbol:
      return;
#define GRAYBOX_EXPR_CASE(e, k, s) \
  case Op::e:                      \
    OpDef<Op::e>::D(a, n, d);      \
    return;
      GRAYBOX_EXPR_OPS_NO_LEAVES(GRAYBOX_EXPR_CASE)
#undef GRAYBOX_EXPR_CASE
  }
}

}  // namespace internal
}  // namespace graybox::expr
