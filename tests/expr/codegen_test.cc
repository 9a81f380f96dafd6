// C code generation and JIT compilation: generated code on random trees covering every
// operation matches the tape, special literals, non-finite reporting and argument checks on the
// native path, the tape fallback when the compiler is missing or fails, and symbol validation.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "graybox/expr.h"
#include "test_util.h"

namespace graybox::expr {
namespace {

using testing::ExpectThrowsWith;
using testing::RandomTrees;
using testing::RandomVector;

constexpr std::uint32_t kSeed = 5150;
constexpr int kNumTrees = 160;
constexpr int kTreeDepth = 5;
constexpr int kPoints = 20;
// The generated code evaluates the tape's operations with the same libm functions and
// -ffp-contract=off; only the compiler's choices for exact operations may differ, so the
// results agree to the last bits.
constexpr double kNativeVsTapeRelTol = 1e-14;

const double kInf = std::numeric_limits<double>::infinity();
const double kNaN = std::numeric_limits<double>::quiet_NaN();

bool Close(double a, double b, double tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::fabs(a - b) <= tol * std::max(1.0, std::fabs(b));
}

// A fresh directory under $TMPDIR or /tmp, removed with its files on destruction.
class TempDir {
 public:
  TempDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string templ = std::string(tmp && *tmp ? tmp : "/tmp") + "/graybox_codegen_test_XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    if (mkdtemp(buf.data()) != nullptr) path_ = buf.data();
  }
  ~TempDir() {
    for (const char* f : {"function.c", "function.so", "compile.log"}) {
      std::remove((path_ + "/" + f).c_str());
    }
    rmdir(path_.c_str());
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Evaluates `f` through `eval` (tape or native) at x; returns the single output.
template <typename F>
Eigen::VectorXd EvaluateWith(const F& f, const Function& fn, const Eigen::VectorXd& x,
                             EvalStatus* status) {
  Eigen::VectorXd y(fn.OutputSize(0));
  const double* ins[] = {x.data()};
  double* outs[] = {y.data()};
  Workspace ws = fn.MakeWorkspace();
  *status = f.Evaluate(ins, outs, &ws);
  return y;
}

TEST(GenerateC, EmitsASelfContainedC99Function) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const Function f("f", {{"in", {x, y}}}, {{"out", {x * y + sin(x), sigmoid(y)}}, {"none", {}}});
  const std::string c = GenerateC(f, "my_model_v2");
  EXPECT_NE(c.find("int my_model_v2(const double* const* arg, double* const* res)"),
            std::string::npos)
      << c;
  EXPECT_EQ(c.find("#include"), c.find("#include <math.h>"));
  EXPECT_EQ(c.find("#include", c.find("#include") + 1), std::string::npos) << "only <math.h>";
  EXPECT_NE(c.find("arg[0][1]"), std::string::npos);
  EXPECT_NE(c.find("if (res[0])"), std::string::npos);
  EXPECT_EQ(c.find("res[1]"), std::string::npos) << "an empty output writes nothing";
  EXPECT_NE(c.find("return 0;"), std::string::npos);
  EXPECT_EQ(GenerateC(f, "my_model_v2"), c) << "deterministic";
}

TEST(GenerateC, RejectsSymbolsThatAreNotUsableCIdentifiers) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"y", {x}}});
  for (const std::string bad : {"", "1abc", "a-b", "a b", "f()", "caf\xc3\xa9",
                                // C keywords are not identifiers.
                                "int", "return", "double", "static", "inline", "restrict",
                                // Reserved identifiers.
                                "__f", "_Bool",
                                // Names the generated file itself declares or includes.
                                "gb_sigmoid", "gb_custom", "sin", "exp", "fmax", "NAN"}) {
    SCOPED_TRACE(bad);
    ExpectThrowsWith<std::invalid_argument>([&] { GenerateC(f, bad); },
                                            {"GenerateC: expected a C identifier", bad});
  }
  for (const std::string good : {"f", "_f", "F2", "my_model_v2", "sine", "integer"}) {
    EXPECT_NO_THROW(GenerateC(f, good)) << good;
  }
}

TEST(CompiledFunction, NativeCodeMatchesTheTapeOnRandomTreesOverAllOps) {
  std::mt19937 rng = testing::SeededRng(kSeed);
  const std::vector<Expr> x = Expr::Symbols("x", 4);
  RandomTrees trees(x, kSeed);
  std::vector<Expr> outs;
  for (int k = 0; k < kNumTrees; ++k) outs.push_back(trees.Generate(kTreeDepth));
  // Sums of products, which the tape fuses into single instructions.
  outs.push_back(x[0] * x[1] + x[2]);
  outs.push_back(x[0] * x[1] - x[3]);
  outs.push_back(x[3] - x[2] * x[1]);
  const std::set<Op> used = testing::OperationsIn(outs);
  for (Op op : testing::AllOperations()) EXPECT_TRUE(used.count(op)) << OpName(op) << " unused";
  const Function f("random", {{"x", x}}, {{"y", outs}});

  const TempDir dir;
  ASSERT_FALSE(dir.path().empty());
  JitOptions options;
  options.work_dir = dir.path();
  options.keep_files = true;
  const CompiledFunction native(f, options);
  ASSERT_TRUE(native.IsNative()) << native.FallbackReason();
  EXPECT_TRUE(native.FallbackReason().empty());
  // The kept source is exactly GenerateC's output.
  EXPECT_EQ(ReadFile(dir.path() + "/function.c"), GenerateC(f, "graybox_function"));

  for (int p = 0; p < kPoints; ++p) {
    const Eigen::VectorXd point = RandomVector(&rng, 4, -2.0, 2.0);
    EvalStatus tape_status, native_status;
    const Eigen::VectorXd expected = EvaluateWith(f, f, point, &tape_status);
    const Eigen::VectorXd got = EvaluateWith(native, f, point, &native_status);
    EXPECT_EQ(native_status.ok, tape_status.ok);
    for (int k = 0; k < got.size(); ++k) {
      EXPECT_TRUE(Close(got[k], expected[k], kNativeVsTapeRelTol))
          << "output " << k << " = " << outs[k] << "\n native " << got[k] << " tape "
          << expected[k];
    }
    // The convenience call agrees too.
    if (tape_status.ok) {
      EXPECT_EQ(native({point})[0], got);
    }
  }
}

TEST(CompiledFunction, LiteralsNonFiniteReportingAndArgumentChecks) {
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const std::vector<Expr> outs = {
      Expr(-0.0),
      x * 1e-310,  // a subnormal constant
      if_else(lt(x, 100.0), x, Expr(kNaN)),
      if_else(lt(x, -100.0), Expr(-kInf), x + y),
      x * -2.5 + 1e300 * 1e8,
  };
  const Function f("lit", {{"x", {x}}, {"y", {y}}}, {{"a", outs}, {"r", {x, log(x)}}});
  const CompiledFunction native(f);
  ASSERT_TRUE(native.IsNative()) << native.FallbackReason();
  const auto r = native({Eigen::VectorXd::Constant(1, 2.0), Eigen::VectorXd::Constant(1, 3.0)});
  EXPECT_EQ(r[0][0], 0.0);
  EXPECT_TRUE(std::signbit(r[0][0]));
  EXPECT_EQ(r[0][1], 2.0 * 1e-310);
  EXPECT_EQ(r[0][2], 2.0);
  EXPECT_EQ(r[0][3], 5.0);
  EXPECT_EQ(r[0][4], -5.0 + 1e308);
  // Non-finite outputs: reported with output name and index; values still written.
  Workspace ws = f.MakeWorkspace();
  const double xv = -1.0, yv = 0.0;
  const double* ins[] = {&xv, &yv};
  double a[5], rr[2];
  double* outputs[] = {a, rr};
  const EvalStatus s = native.Evaluate(ins, outputs, &ws);
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(s.output, 1);
  EXPECT_EQ(s.index, 1);
  EXPECT_TRUE(std::isnan(s.value));
  EXPECT_EQ(s.message.rfind("Function 'lit': output 'r'[1] = ", 0), 0u) << s.message;
  EXPECT_EQ(rr[0], -1.0);
  ExpectThrowsWith<NonFiniteError>(
      [&] {
        native({Eigen::VectorXd::Constant(1, -1.0), Eigen::VectorXd::Zero(1)});
      },
      {"output 'r'[1]"});
  // Null outputs are skipped.
  double* only_a[] = {a, nullptr};
  EXPECT_TRUE(native.Evaluate(ins, only_a, &ws).ok);
  // Sizes are checked like Function::operator().
  ExpectThrowsWith<std::invalid_argument>([&] { native({Eigen::VectorXd::Zero(1)}); },
                                          {"expected 2 inputs, got 1"});
  ExpectThrowsWith<std::invalid_argument>(
      [&] {
        native({Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(1)});
      },
      {"input 'x': expected size 1, got 2"});
}

TEST(CompiledFunction, TrivialFunctionsCompile) {
  // No instructions at all: outputs are raw inputs and constants; and a function of nothing.
  const Expr x = Expr::Symbol("x"), unused = Expr::Symbol("u");
  const Function raw("raw", {{"x", {x, unused}}}, {{"y", {x, Expr(3.0), x}}, {"none", {}}});
  const CompiledFunction native_raw(raw);
  ASSERT_TRUE(native_raw.IsNative()) << native_raw.FallbackReason();
  const auto r = native_raw({Eigen::Vector2d(7.0, 1.0)});
  EXPECT_EQ(r[0], Eigen::Vector3d(7.0, 3.0, 7.0));
  EXPECT_EQ(r[1].size(), 0);
  const CompiledFunction native_empty{Function()};
  ASSERT_TRUE(native_empty.IsNative()) << native_empty.FallbackReason();
  EXPECT_TRUE(native_empty({}).empty());
}

// The disk cache: the second CompiledFunction of the same function and flags loads the library
// the first one compiled; other flags compile anew; a cached file that does not load is
// compiled again.
TEST(CompiledFunction, ASecondCompileOfTheSameFunctionComesFromTheCache) {
  TempDir cache;
  ASSERT_FALSE(cache.path().empty());
  const std::string folder = cache.path() + "/jit";
  const Expr x = Expr::Symbol("x"), y = Expr::Symbol("y");
  const Function f("f", {{"in", {x, y}}}, {{"out", {x * y + sin(x), exp(y) / (1.0 + x * x)}}});
  JitOptions options;
  options.cache_dir = folder;
  const CompiledFunction first(f, options);
  ASSERT_TRUE(first.IsNative()) << first.FallbackReason();
  EXPECT_FALSE(first.FromCache());
  ASSERT_FALSE(first.CacheFile().empty());
  EXPECT_TRUE(std::filesystem::exists(first.CacheFile()));
  const CompiledFunction second(f, options);
  ASSERT_TRUE(second.IsNative()) << second.FallbackReason();
  EXPECT_TRUE(second.FromCache());
  EXPECT_EQ(second.CacheFile(), first.CacheFile());
  const Eigen::Vector2d point(0.3, -1.2);
  EXPECT_EQ(second({point})[0], first({point})[0]);
  // Other flags: another entry, compiled.
  JitOptions o1 = options;
  o1.flags = "-O1 -ffp-contract=off";
  const CompiledFunction other(f, o1);
  ASSERT_TRUE(other.IsNative()) << other.FallbackReason();
  EXPECT_FALSE(other.FromCache());
  EXPECT_NE(other.CacheFile(), first.CacheFile());
  // A damaged entry (here: planted in another cache folder under the entry's name, a file this
  // process has not loaded) is compiled again and replaced.
  const std::string other_folder = cache.path() + "/jit2";
  std::filesystem::create_directories(other_folder);
  const std::string planted =
      other_folder + "/" + std::filesystem::path(first.CacheFile()).filename().string();
  { std::ofstream(planted) << "not a library"; }
  JitOptions o2 = options;
  o2.cache_dir = other_folder;
  const CompiledFunction repaired(f, o2);
  ASSERT_TRUE(repaired.IsNative()) << repaired.FallbackReason();
  EXPECT_FALSE(repaired.FromCache());
  EXPECT_GT(std::filesystem::file_size(planted), 100u);  // the compiled library replaced it
  // Without the cache: compiled, nothing cached.
  JitOptions none = options;
  none.use_cache = false;
  const CompiledFunction uncached(f, none);
  EXPECT_TRUE(uncached.IsNative());
  EXPECT_FALSE(uncached.FromCache());
  EXPECT_TRUE(uncached.CacheFile().empty());
  std::filesystem::remove_all(folder);
  std::filesystem::remove_all(other_folder);
}

TEST(CompiledFunction, ThreadsShareOneNativeFunction) {
  constexpr int kThreads = 4;
  const std::vector<Expr> x = Expr::Symbols("x", 3);
  const Function f("f", {{"x", x}}, {{"y", {sin(x[0]) * x[1] + exp(x[2]), atan2(x[0], x[2])}}});
  const CompiledFunction native(f);
  ASSERT_TRUE(native.IsNative()) << native.FallbackReason();
  std::vector<Eigen::MatrixXd> results(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      std::mt19937 rng(kSeed);  // every thread the same points
      results[t].resize(2, 100);
      for (int p = 0; p < 100; ++p) {
        const Eigen::VectorXd point = RandomVector(&rng, 3, -1, 1);
        results[t].col(p) = native({point})[0];
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 1; t < kThreads; ++t) EXPECT_EQ(results[t], results[0]) << t;
}

TEST(CompiledFunction, FallsBackToTheTapeWhenTheCompilerIsMissing) {
  const std::vector<Expr> x = Expr::Symbols("x", 2);
  const Function f("f", {{"x", x}}, {{"y", {x[0] * x[1] + tanh(x[0]), softplus(x[1])}}});
  JitOptions options;
  options.compiler = "/nonexistent/cc";
  const CompiledFunction fallback(f, options);
  EXPECT_FALSE(fallback.IsNative());
  EXPECT_NE(fallback.FallbackReason().find("compiler command failed"), std::string::npos)
      << fallback.FallbackReason();
  EXPECT_NE(fallback.FallbackReason().find("/nonexistent/cc"), std::string::npos)
      << fallback.FallbackReason();
  // Same results as the tape, through both entry points.
  std::mt19937 rng = testing::SeededRng(kSeed);
  for (int p = 0; p < 5; ++p) {
    const Eigen::VectorXd point = RandomVector(&rng, 2, -2, 2);
    EXPECT_EQ(fallback({point})[0], f({point})[0]);
    EvalStatus s1, s2;
    EXPECT_EQ(EvaluateWith(fallback, f, point, &s1), EvaluateWith(f, f, point, &s2));
    EXPECT_TRUE(s1.ok);
  }
  // The fallback checks its workspace like the tape.
  const double in[2] = {0, 0};
  const double* ins[] = {in};
  double out[2];
  double* outs[] = {out};
  EXPECT_THROW(fallback.Evaluate(ins, outs, nullptr), std::invalid_argument);
  EXPECT_EQ(fallback.function().name(), "f");
}

TEST(CompiledFunction, FallsBackWithTheCompilerMessageWhenCompilationFails) {
  const Expr x = Expr::Symbol("x");
  const Function f("f", {{"x", {x}}}, {{"y", {x * 2.0}}});
  JitOptions options;
  options.flags = "-Wl,--no-such-linker-flag-for-graybox-tests";
  const CompiledFunction fallback(f, options);
  EXPECT_FALSE(fallback.IsNative());
  EXPECT_NE(fallback.FallbackReason().find("compiler command failed"), std::string::npos)
      << fallback.FallbackReason();
  EXPECT_NE(fallback.FallbackReason().find("no-such-linker-flag"), std::string::npos)
      << fallback.FallbackReason();
  EXPECT_EQ(fallback({Eigen::VectorXd::Constant(1, 4.0)})[0][0], 8.0);
}

}  // namespace
}  // namespace graybox::expr
