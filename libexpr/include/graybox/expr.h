// graybox libexpr: symbolic expressions, Functions with compiled tapes, automatic differentiation
// (forward, reverse, sparse Jacobians and Hessians), derivative checks and C code generation.
#pragma once

#include "graybox/expr/codegen.h"
#include "graybox/expr/derivative_check.h"
#include "graybox/expr/derivatives.h"
#include "graybox/expr/expr.h"
#include "graybox/expr/function.h"
#include "graybox/expr/matrix.h"
#include "graybox/expr/ops.h"
#include "graybox/expr/sparsity.h"
