// C code generation and just-in-time compilation of a Function.
//
// GenerateC emits self-contained C99 (only <math.h>) for one Function:
//     int <symbol>(const double* const* arg, double* const* res);
// arg[i] points to the entries of input i, res[j] to those of output j (null to skip); it returns
// 0. The code is straight-line, one local per tape register, and evaluates exactly the operations
// of the tape with the same formulas (ops.h), so results agree with the tape to the last bit
// barring compiler contraction (-ffp-contract is set to off by default for that reason).
//
// CompiledFunction compiles that code with the system C compiler into a shared object, loads it
// with dlopen and calls it. When no compiler is found, or compiling or loading fails, it falls back
// to the tape and says why (IsNative() is false, FallbackReason() explains); the results are the
// same either way. Compilation takes seconds for large functions: compile once, evaluate many
// times.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "graybox/expr/function.h"

namespace graybox::expr {

/// C source for `f` exporting `symbol`: a C identifier that is not a keyword, not reserved
/// (leading "__" or "_X"), and not a name the generated file declares (gb_*) or calls from
/// <math.h> (sin, exp, pow, ...); std::invalid_argument otherwise.
std::string GenerateC(const Function& f, const std::string& symbol);

struct JitOptions {
  /// Compiler command; empty means $CC if set, else "cc".
  std::string compiler;
  /// Flags for the compiler (position-independent shared object flags are added).
  std::string flags = "-O3 -march=native -ffp-contract=off";
  /// Directory for the generated source and library; empty means a fresh one under $TMPDIR or
  /// /tmp, removed after loading.
  std::string work_dir;
  /// Keep the generated files (for inspection).
  bool keep_files = false;
};

class CompiledFunction {
 public:
  explicit CompiledFunction(const Function& f, const JitOptions& options = {});

  /// True when the native code is in use; false when evaluation falls back to the tape.
  bool IsNative() const { return native_ != nullptr; }
  /// Why the tape is used (compiler missing, compile error with its first lines, dlopen error);
  /// empty when native.
  const std::string& FallbackReason() const { return fallback_reason_; }
  const Function& function() const { return function_; }

  /// Same contract as Function::Evaluate; `ws` must come from function().MakeWorkspace() (used
  /// only by the fallback). Allocation-free, thread-safe with one workspace per thread.
  EvalStatus Evaluate(const double* const* inputs, double* const* outputs, Workspace* ws) const;
  /// Convenience with size checks; throws NonFiniteError on NaN/Inf outputs.
  std::vector<Eigen::VectorXd> operator()(const std::vector<Eigen::VectorXd>& inputs) const;

 private:
  using NativeFn = int (*)(const double* const*, double* const*);
  Function function_;
  std::shared_ptr<void> library_;
  NativeFn native_ = nullptr;
  std::vector<int> output_sizes_;
  std::string fallback_reason_;
};

}  // namespace graybox::expr
