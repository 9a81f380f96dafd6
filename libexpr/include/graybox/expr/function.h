// Function: a named map from vector inputs to vector outputs, built from expressions and
// evaluated on doubles by a compiled instruction tape.
//
//   Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
//   Function f("f", {{"x", {x, y}}}, {{"r", {x * y, sin(x)}}});
//   Eigen::VectorXd r = f({Eigen::Vector2d(1.0, 2.0)})[0];
//
// Inputs are lists of distinct symbols; outputs are lists of expressions that may only depend on
// those symbols. Every output carries a Sparsity that gives its shape: a plain output of n entries
// is Dense(n, 1); a sparse Jacobian output holds exactly its structural nonzeros, in CCS order.
//
// Evaluation. At construction the graph is sorted, and compiled into a tape of instructions over a
// small set of work registers (registers are reused once their value is dead). Evaluate() runs the
// tape without allocating, in a Workspace the caller owns: one Workspace per thread makes
// concurrent evaluation of the same Function safe (the Function itself is immutable). Every
// output is checked for NaN/Inf and the first non-finite entry is reported in the returned
// EvalStatus; values are still written, so the caller decides what to do with them.
//
// Derivatives are new Functions (so they compose to any order): Forward (Jacobian times vectors),
// Reverse (vectors times Jacobian), Jacobian (sparse, compressed by graph colouring), Gradient,
// Hessian; HessianOfLagrangian in derivatives.h builds Ipopt's lower-triangular Hessian.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/expr.h"
#include "graybox/expr/sparsity.h"

namespace graybox::expr {

/// One named input or output of a Function.
struct FunctionIo {
  FunctionIo(std::string name, std::vector<Expr> exprs);
  /// `sparsity.nnz()` must equal exprs.size(); exprs are the nonzeros in CCS order.
  FunctionIo(std::string name, std::vector<Expr> exprs, Sparsity sparsity);
  std::string name;
  std::vector<Expr> exprs;
  Sparsity sparsity;
};

/// Result of a numerical evaluation. `ok` is false when an output entry is NaN or +-Inf;
/// `output`/`index` locate the first such entry.
struct EvalStatus {
  bool ok = true;
  int output = -1;
  int index = -1;
  double value = 0.0;
  /// e.g. "output 'r'[1] = nan".
  std::string message;
};

/// Thrown by the convenience operator() when an output is not finite.
class NonFiniteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Tape;

/// Per-thread scratch memory for Function::Evaluate. Create with Function::MakeWorkspace().
class Workspace {
 public:
  Workspace() = default;

 private:
  friend class Function;
  std::vector<double> registers_;
  std::vector<double> batch_registers_;
  const Tape* owner_ = nullptr;
};

class Function {
 public:
  /// An empty function (no inputs, no outputs).
  Function();
  /// Throws std::invalid_argument when: a name is empty or repeated; an input entry is not a
  /// symbol or a symbol appears twice; an output depends on a symbol that is not an input.
  Function(std::string name, std::vector<FunctionIo> inputs, std::vector<FunctionIo> outputs);

  const std::string& name() const;
  int NumInputs() const;
  int NumOutputs() const;
  const std::string& InputName(int i) const;
  const std::string& OutputName(int i) const;
  /// Index of an input by name; throws std::invalid_argument listing the valid names.
  int InputIndex(const std::string& name) const;
  int OutputIndex(const std::string& name) const;
  int InputSize(int i) const;
  /// Number of stored entries of output i (its sparsity's nnz).
  int OutputSize(int i) const;
  const std::vector<Expr>& InputSymbols(int i) const;
  const std::vector<Expr>& OutputExprs(int i) const;
  const Sparsity& OutputSparsity(int i) const;
  /// All input symbols, concatenated in input order.
  std::vector<Expr> AllInputSymbols() const;

  /// Number of tape instructions, registers and distinct graph nodes (for reports and tests).
  int NumInstructions() const;
  int NumRegisters() const;
  std::size_t NumNodes() const;

  // ---- numerical evaluation -----------------------------------------------------------------
  Workspace MakeWorkspace() const;
  /// Allocation-free. inputs[i] points to InputSize(i) doubles; outputs[i] to OutputSize(i)
  /// doubles, or is null to skip that output. `ws` must come from MakeWorkspace() of this
  /// Function (checked; std::invalid_argument otherwise).
  EvalStatus Evaluate(const double* const* inputs, double* const* outputs, Workspace* ws) const;
  /// Convenience: checks sizes (std::invalid_argument "expected X, got Y"), allocates the results,
  /// and throws NonFiniteError if an output is NaN/Inf.
  std::vector<Eigen::VectorXd> operator()(const std::vector<Eigen::VectorXd>& inputs) const;
  /// Batch evaluation over many points: inputs[i] is InputSize(i) x N (one column per point),
  /// outputs are resized to OutputSize(i) x N. Evaluates several points per instruction (SIMD
  /// lanes), which amortises the tape's dispatch. Allocation-free when `outputs` already have the
  /// right sizes and `ws` is reused.
  EvalStatus EvaluateBatch(const std::vector<Eigen::MatrixXd>& inputs,
                           std::vector<Eigen::MatrixXd>* outputs, Workspace* ws) const;

  // ---- symbolic use ---------------------------------------------------------------------------
  /// Inlines the function on symbolic arguments (sizes checked); returns the outputs.
  std::vector<std::vector<Expr>> Call(const std::vector<std::vector<Expr>>& args) const;

  // ---- derivatives (each a new Function) -----------------------------------------------------
  /// Inputs: the inputs of this function, then for each direction k and input i a seed
  /// "fwd<k>_<input>". Outputs: for each direction k and output j, "fwd<k>_<output>" = J_j * seed.
  Function Forward(int num_directions = 1) const;
  /// Inputs: the inputs, then for each direction k and output j a seed "adj<k>_<output>".
  /// Outputs: for each direction k and input i, "adj<k>_<input>" = sum_j seed_j^T J_ji.
  Function Reverse(int num_directions = 1) const;
  /// Inputs: the inputs. Output "jac_<out>_<in>": the sparse Jacobian d out / d in with the
  /// structural pattern JacobianSparsity(out, in), computed with the fewer of column-compressed
  /// forward or row-compressed reverse sweeps.
  Function Jacobian(const std::string& output, const std::string& input) const;
  /// Inputs: the inputs. Output "grad_<out>_<in>" (dense). The output must have one entry.
  Function Gradient(const std::string& output, const std::string& input) const;
  /// Inputs: the inputs. Output "hess_<out>_<in>": the full symmetric sparse Hessian of a
  /// one-entry output.
  Function Hessian(const std::string& output, const std::string& input) const;
  /// Structural sparsity of d output / d input (no numerical cancellation is detected).
  Sparsity JacobianSparsity(const std::string& output, const std::string& input) const;

 private:
  struct Data;
  std::shared_ptr<const Data> data_;
  friend class CompiledFunction;
};

}  // namespace graybox::expr
