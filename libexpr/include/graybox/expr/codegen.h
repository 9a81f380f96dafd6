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
// times. The shared objects are kept in a cache folder under a 64-bit FNV-1a hash of the
// generated source, the compiler command, its flags, the compiler's version
// (`<compiler> -dumpfullversion -dumpmachine`) and the processor (/proc/cpuinfo's model name and
// flags: code built with -march=native is never loaded on another machine sharing the folder),
// so a second run of the same function loads the library instead of compiling it
// (FromCache()); a cached file that does not load is compiled again. Entries are written under a
// temporary name and renamed, so processes that share a cache never load a half-written library.
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
  /// Keep the generated files (for inspection); the cache is not used then.
  bool keep_files = false;
  /// Reuse compiled libraries across runs (file comment).
  bool use_cache = true;
  /// The cache folder; empty means $GRAYBOX_JIT_CACHE, else $XDG_CACHE_HOME/graybox/jit, else
  /// $HOME/.cache/graybox/jit (no cache when none is set). Created (mode 0700) when missing;
  /// an existing folder keeps its permissions.
  std::string cache_dir;
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
  /// True when the native code was loaded from the cache, without compiling.
  bool FromCache() const { return from_cache_; }
  /// The cached library's path; empty without a cache.
  const std::string& CacheFile() const { return cache_file_; }

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
  bool from_cache_ = false;
  std::string cache_file_;

  bool Load(const std::string& library);
};

}  // namespace graybox::expr
