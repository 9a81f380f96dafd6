// Inputs between samples (hold = "foh" in a [[data]] input mapping, docs/problem-format.md): the
// input is linear between its samples with every integrator and formulation, which the order of
// accuracy on a smooth input shows (second order against the zero-order hold's first), and a fit
// of a known gain reproduces the data to the solver's tolerance with it where the zero-order hold
// leaves a 10 % error and a biased gain.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "graybox/estimators/fit/fit.h"
#include "graybox/estimators/problem/problem_file.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::ScratchDir;
using apps_testing::WriteText;

// y' = k u, u = sin(w t), y(0) = 0: y = k (1 - cos(w t)) / w.
constexpr double kGain = 2.0;
constexpr double kOmega = 2.0;     // rad/s
constexpr double kDuration = 6.0;  // s

std::string Csv(double dt) {
  std::ostringstream csv;
  csv << "time,u,y\n";
  char line[160];
  const int n = static_cast<int>(std::lround(kDuration / dt));
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g\n", t, std::sin(kOmega * t),
                  kGain * (1.0 - std::cos(kOmega * t)) / kOmega);
    csv << line;
  }
  return csv.str();
}

// The gain and the integrator; `hold` is the input mapping's hold, `estimation` the section.
std::string Problem(const std::string& hold, const std::string& estimation, double k_start) {
  return "[problem]\nname = \"hold\"\n"
         "[model]\ninputs = [{ name = \"u\", unit = \"V\", min = -1.0, max = 1.0 }]\n"
         "outputs = [\"int.y\"]\n"
         "[[model.blocks]]\ninstance = \"g\"\ntype = \"signal.gain\"\n"
         "options = { input_unit = \"V\", output_unit = \"V\" }\n"
         "inputs = [\"u\"]\noutputs = [\"v\"]\n"
         "[[model.blocks]]\ninstance = \"int\"\ntype = \"signal.integrator\"\n"
         "options = { input_unit = \"V\", output_unit = \"V s\" }\ninputs = [\"v\"]\n"
         "[model.parameters]\n\"g.k\" = { value = " +
         std::to_string(k_start) +
         ", lower = 0.0, upper = 10.0 }\n"
         "[[data]]\nname = \"d\"\nfile = \"d.csv\"\ntime = \"time\"\n"
         "inputs = { u = { variable = \"u\", hold = \"" +
         hold +
         "\" } }\noutputs = { \"int.y\" = \"y\" }\n"
         "initial_state = { \"int.y\" = 0.0 }\n" +
         estimation;
}

// Largest simulation error of the true model on the record sampled at dt.
double SimulationError(const ScratchDir& dir, const std::string& hold, const std::string& method,
                       double dt) {
  WriteText(dir / "d.csv", Csv(dt));
  // Fixed-step schemes with 20 substeps, CVODES at tight tolerances: the integrators' own errors
  // stay well below the holds'.
  const std::string estimation =
      method == "cvodes"
          ? "[estimation]\nmethod = \"single_shooting\"\nsolver = \"ipopt\"\n"
            "[estimation.integrator]\nmethod = \"cvodes\"\nrelative_tolerance = 1e-10\n"
            "absolute_tolerance = 1e-12\n"
          : "[estimation]\nmethod = \"single_shooting\"\nsolver = \"ipopt\"\nscheme = \"" + method +
                "\"\nsubsteps = 20\n";
  WriteText(dir / "p.toml", Problem(hold, estimation, kGain));
  const estimators::Problem p = LoadProblem(dir / "p.toml");
  const std::vector<SplitData> splits = LoadData(p);
  const std::vector<SplitEvaluation> ev = Simulate(p, splits, p.built.ParameterValues(), {});
  return (ev[0].simulated - ev[0].measured).cwiseAbs().maxCoeff();
}

TEST(FirstOrderHold, SecondOrderAccurateWithEveryIntegrator) {
  ScratchDir dir;
  constexpr double kCoarse = 0.1, kFine = 0.05;  // s
  // Halving the sample time: the zero-order hold's error halves (first order), the first-order
  // hold's quarters (second order). The ratios' tolerances leave room for the integrators' own
  // errors (RK4 with its substeps is far more accurate than either hold).
  constexpr double kFirstOrderMin = 1.8, kFirstOrderMax = 2.2;
  constexpr double kSecondOrderMin = 3.6;
  for (const std::string method : {"rk4", "backward_euler", "trapezoidal", "radau_iia", "cvodes"}) {
    SCOPED_TRACE(method);
    const double zoh = SimulationError(dir, "zoh", method, kCoarse);
    const double zoh_fine = SimulationError(dir, "zoh", method, kFine);
    const double foh = SimulationError(dir, "foh", method, kCoarse);
    const double foh_fine = SimulationError(dir, "foh", method, kFine);
    std::printf("%-15s zoh %.3g -> %.3g (x%.2f), foh %.3g -> %.3g (x%.2f)\n", method.c_str(), zoh,
                zoh_fine, zoh / zoh_fine, foh, foh_fine, foh / foh_fine);
    if (method == "rk4" || method == "cvodes") {
      EXPECT_GT(zoh / zoh_fine, kFirstOrderMin);
      EXPECT_LT(zoh / zoh_fine, kFirstOrderMax);
      EXPECT_GT(foh / foh_fine, kSecondOrderMin);
    }
    // Every integrator: the first-order hold is the more accurate by far at the coarse step.
    EXPECT_LT(foh, 0.2 * zoh);
  }
}

TEST(FirstOrderHold, AFitIsExactToTheInterpolationInEveryFormulation) {
  ScratchDir dir;
  constexpr double kDt = 0.1;
  WriteText(dir / "d.csv", Csv(kDt));
  // The first-order hold integrates the linear interpolation of the sampled sine, which is the
  // trapezoidal rule: exactly the true integral times c = x cot(x), x = w dt / 2 (for a sinusoid
  // the rule's error is a pure gain). So the fit reproduces the data exactly with the gain
  // kGain / c (0.33 % above kGain at dt = 0.1 s): the O(dt^2) of linear interpolation, nothing
  // else. The zero-order hold's left sums add a half-sample phase lag no gain can fit.
  const double x = 0.5 * kOmega * kDt;
  const double expected_foh_gain = kGain / (x / std::tan(x));
  constexpr double kSolverTolerance = 1e-6;  // relative, Ipopt's tolerance on noise-free data
  constexpr double kNrmseRatio = 1e3;        // foh's NRMSE at least this much smaller
  const std::vector<std::pair<std::string, std::string>> methods = {
      {"multiple shooting",
       "[estimation]\nmethod = \"multiple_shooting\"\nsolver = \"ipopt\"\n"
       "[estimation.multiple_shooting]\nsegment_length = 10\nfix_initial_state = true\n"},
      {"single shooting", "[estimation]\nmethod = \"single_shooting\"\nsolver = \"ipopt\"\n"},
      {"collocation", "[estimation]\nmethod = \"collocation\"\nsolver = \"ipopt\"\n"},
      {"n-step",
       "[estimation]\nmethod = \"n_step\"\nsolver = \"ipopt\"\n"
       "[estimation.n_step]\nsteps = 10\n"}};
  for (const auto& [name, estimation] : methods) {
    SCOPED_TRACE(name);
    double k[2], nrmse[2];
    int i = 0;
    for (const std::string hold : {"zoh", "foh"}) {
      WriteText(dir / "p.toml", Problem(hold, estimation, 1.0));
      const estimators::Problem p = LoadProblem(dir / "p.toml");
      FitOptions o;
      o.compute_covariance = false;
      const FitResult fit = Fit(p, LoadData(p), o);
      ASSERT_TRUE(fit.solver_result.success) << fit.BriefReport();
      k[i] = fit.Parameter("g.k").value;
      nrmse[i] = fit.evaluations.at(0).simulation.overall.nrmse;
      ++i;
    }
    std::printf("%-18s zoh: k %.6f NRMSE %.3g;  foh: k %.6f NRMSE %.3g\n", name.c_str(), k[0],
                nrmse[0], k[1], nrmse[1]);
    EXPECT_NEAR(k[1], expected_foh_gain, kSolverTolerance * kGain);
    EXPECT_LT(kNrmseRatio * nrmse[1], nrmse[0]);
  }
}

// Equation error evaluates the model at the samples, where both holds give the same input: the
// first-order hold's state is read from the input's samples, and the fit is the zero-order hold's.
TEST(FirstOrderHold, EquationErrorReadsTheHoldsStateFromTheInput) {
  ScratchDir dir;
  WriteText(dir / "d.csv", Csv(0.1));
  const std::string estimation =
      "[estimation]\nmethod = \"equation_error\"\nsolver = \"ipopt\"\n"
      "[estimation.equation_error]\nform = \"state_derivative\"\n";
  double k[2];
  int i = 0;
  for (const std::string hold : {"zoh", "foh"}) {
    WriteText(dir / "p.toml", Problem(hold, estimation, 1.0));
    const estimators::Problem p = LoadProblem(dir / "p.toml");
    if (hold == "foh") {
      EXPECT_EQ(p.estimation.equation_error.residual_states, std::vector<std::string>{"int.y"});
      EXPECT_EQ(p.estimation.equation_error.from_inputs.at("u_foh.y"), "u");
    }
    FitOptions o;
    o.compute_covariance = false;
    const FitResult fit = Fit(p, LoadData(p), o);
    ASSERT_TRUE(fit.solver_result.success) << fit.BriefReport();
    k[i++] = fit.Parameter("g.k").value;
  }
  constexpr double kSame = 1e-9;  // relative; the same residuals up to rounding
  EXPECT_NEAR(k[1], k[0], kSame * kGain);
}

TEST(FirstOrderHold, TheHoldIsCheckedWhereItIsWritten) {
  ScratchDir dir;
  WriteText(dir / "d.csv", Csv(0.1));
  const std::string text = Problem("foh", "[estimation]\nmethod = \"single_shooting\"\n", 2.0);
  auto error_of = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    WriteText(dir / "bad.toml", t);
    try {
      LoadProblem(dir / "bad.toml");
    } catch (const ProblemFileError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error_of("hold = \"foh\"", "hold = \"fho\"").find("did you mean 'foh'"),
            std::string::npos);
  EXPECT_NE(error_of("hold = \"foh\"", "hold = \"foh\", rate = true").find("of a rate signal"),
            std::string::npos);
  EXPECT_NE(error_of("\"int.y\" = \"y\"", "\"int.y\" = { variable = \"y\", hold = \"foh\" }")
                .find("applies to inputs"),
            std::string::npos);
  // The problem as written: the hold block, its rate input and its held initial state.
  WriteText(dir / "p.toml", text);
  const estimators::Problem p = LoadProblem(dir / "p.toml");
  EXPECT_GE(p.built.StateIndex("u_foh.y"), 0);
  EXPECT_EQ(p.built.NumInputs(), 2);
  const std::vector<SplitData> splits = LoadData(p);
  EXPECT_EQ(splits[0].experiment.u.cols(), 2);
  EXPECT_EQ(splits[0].setup.x0[p.built.StateIndex("u_foh.y")], 0.0);  // u[0] = sin(0)
  EXPECT_EQ(splits[0].setup.x0_free[p.built.StateIndex("u_foh.y")], kInitialStateFixed);
}

}  // namespace
}  // namespace graybox::estimators
