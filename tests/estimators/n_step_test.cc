// The batched, threaded N-step evaluator gives exactly the eta_N of the sequential definition,
// scores the selected states (named in the result), and reproduces the roblue KUKA data
// (simulated by the same model) to its float32 floor; [metrics] n_step_channels of a problem
// file selects those states by name, by default the measured ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "graybox/estimators/analysis/n_step.h"
#include "graybox/estimators/data/mat_file.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/problem/problem_file.h"
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
  // The generated code (the default where a compiler is) and the batched tape give the same
  // numbers; the result says which ran.
  EXPECT_EQ(batched.evaluation, "generated code");
  options.generated_code = false;
  const NStepResult tape = NStepNrmsSimulated(model, x, u, p, 0.004, options);
  EXPECT_EQ(tape.evaluation, "tape: generated code not asked for (generated_code = false)");
  EXPECT_NEAR(tape.nrms, batched.nrms, kSameArithmetic * tape.nrms);
  for (Eigen::Index s = 0; s < tape.step_nrms.size(); ++s) {
    EXPECT_NEAR(tape.step_nrms[s], batched.step_nrms[s], kSameArithmetic * tape.nrms);
  }
  // Without a compiler: the tape, and why.
  options.generated_code = true;
  options.jit.compiler = "/nonexistent/cc";
  const NStepResult fallback = NStepNrmsSimulated(model, x, u, p, 0.004, options);
  EXPECT_EQ(fallback.evaluation.rfind("tape: no generated code: ", 0), 0u) << fallback.evaluation;
  EXPECT_NEAR(fallback.nrms, tape.nrms, kSameArithmetic * tape.nrms);
}

// A mass pushed against viscous friction (states load.q, load.qd; input force) with the given
// model outputs (each mapped onto a data column) and [metrics] table. The data are not read.
std::string PushedMass(const std::vector<std::string>& outputs, const std::string& metrics) {
  std::string declared, mapped;
  for (const std::string& o : outputs) {
    declared += (declared.empty() ? "\"" : ", \"") + o + "\"";
    mapped += (mapped.empty() ? "\"" : ", \"") + o + "\" = \"" + o + "\"";
  }
  return "[problem]\n"
         "name = \"pushed\"\n"
         "[model]\n"
         "inputs = [{ name = \"force\", unit = \"N\" }]\n"
         "outputs = [" +
         declared +
         "]\n"
         "[[model.blocks]]\n"
         "instance = \"load\"\n"
         "type = \"mechanics.mass\"\n"
         "inputs = [\"force\"]\n"
         "[[model.blocks]]\n"
         "instance = \"friction\"\n"
         "type = \"friction.viscous\"\n"
         "options = { motion = \"prismatic\" }\n"
         "inputs = [\"load.qd\"]\n"
         "outputs = [\"-force\"]\n"
         "[[model.blocks]]\n"
         "instance = \"sensor\"\n"
         "type = \"signal.gain\"\n"
         "inputs = [\"load.q\"]\n"
         "outputs = [\"encoder\"]\n"
         "[[data]]\n"
         "name = \"pushed\"\n"
         "file = \"pushed.csv\"\n"
         "time = \"time\"\n"
         "inputs = { force = \"force\" }\n"
         "outputs = { " +
         mapped +
         " }\n"
         "splits = [{ name = \"all\", role = \"estimation\" }]\n"
         "initial_state = { \"load.q\" = 0.0, \"load.qd\" = 0.0 }\n"
         "[estimation]\n"
         "method = \"single_shooting\"\n"
         "[metrics]\n" +
         metrics;
}

std::string LoadError(const std::string& text) {
  try {
    ParseProblem(text, "pushed.toml");
  } catch (const ProblemFileError& e) {
    return e.what();
  }
  return "";
}

TEST(NStepChannels, ProblemFileDefaultsToTheMeasuredStates) {
  // load.q is a model output (measured), load.qd is not: only load.q is scored.
  const Problem measured = ParseProblem(PushedMass({"load.q"}, "n_step = 20\n"), "pushed.toml");
  EXPECT_EQ(measured.metrics.n_step_channels, (std::vector<std::string>{"load.q"}));
  EXPECT_EQ(measured.metrics.n_step_channel_indices,
            (std::vector<int>{measured.built.StateIndex("load.q")}));
  EXPECT_FALSE(measured.metrics.n_step_channels_given);
  // Both measured: both, in state order whatever the output order.
  const Problem both =
      ParseProblem(PushedMass({"load.qd", "load.q"}, "n_step = 20\n"), "pushed.toml");
  EXPECT_EQ(both.metrics.n_step_channel_indices, (std::vector<int>{0, 1}));
  // No state is an output (only a sensor signal computed from q): every state.
  const Problem none = ParseProblem(PushedMass({"encoder"}, ""), "pushed.toml");
  EXPECT_EQ(none.metrics.n_step_channels, (std::vector<std::string>{"load.q", "load.qd"}));
  // Given in the file: exactly those, in the file's order.
  const Problem given = ParseProblem(
      PushedMass({"load.q"}, "n_step = 20\nn_step_channels = [\"load.qd\", \"load.q\"]\n"),
      "pushed.toml");
  EXPECT_EQ(given.metrics.n_step_channels, (std::vector<std::string>{"load.qd", "load.q"}));
  EXPECT_EQ(
      given.metrics.n_step_channel_indices,
      (std::vector<int>{given.built.StateIndex("load.qd"), given.built.StateIndex("load.q")}));
  EXPECT_TRUE(given.metrics.n_step_channels_given);
}

TEST(NStepChannels, ProblemFileErrorsNameTheLineAndSuggest) {
  // The message starts with the file and the line of the unknown name.
  const std::string text =
      PushedMass({"load.q"}, "n_step = 20\n\nn_step_channels = [\"load.q\", \"load.qdd\"]\n");
  const std::string before = text.substr(0, text.find("load.qdd"));
  const int line = 1 + static_cast<int>(std::count(before.begin(), before.end(), '\n'));
  const std::string unknown = LoadError(text);
  EXPECT_NE(unknown.find("pushed.toml:" + std::to_string(line) + ":"), std::string::npos)
      << unknown;
  EXPECT_NE(unknown.find("'load.qdd' is not a model state; did you mean 'load.qd'?"),
            std::string::npos)
      << unknown;
  const std::string twice = LoadError(
      PushedMass({"load.q"}, "n_step = 20\nn_step_channels = [\"load.q\", \"load.q\"]\n"));
  EXPECT_NE(twice.find("expected distinct states, got 'load.q' twice"), std::string::npos) << twice;
  const std::string empty =
      LoadError(PushedMass({"load.q"}, "n_step = 20\nn_step_channels = []\n"));
  EXPECT_NE(empty.find("expected at least one model state"), std::string::npos) << empty;
  const std::string off = LoadError(PushedMass({"load.q"}, "n_step_channels = [\"load.q\"]\n"));
  EXPECT_NE(off.find("expected 'n_step' > 0 in [metrics], got n_step = 0"), std::string::npos)
      << off;
  const std::string typo = LoadError(PushedMass({"load.q"}, "n_step = 20\nn_step_channel = []\n"));
  EXPECT_NE(typo.find("did you mean 'n_step_channels'?"), std::string::npos) << typo;
}

TEST(NStepChannels, SimulatedScoresTheProblemsChannelsByName) {
  const Problem problem = ParseProblem(PushedMass({"load.q"}, "n_step = 20\n"), "pushed.toml");
  const models::StateSpaceModel& model = problem.built;
  const int n = 300;
  const double dt = 0.01;
  Eigen::MatrixXd u(n, 1);
  for (int k = 0; k < n; ++k) u(k, 0) = std::sin(0.05 * k) + 0.3 * std::sin(0.31 * k);
  const Eigen::VectorXd p = model.ParameterValues();
  Eigen::MatrixXd x = SimulateRk4(model, Eigen::VectorXd::Zero(2), u, p, dt).x;
  // A "measurement" off the model on both states, so that every channel scores above zero.
  for (int k = 0; k < n; ++k) {
    x(k, 0) += 1e-3 * std::cos(0.2 * k);
    x(k, 1) += 2e-2 * std::sin(0.37 * k);
  }
  NStepSimulationOptions options;
  options.scoring.steps = problem.metrics.n_step;
  options.num_threads = 1;
  const NStepResult all = NStepNrmsSimulated(model, x, u, p, dt, options);
  EXPECT_EQ(all.channel_names, (std::vector<std::string>{"load.q", "load.qd"}));
  options.scoring.channels = problem.metrics.n_step_channel_indices;
  const NStepResult measured = NStepNrmsSimulated(model, x, u, p, dt, options);
  EXPECT_EQ(measured.channel_names, (std::vector<std::string>{"load.q"}));
  // Scoring a subset is exactly the mean over that subset of the per-channel values.
  constexpr double kSameArithmetic = 1e-12;  // identical simulations, sums in another grouping
  const int q = model.StateIndex("load.q");
  EXPECT_NEAR(measured.nrms, all.channel_nrms(q), kSameArithmetic * all.channel_nrms(q));
  EXPECT_NEAR(
      all.nrms * all.nrms,
      0.5 * (all.channel_nrms(0) * all.channel_nrms(0) + all.channel_nrms(1) * all.channel_nrms(1)),
      kSameArithmetic * all.nrms * all.nrms);
  EXPECT_GT(all.nrms, 2.0 * measured.nrms);  // the noisier velocity dominates when scored

  // Bad selections are caught before anything is simulated.
  options.scoring.channels = {0, 2};
  try {
    NStepNrmsSimulated(model, x, u, p, dt, options);
    ADD_FAILURE() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "expected distinct state indices in [0, 2) in scoring.channels, got 2"),
              std::string::npos)
        << e.what();
  }
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
  EXPECT_EQ(r.channel_names, (std::vector<std::string>{"robot.q1", "robot.q2", "robot.q3",
                                                       "robot.q4", "robot.q5", "robot.q6"}));
  EXPECT_EQ(r.starts.size(), static_cast<std::size_t>((15000 - 1 - 150) / 10 + 1));
}

}  // namespace
}  // namespace graybox::estimators
