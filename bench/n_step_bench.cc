// The 150-step NRMS of seed 000 (eq. 7) on a 15,000-sample 6-DoF record: the roblue KUKA test
// split (../shared/data/roblue_elabee/elabee_robot_ftsd.mat), 14,850 starts x 150 RK4 steps of the
// KUKA forward dynamics, spread over threads (estimators/n_step.h): the step as generated C
// (compiled at run time, cached on disk) or as the batched tape; arguments: threads, generated.
//   build/bench/n_step_bench --benchmark_min_time=1
#include <benchmark/benchmark.h>

#include <string>

#include "graybox/estimators/analysis/n_step.h"
#include "graybox/estimators/data/mat_file.h"
#include "graybox/models/model.h"
#include "graybox/models/robot_blocks.h"

namespace {

using graybox::estimators::NStepNrmsSimulated;
using graybox::estimators::NStepSimulationOptions;
namespace models = graybox::models;

models::StateSpaceModel KukaModel() {
  models::Model m("kuka");
  std::vector<std::string> inputs;
  for (int i = 1; i <= 6; ++i) {
    inputs.push_back("tau_m" + std::to_string(i));
    m.AddInput(inputs.back(), "N m");
  }
  models::KukaBlockOptions options;
  options.inertial_parameters = false;
  m.AddBlock("robot", models::MakeKukaKr300Block(options), inputs, {});
  for (int i = 1; i <= 6; ++i) m.AddOutput("robot.q" + std::to_string(i));
  return m.Build();
}

void BM_Nrms150_RoblueTest(benchmark::State& state) {
  graybox::estimators::MatFile mat(std::string(GRAYBOX_SHARED_DATA_DIR) +
                                   "/roblue_elabee/elabee_robot_ftsd.mat");
  const Eigen::MatrixXd u = mat.ReadMatrix("u_test"), y = mat.ReadMatrix("y_test");
  const models::StateSpaceModel model = KukaModel();
  NStepSimulationOptions options;
  options.scoring.steps = 150;
  options.scoring.channels = {0, 1, 2, 3, 4, 5};
  options.num_threads = static_cast<int>(state.range(0));
  options.generated_code = state.range(1) == 1;
  std::string evaluation;
  double nrms = 0.0;
  for (auto _ : state) {
    const graybox::estimators::NStepResult r =
        NStepNrmsSimulated(model, y, u, model.ParameterValues(), 0.004, options);
    nrms = r.nrms;
    evaluation = r.evaluation;
    benchmark::DoNotOptimize(nrms);
  }
  state.counters["nrms"] = nrms;
  state.counters["starts"] = 15000 - 1 - 150 + 1;
  state.SetLabel(evaluation);
}
BENCHMARK(BM_Nrms150_RoblueTest)
    ->ArgsProduct({{1, 2}, {0, 1}})
    ->Unit(benchmark::kSecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
