// Benchmarks of the KUKA KR300 R2500 dynamics (models/kuka_kr300.h) through libexpr. Forward
// dynamics:
//   qdd = M(q)^-1 (u o tau_m - tau_f(qd) - g(q) - tau_hwc(q2) e2 - C(q, qd) qd),
// built once from libexpr operations (recursive Newton-Euler, mass matrix, LDL^T solve) and
// evaluated
//   - on the tape, one point at a time and batched over many points (SIMD lanes);
//   - as generated C compiled at run time (CompiledFunction);
//   - as the same template instantiated on double ("hand-written C++ doubles");
// plus the reverse-mode gradient of a scalar projection w^T qdd and the full sparse Jacobian
// d qdd / d (q, qd, tau). Inverse dynamics tau_m = (M qdd + C qd + g + tau_HWC e2 + tau_f) / u:
// on doubles, tape and generated code, with its Jacobian d tau / d (q, qd, qdd). Every benchmark
// reports time per point; ratios are formed from one run (see docs/performance.md).
// $GRAYBOX_BENCH_JIT_FLAGS sets the generated code's compiler flags (default JitOptions::flags).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>
#include <vector>

#include "graybox/expr.h"
#include "graybox/models/kuka_kr300.h"

namespace {

using graybox::expr::CompiledFunction;
using graybox::expr::Expr;
using graybox::expr::Function;
using graybox::expr::JitOptions;
using graybox::expr::Workspace;
namespace models = graybox::models;

constexpr int kDof = 6;
constexpr int kInputs = 3 * kDof;
constexpr unsigned kSeed = 42;

// Input points: q within joint ranges around the home pose, moderate speeds and motor torques.
Eigen::MatrixXd Points(int n) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd x(kInputs, n);
  for (int p = 0; p < n; ++p) {
    for (int i = 0; i < kDof; ++i) {
      x(i, p) = 0.8 * u(rng);
      x(kDof + i, p) = 0.5 * u(rng);
      x(2 * kDof + i, p) = 5.0 * u(rng);
    }
  }
  return x;
}

// The forward dynamics as a Function of one input x = (q, qd, tau_m) with output qdd, and a
// scalar output w^T qdd for gradients.
struct KukaFunctions {
  Function fd;
  Function gradient;
  Function reverse;
  Function jacobian;
  Function id;
  Function id_jacobian;
  KukaFunctions() {
    const std::vector<Expr> x = Expr::Symbols("x", kInputs);
    models::JointVector<Expr> q(kDof), qd(kDof), tau(kDof);
    for (int i = 0; i < kDof; ++i) {
      q[i] = x[i];
      qd[i] = x[kDof + i];
      tau[i] = x[2 * kDof + i];
    }
    const models::JointVector<Expr> qdd = models::KukaForwardDynamics(q, qd, tau);
    std::vector<Expr> out(qdd.data(), qdd.data() + kDof);
    Expr projection = 0.0;
    for (int i = 0; i < kDof; ++i) projection += (1.0 + 0.1 * i) * out[i];
    fd = Function("kuka_fd", {{"x", x}}, {{"qdd", out}, {"wqdd", {projection}}});
    gradient = fd.Gradient("wqdd", "x");
    reverse = fd.Reverse(1);
    jacobian = fd.Jacobian("qdd", "x");
    // Inverse dynamics: x = (q, qd, qdd) -> tau_m.
    models::JointVector<Expr> qdd_in(kDof);
    for (int i = 0; i < kDof; ++i) qdd_in[i] = x[2 * kDof + i];
    const models::JointVector<Expr> tau_m = models::KukaInverseDynamics(q, qd, qdd_in);
    id = Function("kuka_id", {{"x", x}},
                  {{"tau", std::vector<Expr>(tau_m.data(), tau_m.data() + kDof)}});
    id_jacobian = id.Jacobian("tau", "x");
  }
};

const KukaFunctions& Kuka() {
  static const KukaFunctions* f = new KukaFunctions();
  return *f;
}

const CompiledFunction& Compiled(const Function& f) {
  // One compiled object per Function name, built on first use.
  static std::vector<std::pair<std::string, CompiledFunction*>> cache;
  for (const auto& [name, cf] : cache) {
    if (name == f.name()) return *cf;
  }
  // $GRAYBOX_BENCH_JIT_FLAGS replaces the compiler flags: "-O3 -ffp-contract=off" gives x86-64
  // baseline code, whose instructions valgrind counts (it cannot run AVX-512).
  JitOptions options;
  if (const char* flags = std::getenv("GRAYBOX_BENCH_JIT_FLAGS")) options.flags = flags;
  cache.push_back({f.name(), new CompiledFunction(f, options)});
  return *cache.back().second;
}

void SetCounters(benchmark::State& state, const Function& f, std::int64_t points) {
  state.SetItemsProcessed(points);
  state.counters["instructions"] = f.NumInstructions();
  state.counters["registers"] = f.NumRegisters();
}

// Evaluates f (through `evaluator`: the Function itself or its CompiledFunction) on one point
// after another; inputs vary so nothing is hoisted, extra inputs (Reverse's seeds) are ones.
template <typename Evaluator>
void RunSingle(benchmark::State& state, const Function& f, const Evaluator& evaluator) {
  const Eigen::MatrixXd x = Points(256);
  Workspace ws = f.MakeWorkspace();
  std::vector<Eigen::VectorXd> out(f.NumOutputs());
  std::vector<double*> out_ptr(f.NumOutputs());
  for (int j = 0; j < f.NumOutputs(); ++j) {
    out[j].resize(f.OutputSize(j));
    out_ptr[j] = out[j].data();
  }
  std::vector<Eigen::VectorXd> extra;
  for (int i = 1; i < f.NumInputs(); ++i) extra.push_back(Eigen::VectorXd::Ones(f.InputSize(i)));
  std::vector<const double*> in(f.NumInputs());
  for (int i = 1; i < f.NumInputs(); ++i) in[i] = extra[i - 1].data();
  std::int64_t p = 0;
  for (auto _ : state) {
    in[0] = x.col(p++ % x.cols()).data();
    benchmark::DoNotOptimize(evaluator.Evaluate(in.data(), out_ptr.data(), &ws));
    benchmark::ClobberMemory();
  }
  SetCounters(state, f, state.iterations());
}

void RunTapeSingle(benchmark::State& state, const Function& f) { RunSingle(state, f, f); }

void RunNativeSingle(benchmark::State& state, const Function& f) {
  const CompiledFunction& cf = Compiled(f);
  if (!cf.IsNative()) {
    state.SkipWithError(cf.FallbackReason().c_str());
    return;
  }
  RunSingle(state, f, cf);
}

void RunTapeBatch(benchmark::State& state, const Function& f) {
  const int n = static_cast<int>(state.range(0));
  std::vector<Eigen::MatrixXd> in{Points(n)};
  for (int i = 1; i < f.NumInputs(); ++i) in.push_back(Eigen::MatrixXd::Ones(f.InputSize(i), n));
  std::vector<Eigen::MatrixXd> out;
  Workspace ws = f.MakeWorkspace();
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.EvaluateBatch(in, &out, &ws));
    benchmark::ClobberMemory();
  }
  SetCounters(state, f, state.iterations() * n);
}

// The reference: the same model template instantiated on double.
void BM_KukaFd_Double(benchmark::State& state) {
  const Eigen::MatrixXd x = Points(256);
  std::int64_t p = 0;
  models::JointVector<double> q(kDof), qd(kDof), tau(kDof);
  for (auto _ : state) {
    const auto col = x.col(p++ % x.cols());
    for (int i = 0; i < kDof; ++i) {
      q[i] = col[i];
      qd[i] = col[kDof + i];
      tau[i] = col[2 * kDof + i];
    }
    benchmark::DoNotOptimize(models::KukaForwardDynamics(q, qd, tau));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KukaFd_Double);

void BM_KukaFd_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().fd); }
BENCHMARK(BM_KukaFd_Tape);
void BM_KukaFd_TapeBatch(benchmark::State& state) { RunTapeBatch(state, Kuka().fd); }
BENCHMARK(BM_KukaFd_TapeBatch)->Arg(1024);
void BM_KukaFd_Native(benchmark::State& state) { RunNativeSingle(state, Kuka().fd); }
BENCHMARK(BM_KukaFd_Native);

void BM_KukaGradient_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().gradient); }
BENCHMARK(BM_KukaGradient_Tape);
void BM_KukaGradient_TapeBatch(benchmark::State& state) { RunTapeBatch(state, Kuka().gradient); }
BENCHMARK(BM_KukaGradient_TapeBatch)->Arg(1024);
void BM_KukaGradient_Native(benchmark::State& state) { RunNativeSingle(state, Kuka().gradient); }
BENCHMARK(BM_KukaGradient_Native);

void BM_KukaReverse_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().reverse); }
BENCHMARK(BM_KukaReverse_Tape);

void BM_KukaJacobian_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().jacobian); }
BENCHMARK(BM_KukaJacobian_Tape);
void BM_KukaJacobian_TapeBatch(benchmark::State& state) { RunTapeBatch(state, Kuka().jacobian); }
BENCHMARK(BM_KukaJacobian_TapeBatch)->Arg(1024);
void BM_KukaJacobian_Native(benchmark::State& state) { RunNativeSingle(state, Kuka().jacobian); }
BENCHMARK(BM_KukaJacobian_Native);

void BM_KukaId_Double(benchmark::State& state) {
  const Eigen::MatrixXd x = Points(256);
  std::int64_t p = 0;
  models::JointVector<double> q(kDof), qd(kDof), qdd(kDof);
  for (auto _ : state) {
    const auto col = x.col(p++ % x.cols());
    for (int i = 0; i < kDof; ++i) {
      q[i] = col[i];
      qd[i] = col[kDof + i];
      qdd[i] = col[2 * kDof + i];
    }
    benchmark::DoNotOptimize(models::KukaInverseDynamics(q, qd, qdd));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KukaId_Double);
void BM_KukaId_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().id); }
BENCHMARK(BM_KukaId_Tape);
void BM_KukaId_Native(benchmark::State& state) { RunNativeSingle(state, Kuka().id); }
BENCHMARK(BM_KukaId_Native);
void BM_KukaIdJacobian_Tape(benchmark::State& state) { RunTapeSingle(state, Kuka().id_jacobian); }
BENCHMARK(BM_KukaIdJacobian_Tape);
void BM_KukaIdJacobian_Native(benchmark::State& state) {
  RunNativeSingle(state, Kuka().id_jacobian);
}
BENCHMARK(BM_KukaIdJacobian_Native);

// Building the graph and the tape (symbolic work, done once per model).
void BM_KukaFd_BuildFunction(benchmark::State& state) {
  for (auto _ : state) {
    const std::vector<Expr> x = Expr::Symbols("x", kInputs);
    models::JointVector<Expr> q(kDof), qd(kDof), tau(kDof);
    for (int i = 0; i < kDof; ++i) {
      q[i] = x[i];
      qd[i] = x[kDof + i];
      tau[i] = x[2 * kDof + i];
    }
    const auto qdd = models::KukaForwardDynamics(q, qd, tau);
    Function f("kuka_fd", {{"x", x}}, {{"qdd", std::vector<Expr>(qdd.data(), qdd.data() + kDof)}});
    benchmark::DoNotOptimize(f.NumInstructions());
  }
}
BENCHMARK(BM_KukaFd_BuildFunction)->Unit(benchmark::kMillisecond);

// Just-in-time compilation of the forward dynamics (and of its 6x12 Jacobian): compiled afresh
// (a new, empty cache folder per iteration) against loaded from the disk cache
// (docs/performance.md, "Compiled code cache").
void RunJit(benchmark::State& state, const Function& f) {
  const bool cached = state.range(0) == 1;
  const std::filesystem::path root =
      std::filesystem::temp_directory_path() / "graybox_kuka_jit_bench";
  JitOptions options;
  int run = 0;
  options.cache_dir = (root / "warm").string();
  if (cached) CompiledFunction warm(f, options);  // fills the cache
  for (auto _ : state) {
    if (!cached) options.cache_dir = (root / std::to_string(run++)).string();
    const CompiledFunction cf(f, options);
    if (!cf.IsNative() || cf.FromCache() != cached) {
      state.SkipWithError(cf.IsNative() ? "unexpected cache state" : cf.FallbackReason().c_str());
      break;
    }
  }
  std::filesystem::remove_all(root);
  state.SetLabel(cached ? "from the cache" : "compiled");
}
void BM_KukaFd_Jit(benchmark::State& state) { RunJit(state, Kuka().fd); }
BENCHMARK(BM_KukaFd_Jit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);
void BM_KukaFdJacobian_Jit(benchmark::State& state) { RunJit(state, Kuka().jacobian); }
BENCHMARK(BM_KukaFdJacobian_Jit)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
