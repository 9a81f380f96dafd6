// A first fit against a warm re-fit after changing one fixed parameter (docs/performance.md,
// "Re-fits"): FitSession formulates once; the re-fit changes the value in the element data and
// starts from the previous optimum (primal point, and Ipopt's multipliers).
//   build/bench/fit_bench
// Cases: EMPS closed loop by multiple shooting on Ipopt (all 24,841 samples; the drive gain
// drive.k changed by 1 %), and the KUKA KR300 roblue friction fit by multiple shooting on Ceres
// (the first 3,000 samples, 12 s; f_vis6 held fixed at the file's start value and changed by 1 %).
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "graybox/estimators/data/dataset.h"
#include "graybox/estimators/fit/fit.h"

namespace est = graybox::estimators;

namespace {

struct Case {
  est::Problem problem;
  std::vector<est::SplitData> splits;
  std::string changed;  // the fixed parameter changed before the re-fit
};

est::FitOptions Options() {
  est::FitOptions o;
  o.evaluate_splits = false;
  o.compute_covariance = false;
  return o;
}

Case Emps() {
  Case c;
  c.problem =
      est::LoadProblem(std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop.toml");
  for (est::SplitData& s : est::LoadData(c.problem)) {
    if (s.role == est::SplitRole::kEstimation) c.splits.push_back(s);
  }
  c.changed = "drive.k";
  return c;
}

Case Kuka() {
  Case c;
  c.problem =
      est::LoadProblem(std::string(GRAYBOX_SOURCE_DIR) + "/problems/kuka/roblue_friction_ms.toml");
  c.problem.model.Fix("kuka.f_vis6");
  c.problem.built = c.problem.model.Build();
  for (est::SplitData& s : est::LoadData(c.problem)) {
    if (s.role != est::SplitRole::kEstimation) continue;
    s.experiment = est::Slice(s.experiment, 0, 3000);
    c.splits.push_back(s);
  }
  c.changed = "kuka.f_vis6";
  return c;
}

void FirstFit(benchmark::State& state, Case (*make)()) {
  const Case c = make();
  for (auto _ : state) {
    est::FitSession session(c.problem, c.splits, Options());
    const est::FitResult r = session.Solve();
    state.counters["iterations"] = r.solver_result.iterations;
    state.counters["formulations"] = session.num_formulations();
  }
}

void WarmRefit(benchmark::State& state, Case (*make)()) {
  const Case c = make();
  est::FitSession session(c.problem, c.splits, Options());
  est::FitResult previous = session.Solve();
  const double value = c.problem.built.parameters[c.problem.built.ParameterIndex(c.changed)].value;
  int k = 0;
  for (auto _ : state) {
    // Alternate between +1 % and the original value, each re-fit warm-started from the last.
    session.SetParameterValue(c.changed, (k++ % 2 == 0) ? 1.01 * value : value);
    previous = session.Solve(&previous);
    state.counters["iterations"] = previous.solver_result.iterations;
    state.counters["formulations"] = session.num_formulations();
  }
}

}  // namespace

BENCHMARK_CAPTURE(FirstFit, emps_closed_loop_ipopt, Emps)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(WarmRefit, emps_closed_loop_ipopt, Emps)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(4);
BENCHMARK_CAPTURE(FirstFit, kuka_roblue_friction_ceres, Kuka)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(WarmRefit, kuka_roblue_friction_ceres, Kuka)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

BENCHMARK_MAIN();
