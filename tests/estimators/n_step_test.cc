// The batched, threaded N-step evaluator gives exactly the eta_N of the sequential definition,
// and reproduces the roblue KUKA data (simulated by the same model) to its float32 floor.
#include <gtest/gtest.h>

#include <cmath>

#include "graybox/estimators/integrators.h"
#include "graybox/estimators/mat_file.h"
#include "graybox/estimators/n_step.h"
#include "graybox/models/model.h"
#include "graybox/models/robot_blocks.h"

namespace graybox::estimators {
namespace {

// KUKA model with the roblue parameters: states q1..q6, qd1..qd6, inputs tau_m1..tau_m6.
models::StateSpaceModel KukaModel() {
  models::Model m("kuka");
  std::vector<std::string> inputs;
  for (int i = 1; i <= 6; ++i) {
    m.AddInput("tau_m" + std::to_string(i), "N m");
    inputs.push_back("tau_m" + std::to_string(i));
  }
  models::KukaBlockOptions options;
  options.inertial_parameters = false;
  m.AddBlock("robot", models::MakeKukaKr300Block(options), inputs, {});
  for (int i = 1; i <= 6; ++i) m.AddOutput("robot.q" + std::to_string(i));
  return m.Build();
}

TEST(NStep, BatchedThreadedEqualsSequentialDefinition) {
  const models::StateSpaceModel model = KukaModel();
  const int n = 400;
  Eigen::MatrixXd u(n, 6), x(n, 12);
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < 6; ++j) u(k, j) = 2.0 * std::sin(0.01 * k * (j + 1));
  }
  const Eigen::VectorXd p = model.ParameterValues();
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(12);
  x = SimulateRk4(model, x0, u, p, 0.004).x;
  // Perturb the "measurement" so the errors are not zero.
  for (int k = 0; k < n; ++k) x(k, k % 12) += 1e-4 * std::cos(0.3 * k);
  NStepSimulationOptions options;
  options.scoring.steps = 20;
  options.chunk = 37;  // several chunks, uneven last chunk, both threads busy
  options.num_threads = 2;
  const NStepResult batched = NStepNrmsSimulated(model, x, u, p, 0.004, options);
  const expr::Function step = MakeStepFunction(model, 0.004);
  const NStepResult sequential = NStepNrms(
      x,
      [&](int start, const Eigen::VectorXd& state, int steps) {
        // Predictions for samples start + 1 .. start + steps, one RK4 step at a time.
        Eigen::MatrixXd out(steps, 12);
        Eigen::VectorXd xs = state;
        for (int k = 0; k < steps; ++k) {
          xs = step({xs, u.row(start + k).transpose(), p})[0];
          out.row(k) = xs.transpose();
        }
        return out;
      },
      options.scoring);
  ASSERT_EQ(batched.starts.size(), sequential.starts.size());
  constexpr double kSameArithmetic = 1e-12;  // identical steps; sums combined in another order
  EXPECT_NEAR(batched.nrms, sequential.nrms, kSameArithmetic * sequential.nrms);
  for (Eigen::Index s = 0; s < batched.step_nrms.size(); ++s) {
    EXPECT_NEAR(batched.step_nrms[s], sequential.step_nrms[s], kSameArithmetic * sequential.nrms);
  }
  EXPECT_GT(batched.nrms, 0.0);
}

TEST(NStep, RoblueKukaDataIsReproducedToItsPrecision) {
  const std::string file =
      std::string(GRAYBOX_SHARED_DATA_DIR) + "/roblue_elabee/elabee_robot_ftsd.mat";
  MatFile mat(file);
  const Eigen::MatrixXd u = mat.ReadMatrix("u_test"), y = mat.ReadMatrix("y_test");
  const models::StateSpaceModel model = KukaModel();
  NStepSimulationOptions options;
  options.scoring.steps = 150;
  options.scoring.stride = 10;                    // every 10th start keeps the test fast
  options.scoring.channels = {0, 1, 2, 3, 4, 5};  // positions, as seed 000 eq. 7
  const NStepResult r = NStepNrmsSimulated(model, y, u, model.ParameterValues(), 0.004, options);
  // The file holds float32 values of a simulation of this very model (models/kuka_kr300.h).
  constexpr double kFloat32Floor = 1e-5;
  EXPECT_LT(r.nrms, kFloat32Floor) << r.BriefReport();
  EXPECT_EQ(r.starts.size(), static_cast<std::size_t>((15000 - 1 - 150) / 10 + 1));
}

}  // namespace
}  // namespace graybox::estimators
