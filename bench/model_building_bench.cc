// Model building and formulation against the number of blocks: a chain of N signal.gain blocks
// (the input through N gains into an integrator with a damping gain, the gains' k fixed by the
// pattern "g*.k", the damping free) written as a problem file in memory (its data file is not
// read: the record is made here).
//   BM_ParseGainChain: ParseProblem (TOML, the model's blocks and connections, the pattern over
//     N parameters, Model::Build), as `graybox check` does.
//   BM_MultipleShootingGainChain: BuildMultipleShooting on 200 samples (segments of 20) with the
//     lazily built objective, gradient and Hessian-of-the-Lagrangian Functions, as `graybox fit`
//     does before its first Ipopt iteration.
// Linear growth: the fitted complexity is O(N) and time per block (s_per_block) stays flat.
//   build/bench/model_building_bench
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/problem/problem_file.h"

namespace {

namespace est = graybox::estimators;

std::string GainChainProblem(int blocks) {
  std::string s =
      "[problem]\nname = \"gain_chain\"\n[model]\n"
      "inputs = [{ name = \"u\", unit = \"1\", min = -2.0, max = 2.0 }]\noutputs = [\"x.y\"]\n";
  s.reserve(static_cast<std::size_t>(blocks) * 110 + 1024);
  for (int i = 0; i < blocks; ++i) {
    const std::string in = i == 0 ? "u" : "s" + std::to_string(i - 1);
    const std::string out = i == blocks - 1 ? "net" : "s" + std::to_string(i);
    s += "[[model.blocks]]\ninstance = \"g" + std::to_string(i) +
         "\"\ntype = \"signal.gain\"\ninputs = [\"" + in + "\"]\noutputs = [\"" + out + "\"]\n";
  }
  s += "[[model.blocks]]\ninstance = \"damp\"\ntype = \"signal.gain\"\ninputs = [\"x.y\"]\n"
       "outputs = [\"-net\"]\n"
       "[[model.blocks]]\ninstance = \"x\"\ntype = \"signal.integrator\"\ninputs = [\"net\"]\n"
       "[model.parameters]\n\"g*.k\" = { value = 1.0, free = false }\n"
       "\"damp.k\" = { value = 1.0, lower = 0.01, upper = 100.0 }\n"
       "[[data]]\nname = \"d\"\nfile = \"chain.csv\"\ntime = \"t\"\ninputs = { u = \"u\" }\n"
       "outputs = { \"x.y\" = \"y\" }\n"
       "[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ipopt\"\n";
  return s;
}

void BM_ParseGainChain(benchmark::State& state) {
  const int blocks = static_cast<int>(state.range(0));
  const std::string text = GainChainProblem(blocks);
  for (auto _ : state) {
    const est::Problem problem = est::ParseProblem(text, "gain_chain.toml");
    benchmark::DoNotOptimize(problem.built.parameters.size());
  }
  state.SetComplexityN(blocks);
  // blocks / second, inverted: seconds per block.
  state.counters["s_per_block"] = benchmark::Counter(
      blocks, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ParseGainChain)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(4000)
    ->Arg(8000)
    ->Arg(16000)
    ->Unit(benchmark::kMillisecond)
    ->Complexity(benchmark::oN);

void BM_MultipleShootingGainChain(benchmark::State& state) {
  const int blocks = static_cast<int>(state.range(0));
  const est::Problem problem = est::ParseProblem(GainChainProblem(blocks), "gain_chain.toml");
  constexpr int kSamples = 200;
  est::Experiment record;
  record.name = "chain";
  record.dt = 0.01;
  record.u.resize(kSamples, 1);
  record.y.resize(kSamples, 1);
  double x = 0.0;
  for (int k = 0; k < kSamples; ++k) {
    const double t = k * record.dt;
    record.u(k, 0) = std::sin(3.0 * t) + 0.5 * std::sin(11.0 * t);
    record.y(k, 0) = x;
    x += record.dt * (record.u(k, 0) - x);
  }
  est::ExperimentSetup setup;
  setup.x0 = Eigen::VectorXd::Zero(1);
  est::MultipleShootingOptions options = problem.estimation.multiple_shooting;
  options.segment_length = 20;
  for (auto _ : state) {
    const est::ShootingProblem nlp =
        est::BuildMultipleShooting(problem.built, {record}, {setup}, options);
    nlp.nlp.HessianRows();
    double f = 0.0;
    nlp.nlp.Objective(nlp.nlp.w0().data(), &f);
    Eigen::VectorXd g(nlp.nlp.NumVariables());
    nlp.nlp.Gradient(nlp.nlp.w0().data(), g.data());
    benchmark::DoNotOptimize(f);
  }
  state.SetComplexityN(blocks);
  // blocks / second, inverted: seconds per block.
  state.counters["s_per_block"] = benchmark::Counter(
      blocks, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_MultipleShootingGainChain)
    ->Arg(250)
    ->Arg(500)
    ->Arg(1000)
    ->Arg(2000)
    ->Arg(4000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Complexity(benchmark::oN);

}  // namespace

BENCHMARK_MAIN();
