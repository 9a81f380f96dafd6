// Time per Ipopt iteration against the record length: the EMPS closed-loop problem
// (problems/emps/emps_closed_loop.toml: multiple shooting, segments of 20 samples, continuity
// constraints, exact Hessian) on 1,000, 10,000 and 100,000 samples. The 1k and 10k records are
// the first samples of DATA_EMPS; 100k is DATA_EMPS four times plus its first 636 samples, each
// copy its own experiment (shared parameters, own fixed initial state), so nothing is spliced.
// Ipopt runs 3 and then 11 iterations from the same start; the time per iteration is the
// difference over 8 (set-up costs cancel). The NLP build time includes the lazily built objective
// and Hessian Functions. Linear growth means us_per_iter_per_sample constant.
//
//   build/bench/nlp_scaling_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <string>
#include <vector>

#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/problem/problem_file.h"
#include "graybox/estimators/solvers/solvers.h"

namespace {

namespace est = graybox::estimators;

struct Emps {
  est::Problem problem;
  est::Experiment record;
  est::ExperimentSetup setup;
};

const Emps& LoadEmps() {
  static const Emps emps = [] {
    Emps e{
        est::LoadProblem(std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop.toml"),
        {},
        {}};
    for (const est::SplitData& s : est::LoadData(e.problem)) {
      if (s.name != "estimation") continue;
      e.record.name = s.name;
      e.record.dt = s.experiment.dt;
      e.record.u = s.experiment.u;
      e.record.y = s.experiment.y;
      e.setup.x0 = s.setup.x0;
    }
    return e;
  }();
  return emps;
}

/// The copies of the record and their setups (the same initial state each), in the same order.
struct Records {
  std::vector<est::Experiment> experiments;
  std::vector<est::ExperimentSetup> setups;
};

Records Copies(int samples) {
  const est::Experiment& full = LoadEmps().record;
  Records out;
  int left = samples;
  while (left > 0) {
    const int n = std::min<int>(left, static_cast<int>(full.u.rows()));
    est::Experiment e = full;
    e.name = "copy" + std::to_string(out.experiments.size());
    e.u = full.u.topRows(n);
    e.y = full.y.topRows(n);
    out.experiments.push_back(std::move(e));
    out.setups.push_back(LoadEmps().setup);
    left -= n;
  }
  return out;
}

void BM_EmpsMultipleShootingIpoptIteration(benchmark::State& state) {
  const int samples = static_cast<int>(state.range(0));
  const Emps& emps = LoadEmps();
  const Records records = Copies(samples);
  est::MultipleShootingOptions options = emps.problem.estimation.multiple_shooting;
  est::IpoptOptions ipopt = emps.problem.estimation.ipopt;
  constexpr int kShort = 3, kLong = 11;
  ipopt.tolerance = 1e-14;  // never converged before kLong
  double build = 0.0, per_iteration = 0.0;
  int solves = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const est::ShootingProblem problem = est::BuildMultipleShooting(
        emps.problem.built, records.experiments, records.setups, options);
    problem.nlp.HessianRows();  // the lazy Functions, so the solves time iterations only
    double f = 0.0;
    problem.nlp.Objective(problem.nlp.w0().data(), &f);
    build += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ipopt.max_iterations = kShort;
    const est::SolverResult short_run = est::SolveWithIpopt(problem.nlp, ipopt);
    ipopt.max_iterations = kLong;
    const est::SolverResult long_run = est::SolveWithIpopt(problem.nlp, ipopt);
    if (long_run.iterations != kLong || short_run.iterations != kShort) {
      state.SkipWithError("Ipopt stopped early");
      return;
    }
    per_iteration += (long_run.seconds - short_run.seconds) / (kLong - kShort);
    ++solves;
    state.counters["variables"] = problem.nlp.NumVariables();
  }
  state.counters["samples"] = samples;
  state.counters["build_s"] = build / solves;
  state.counters["s_per_iter"] = per_iteration / solves;
  state.counters["us_per_iter_per_sample"] = 1e6 * per_iteration / solves / samples;
}
BENCHMARK(BM_EmpsMultipleShootingIpoptIteration)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(100000)
    ->Iterations(1)
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
