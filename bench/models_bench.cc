// Benchmarks of the models-issue additions that kuka_dynamics_bench.cc does not cover, on the KUKA
// KR300 R2500 (6 joints, 66 standard inertial parameters):
//   - the regressor Y(q, qd, qdd) (6 x 66, regressor.h) on double and as a libexpr Function (tape,
//     batched tape, generated code): the inner loop of equation-error identification (IDIM-LS);
//   - the forward dynamics with the 84 block parameters (inertial and friction) as INPUTS
//     (robot.kuka_kr300, robot_blocks.h), and its Jacobian d qdd / d (q, qd, tau_m, p): what an
//     estimator evaluates when it identifies the physical parameters. kuka_dynamics_bench.cc has
//     the same with the parameters folded in as constants.
// Every benchmark reports time per point.
#include <benchmark/benchmark.h>

#include <random>
#include <string>
#include <vector>

#include "graybox/expr.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/regressor.h"
#include "graybox/models/robot_blocks.h"

namespace {

using graybox::expr::CompiledFunction;
using graybox::expr::Expr;
using graybox::expr::Function;
using graybox::expr::Workspace;
namespace models = graybox::models;

constexpr int kDof = 6;
constexpr unsigned kSeed = 42;

// 3 * kDof inputs per point (q, qd, qdd or tau_m), as in kuka_dynamics_bench.cc.
Eigen::MatrixXd Points(int n) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd x(3 * kDof, n);
  for (int p = 0; p < n; ++p) {
    for (int i = 0; i < kDof; ++i) {
      x(i, p) = 0.8 * u(rng);
      x(kDof + i, p) = 0.5 * u(rng);
      x(2 * kDof + i, p) = 5.0 * u(rng);
    }
  }
  return x;
}

struct Functions {
  Function regressor;      // x = (q, qd, qdd) -> Y (column-major, 6 x 66)
  Function fd_params;      // x = (q, qd, tau_m), p (84) -> qdd
  Function fd_params_jac;  // d qdd / d (x, p), one sparse output per input
  Eigen::VectorXd nominal;
  Functions() {
    const models::SerialChain& chain = models::DefaultKukaKr300Model().chain;
    const std::vector<Expr> x = Expr::Symbols("x", 3 * kDof);
    models::JointVector<Expr> q(kDof), qd(kDof), a(kDof);
    for (int i = 0; i < kDof; ++i) {
      q[i] = x[i];
      qd[i] = x[kDof + i];
      a[i] = x[2 * kDof + i];
    }
    const auto y = models::Regressor(chain, q, qd, a);
    regressor = Function("kuka_regressor", {{"x", x}},
                         {{"y", std::vector<Expr>(y.data(), y.data() + y.size())}});

    const auto block = models::MakeKukaKr300Block();
    const std::vector<Expr> p = Expr::Symbols("p", block->NumParameters());
    std::vector<Expr> state(x.begin(), x.begin() + 2 * kDof), xdot(2 * kDof);
    block->Evaluate(graybox::models::BlockArgs<Expr>{state.data(), x.data() + 2 * kDof, p.data(),
                                                     xdot.data(), nullptr});
    fd_params = Function("kuka_fd_params", {{"x", x}, {"p", p}},
                         {{"qdd", std::vector<Expr>(xdot.begin() + kDof, xdot.end())}});
    const Function jx = fd_params.Jacobian("qdd", "x");
    const Function jp = fd_params.Jacobian("qdd", "p");
    fd_params_jac = Function("kuka_fd_params_jac", {{"x", x}, {"p", p}},
                             {{"jx", jx.Call({x, p})[0], jx.OutputSparsity(0)},
                              {"jp", jp.Call({x, p})[0], jp.OutputSparsity(0)}});
    const std::vector<double> nom = block->NominalParameters();
    nominal = Eigen::Map<const Eigen::VectorXd>(nom.data(), static_cast<Eigen::Index>(nom.size()));
  }
};

const Functions& Kuka() {
  static const Functions* f = new Functions();
  return *f;
}

const CompiledFunction& Compiled(const Function& f) {
  static std::vector<std::pair<std::string, CompiledFunction*>> cache;
  for (const auto& [name, cf] : cache) {
    if (name == f.name()) return *cf;
  }
  cache.push_back({f.name(), new CompiledFunction(f)});
  return *cache.back().second;
}

void SetCounters(benchmark::State& state, const Function& f, std::int64_t points) {
  state.SetItemsProcessed(points);
  state.counters["instructions"] = f.NumInstructions();
}

// One point after another; the second input (parameters), if any, is the nominal vector.
template <typename Evaluator>
void RunSingle(benchmark::State& state, const Function& f, const Evaluator& evaluate) {
  const Eigen::MatrixXd x = Points(256);
  Workspace ws = f.MakeWorkspace();
  std::vector<Eigen::VectorXd> out(f.NumOutputs());
  std::vector<double*> out_ptr(f.NumOutputs());
  for (int j = 0; j < f.NumOutputs(); ++j) {
    out[j].resize(f.OutputSize(j));
    out_ptr[j] = out[j].data();
  }
  std::vector<const double*> in(f.NumInputs());
  if (f.NumInputs() > 1) in[1] = Kuka().nominal.data();
  std::int64_t p = 0;
  for (auto _ : state) {
    in[0] = x.col(p++ % x.cols()).data();
    benchmark::DoNotOptimize(evaluate(in.data(), out_ptr.data(), &ws));
    benchmark::ClobberMemory();
  }
  SetCounters(state, f, state.iterations());
}

void RunTape(benchmark::State& state, const Function& f) {
  RunSingle(state, f, [&](const double* const* in, double* const* out, Workspace* ws) {
    return f.Evaluate(in, out, ws);
  });
}

void RunNative(benchmark::State& state, const Function& f) {
  const CompiledFunction& cf = Compiled(f);
  if (!cf.IsNative()) {
    state.SkipWithError(cf.FallbackReason().c_str());
    return;
  }
  RunSingle(state, f, [&](const double* const* in, double* const* out, Workspace* ws) {
    return cf.Evaluate(in, out, ws);
  });
}

void RunTapeBatch(benchmark::State& state, const Function& f) {
  const int n = static_cast<int>(state.range(0));
  std::vector<Eigen::MatrixXd> in{Points(n)};
  if (f.NumInputs() > 1) in.push_back(Kuka().nominal.replicate(1, n));
  std::vector<Eigen::MatrixXd> out;
  Workspace ws = f.MakeWorkspace();
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.EvaluateBatch(in, &out, &ws));
    benchmark::ClobberMemory();
  }
  SetCounters(state, f, state.iterations() * n);
}

// The regressor template on double (fixed-size storage, no heap).
void BM_KukaRegressor_Double(benchmark::State& state) {
  const models::SerialChain& chain = models::DefaultKukaKr300Model().chain;
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
    benchmark::DoNotOptimize(models::Regressor(chain, q, qd, qdd));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_KukaRegressor_Double);

void BM_KukaRegressor_Tape(benchmark::State& state) { RunTape(state, Kuka().regressor); }
BENCHMARK(BM_KukaRegressor_Tape);
void BM_KukaRegressor_TapeBatch(benchmark::State& state) { RunTapeBatch(state, Kuka().regressor); }
BENCHMARK(BM_KukaRegressor_TapeBatch)->Arg(1024);
void BM_KukaRegressor_Native(benchmark::State& state) { RunNative(state, Kuka().regressor); }
BENCHMARK(BM_KukaRegressor_Native);

void BM_KukaFdParams_Tape(benchmark::State& state) { RunTape(state, Kuka().fd_params); }
BENCHMARK(BM_KukaFdParams_Tape);
void BM_KukaFdParams_Native(benchmark::State& state) { RunNative(state, Kuka().fd_params); }
BENCHMARK(BM_KukaFdParams_Native);
void BM_KukaFdParamsJacobian_Tape(benchmark::State& state) { RunTape(state, Kuka().fd_params_jac); }
BENCHMARK(BM_KukaFdParamsJacobian_Tape);
void BM_KukaFdParamsJacobian_TapeBatch(benchmark::State& state) {
  RunTapeBatch(state, Kuka().fd_params_jac);
}
BENCHMARK(BM_KukaFdParamsJacobian_TapeBatch)->Arg(1024);
void BM_KukaFdParamsJacobian_Native(benchmark::State& state) {
  RunNative(state, Kuka().fd_params_jac);
}
BENCHMARK(BM_KukaFdParamsJacobian_Native);

}  // namespace

BENCHMARK_MAIN();
