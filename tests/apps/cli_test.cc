// The `graybox` executable end to end: exit codes 0 / 2 / 3, result.json of the shipped EMPS
// IDIM-LS problem against the published values, the closed-loop problem against IDIM-LS, a
// generated problem whose parameters are known, `simulate` with a result.json, and that a
// bad-input run leaves an existing output directory untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "test_util.h"

namespace graybox::apps_testing {
namespace {

using Json = nlohmann::json;

const std::string kEmpsDir = std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps";
const std::string kEmpsData = std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat";
bool HaveEmps() { return fs::exists(kEmpsData); }

// Published IDIM-LS values (../shared/data/emps/SOURCE.md, EMPS_Description.pdf).
constexpr double kPublishedMass = 95.1089;      // kg
constexpr double kPublishedViscous = 203.5034;  // N s/m
constexpr double kPublishedCoulomb = 20.3935;   // N
constexpr double kPublishedOffset = -3.1648;    // N
constexpr double kPublishedMassStd = 0.1085;    // kg
// The task's acceptance band. The recipe reproduced here matches to ~1e-5 relative; 2 % is the
// band the benchmark's own sensitivity study (cut-offs 75-200 Hz, orders 2-8, decimation 1-20
// within 0.8 %) leaves for honest variations of the recipe.
constexpr double kPublishedTolerance = 0.02;
// Published relative errors (direct validation and cross-test on the pulses record), given to
// 3 digits: half a unit of the last digit plus the tolerance on the parameters' effect (0.1).
constexpr double kPublishedRelativeError = 4.08;   // %
constexpr double kPublishedCrossTestError = 5.98;  // %
constexpr double kRelativeErrorTolerance = 0.1;    // percentage points
// Multiple shooting of the closed loop against IDIM-LS: a different model of the same stage
// (continuous controller, smoothed Coulomb friction, output error on position and command), so
// agreement within 3 % is what the closed loop determines (problems/emps/README.md: 1.4 % on M).
constexpr double kClosedLoopTolerance = 0.03;
// The generated problem is simulated exactly by the closed form; the RK4 model at dt = 10 ms
// with T = m / fv = 0.5 s has a discretisation error ~(dt/T)^4 / 120 ~ 1e-9, so the noise-free
// fit recovers the parameters to ~1e-6 relative; 1e-4 leaves margin for the solver tolerance.
constexpr double kRecoveryTolerance = 1e-4;

Json ReadJson(const std::string& path) { return Json::parse(ReadText(path)); }

double Value(const Json& result, const std::string& name) {
  return result["parameters"][name]["value"].get<double>();
}

TEST(Cli, EmpsIdimReproducesThePublishedValues) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data at " << kEmpsData;
  ScratchDir dir;
  const RunResult r = RunGraybox(
      "fit '" + kEmpsDir + "/emps_idim.toml' --out '" + (dir / "out") + "'", dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir / "out/result.json");
  EXPECT_EQ(result["status"]["result"], "success");
  EXPECT_EQ(result["status"]["exit_code"], 0);
  EXPECT_TRUE(result["status"]["solver_success"].get<bool>());
  EXPECT_EQ(result["method"], "equation_error");
  EXPECT_EQ(result["seed"], 1);
  EXPECT_FALSE(result["graybox"]["git_revision"].get<std::string>().empty());
  EXPECT_EQ(result["formulation"]["samples"], "2480");
  const struct {
    const char* name;
    double published;
  } expected[] = {{"load.mass", kPublishedMass},
                  {"viscous.fv", kPublishedViscous},
                  {"coulomb.fc", kPublishedCoulomb},
                  {"offset.f_asym", kPublishedOffset}};
  for (const auto& e : expected) {
    EXPECT_NEAR(Value(result, e.name), e.published, kPublishedTolerance * std::fabs(e.published))
        << e.name;
    const Json& p = result["parameters"][e.name];
    ASSERT_TRUE(p["ci95"].is_array()) << e.name;
    EXPECT_LT(p["ci95"][0].get<double>(), p["value"].get<double>());
    EXPECT_GT(p["ci95"][1].get<double>(), p["value"].get<double>());
  }
  EXPECT_NEAR(result["parameters"]["load.mass"]["std_error"].get<double>(), kPublishedMassStd,
              kPublishedTolerance * kPublishedMassStd);
  const Json& metrics = result["metrics"];
  EXPECT_NEAR(metrics["estimation"]["equation"]["channels"]["force"]["relative_error_percent"]
                  .get<double>(),
              kPublishedRelativeError, kRelativeErrorTolerance);
  EXPECT_NEAR(metrics["test_pulses"]["equation"]["channels"]["force"]["relative_error_percent"]
                  .get<double>(),
              kPublishedCrossTestError, kRelativeErrorTolerance);
  EXPECT_EQ(metrics["test_pulses"]["role"], "test");
  EXPECT_TRUE(metrics["estimation"]["simulation"]["ok"].get<bool>());
  for (const char* plot : {"plots/estimation_outputs.svg", "plots/estimation_residuals.svg",
                           "plots/estimation_equation.svg", "plots/test_pulses_outputs.svg",
                           "traces/estimation.csv"}) {
    EXPECT_TRUE(fs::exists(dir / ("out/" + std::string(plot)))) << plot;
  }
  EXPECT_EQ(ReadText(dir / "out/plots/estimation_outputs.svg").rfind("<?xml", 0), 0u);
}

TEST(Cli, BlocksListsTheTypesAndDescribesOne) {
  ScratchDir dir;
  const RunResult list = RunGraybox("blocks", dir / "list.log");
  EXPECT_EQ(list.exit_code, 0) << list.output;
  EXPECT_NE(list.output.find("friction.coulomb "), std::string::npos) << list.output;
  const RunResult one =
      RunGraybox("blocks friction.coulomb --option steepness=250", dir / "one.log");
  EXPECT_EQ(one.exit_code, 0) << one.output;
  EXPECT_NE(one.output.find("tau = (fc*tanh((qd*250)))"), std::string::npos) << one.output;
  const RunResult typo = RunGraybox("blocks friction.colomb", dir / "typo.log");
  EXPECT_EQ(typo.exit_code, 2) << typo.output;  // bad input
  EXPECT_NE(typo.output.find("did you mean 'friction.coulomb'"), std::string::npos) << typo.output;
}

TEST(Cli, AMistypedCommandIsNamedWithTheClosestOne) {
  ScratchDir dir;
  const RunResult typo = RunGraybox("fitt x.toml", dir / "typo.log");
  EXPECT_EQ(typo.exit_code, 2) << typo.output;  // bad input
  EXPECT_NE(typo.output.find("unknown command 'fitt'; did you mean 'fit'?"), std::string::npos)
      << typo.output;
  const RunResult none = RunGraybox("", dir / "none.log");
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_NE(none.output.find("subcommand is required"), std::string::npos) << none.output;
  EXPECT_EQ(RunGraybox("--version", dir / "version.log").exit_code, 0);
}

TEST(Cli, EmpsClosedLoopAgreesWithIdim) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data";
  ScratchDir dir;
  const RunResult r =
      RunGraybox("fit '" + kEmpsDir + "/emps_closed_loop.toml' --out '" + (dir / "out") + "'",
                 dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir / "out/result.json");
  EXPECT_EQ(result["solver"], "ipopt");
  EXPECT_NEAR(Value(result, "load.mass"), kPublishedMass, kClosedLoopTolerance * kPublishedMass);
  EXPECT_NEAR(Value(result, "viscous.fv"), kPublishedViscous,
              kClosedLoopTolerance * kPublishedViscous);
  EXPECT_NEAR(Value(result, "coulomb.fc"), kPublishedCoulomb,
              kClosedLoopTolerance * kPublishedCoulomb);
  EXPECT_NEAR(Value(result, "offset.f_asym"), kPublishedOffset,
              kClosedLoopTolerance * std::fabs(kPublishedOffset));
  EXPECT_FALSE(result["parameters"]["controller.kp"]["free"].get<bool>());
  EXPECT_EQ(Value(result, "controller.kp"), 160.18);
}

// Ceres with continuity residuals (weight 1e7) and Ipopt with continuity constraints solve the
// same closed-loop problem: 4-5 digits agree (problems/emps/README.md).
TEST(Cli, EmpsClosedLoopOnCeresAgreesWithIpopt) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data";
  ScratchDir dir;
  const RunResult ipopt =
      RunGraybox("fit '" + kEmpsDir + "/emps_closed_loop.toml' --out '" + (dir / "ipopt") + "'",
                 dir / "log_ipopt.txt");
  const RunResult ceres = RunGraybox(
      "fit '" + kEmpsDir + "/emps_closed_loop_ceres.toml' --out '" + (dir / "ceres") + "'",
      dir / "log_ceres.txt");
  ASSERT_EQ(ipopt.exit_code, 0) << ipopt.output;
  ASSERT_EQ(ceres.exit_code, 0) << ceres.output;
  const Json a = ReadJson(dir / "ipopt/result.json");
  const Json b = ReadJson(dir / "ceres/result.json");
  EXPECT_EQ(b["solver"], "ceres");
  constexpr double kSolverAgreement = 1e-3;  // penalty 1e7 vs exact continuity
  for (const char* name : {"load.mass", "viscous.fv", "coulomb.fc", "offset.f_asym"}) {
    EXPECT_NEAR(Value(b, name), Value(a, name), kSolverAgreement * std::fabs(Value(a, name)))
        << name;
  }
}

// The physics augmented by a friction network with weight decay (emps_closed_loop_mlp.toml): on
// the held-out pulses file the command's relative error must fall below the physics-only model's
// (10.15 %, problems/emps/README.md; measured 9.82 % with the network), the position stays at the
// physics-only level, and the physical parameters stay identifiable (the decay keeps the network
// from absorbing the viscous term: Fv 145 N s/m with a 0.6 % standard error).
constexpr double kPhysicsOnlyPulsesCommandError = 10.0;    // %, below physics-only 10.15 %
constexpr double kPhysicsOnlyPulsesPositionError = 0.003;  // %, physics-only 0.0028 %
constexpr double kIdentifiableRelativeStd = 0.05;

TEST(Cli, EmpsFrictionNetworkWithWeightDecayImprovesTheHeldOutRecord) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data";
  ScratchDir dir;
  const RunResult r =
      RunGraybox("fit '" + kEmpsDir + "/emps_closed_loop_mlp.toml' --out '" + (dir / "out") + "'",
                 dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir / "out/result.json");
  EXPECT_TRUE(result["formulation"].contains("regularization.weight_decay"));
  const Json& pulses = result["metrics"]["test_pulses"]["simulation"]["channels"];
  EXPECT_LT(pulses["nu"]["relative_error_percent"].get<double>(), kPhysicsOnlyPulsesCommandError);
  EXPECT_LT(pulses["load.q"]["relative_error_percent"].get<double>(),
            kPhysicsOnlyPulsesPositionError);
  for (const char* name : {"load.mass", "viscous.fv", "coulomb.fc"}) {
    const Json& p = result["parameters"][name];
    EXPECT_LT(p["std_error"].get<double>(), kIdentifiableRelativeStd * p["value"].get<double>())
        << name;
  }
}

class GeneratedCli : public ::testing::Test {
 protected:
  void SetUp() override { WriteText(dir_ / "pushed.csv", PushedCsv()); }
  RunResult Fit(const std::string& problem_text, const std::string& out = "out",
                const std::string& flags = "") {
    WriteText(dir_ / "pushed.toml", problem_text);
    return RunGraybox("fit pushed.toml --out " + out + " " + flags, dir_ / "log.txt",
                      dir_.path().string());
  }
  ScratchDir dir_;
};

TEST_F(GeneratedCli, CheckPrintsTheDiagnosisAxesAndRejectsAnUnknownEffect) {
  WriteText(dir_ / "pushed.toml", PushedProblem() +
                                      "[diagnosis]\n"
                                      "effects = [\"coulomb\", \"ripple\"]\n"
                                      "remove_effects = [\"ripple\"]\n");
  const RunResult ok = RunGraybox("check pushed.toml", dir_ / "ok.log", dir_.path().string());
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("diagnosis axis: velocity load.qd, force -force, position load.q, "
                           "actuators force"),
            std::string::npos)
      << ok.output;
  EXPECT_NE(ok.output.find("diagnosis effects: coulomb\n"), std::string::npos) << ok.output;
  WriteText(dir_ / "pushed.toml", PushedProblem() + "[diagnosis]\neffects = [\"colomb\"]\n");
  const RunResult bad = RunGraybox("check pushed.toml", dir_ / "bad.log", dir_.path().string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;  // bad input, with the place
  EXPECT_NE(bad.output.find("pushed.toml:"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("'effects[0]': unknown effect 'colomb'; did you mean 'coulomb'?"),
            std::string::npos)
      << bad.output;
}

// A friction block subtracting from a misspelt signal would be disconnected silently: check and
// fit refuse it with the place, the block, the signal and the closest signal that is read.
TEST_F(GeneratedCli, ATypoInAConnectionIsAnErrorNotADisconnectedBlock) {
  std::string text = PushedProblem();
  const std::string right = "outputs = [\"-force\"]";
  text.replace(text.find(right), right.size(), "outputs = [\"-forc\"]");
  WriteText(dir_ / "pushed.toml", text);
  for (const std::string command : {"check pushed.toml", "fit pushed.toml --out out"}) {
    const RunResult r = RunGraybox(command, dir_ / "typo.log", dir_.path().string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("pushed.toml:"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("block 'friction' output 'tau' subtracts from signal 'forc', which no "
                            "block reads and no output reports; did you mean 'force'?"),
              std::string::npos)
        << r.output;
  }
}

// An error of the formulation stage (here: a one-sample estimation split cannot determine the
// free parameters) names the problem file and its [estimation] table, as the loader's errors do.
TEST_F(GeneratedCli, AFormulationErrorNamesTheProblemFile) {
  std::string text = PushedProblem();
  const std::string split = "{ name = \"first\", role = \"estimation\", end = 150 }";
  text.replace(text.find(split), split.size(),
               "{ name = \"first\", role = \"estimation\", end = 1 }");
  const RunResult r = Fit(text);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("pushed.toml:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("[estimation] problem 'pushed': the estimation splits 'first'"),
            std::string::npos)
      << r.output;
}

TEST_F(GeneratedCli, FitRecoversKnownParametersAndSimulateReadsTheResult) {
  const RunResult r = Fit(PushedProblem(), "out", "--check-derivatives");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir_ / "out/result.json");
  EXPECT_NEAR(Value(result, "load.mass"), kTrueMass, kRecoveryTolerance * kTrueMass);
  EXPECT_NEAR(Value(result, "friction.fv"), kTrueViscous, kRecoveryTolerance * kTrueViscous);
  ASSERT_TRUE(result["derivative_checks"].is_array());
  EXPECT_FALSE(result["derivative_checks"].empty());
  for (const auto& c : result["derivative_checks"]) EXPECT_TRUE(c["ok"].get<bool>()) << c.dump();
  EXPECT_EQ(result["metrics"]["last"]["role"], "validation");
  EXPECT_TRUE(result["initial_states"].contains("first"));
  // simulate with the fitted parameters: exit 0 and the fit carried over.
  const RunResult s = RunGraybox("simulate pushed.toml --params out/result.json --out sim",
                                 dir_ / "log2.txt", dir_.path().string());
  ASSERT_EQ(s.exit_code, 0) << s.output;
  const Json sim = ReadJson(dir_ / "sim/simulation.json");
  EXPECT_EQ(Value(sim, "load.mass"), Value(result, "load.mass"));
  EXPECT_GT(sim["metrics"]["first"]["simulation"]["overall"]["fit_percent"].get<double>(), 99.0);
  // A TOML parameter file with an unknown name is bad input.
  WriteText(dir_ / "params.toml", "\"load.mas\" = 2.0\n");
  const RunResult bad = RunGraybox("simulate pushed.toml --params params.toml --out sim2",
                                   dir_ / "log3.txt", dir_.path().string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("did you mean 'load.mass'"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(dir_ / "sim2"));
  // fit --from the result: starts at the fitted values and lands on the same optimum in fewer
  // iterations than the cold fit; a starting value outside the file's bounds is bad input.
  const RunResult again = RunGraybox("fit pushed.toml --from out/result.json --out again",
                                     dir_ / "log4.txt", dir_.path().string());
  ASSERT_EQ(again.exit_code, 0) << again.output;
  const Json refit = ReadJson(dir_ / "again/result.json");
  EXPECT_EQ(refit["from"], "out/result.json");
  EXPECT_EQ(refit["parameters"]["load.mass"]["initial"].get<double>(), Value(result, "load.mass"));
  EXPECT_NEAR(Value(refit, "load.mass"), Value(result, "load.mass"),
              kRecoveryTolerance * kTrueMass);
  EXPECT_LE(refit["status"]["iterations"].get<int>(), result["status"]["iterations"].get<int>());
  WriteText(dir_ / "far.toml", "\"load.mass\" = -5.0\n");
  const RunResult far = RunGraybox("fit pushed.toml --from far.toml --out far", dir_ / "log5.txt",
                                   dir_.path().string());
  EXPECT_EQ(far.exit_code, 2) << far.output;
  EXPECT_NE(far.output.find("within the problem's bounds"), std::string::npos) << far.output;
  EXPECT_FALSE(fs::exists(dir_ / "far"));
}

// Single shooting simulates through the integrator of [estimation.integrator] (here CVODES with
// forward sensitivities) and recovers the same parameters; x0 is estimated.
TEST_F(GeneratedCli, SingleShootingThroughCvodesRecoversKnownParameters) {
  const RunResult r =
      Fit(PushedProblem("[estimation]\n"
                        "method = \"single_shooting\"\n"
                        "solver = \"ceres\"\n"
                        "[estimation.integrator]\n"
                        "method = \"cvodes\"\n"
                        "relative_tolerance = 1e-10\n"
                        "absolute_tolerance = 1e-12\n"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir_ / "out/result.json");
  EXPECT_EQ(result["formulation"]["integrator"], "cvodes");
  // CVODES integrates the continuous model the closed form solves; its tolerances, not a
  // discretisation, bound the error.
  constexpr double kCvodesRecovery = 1e-5;
  EXPECT_NEAR(Value(result, "load.mass"), kTrueMass, kCvodesRecovery * kTrueMass);
  EXPECT_NEAR(Value(result, "friction.fv"), kTrueViscous, kCvodesRecovery * kTrueViscous);
  EXPECT_TRUE(std::isfinite(result["parameters"]["load.mass"]["std_error"].get<double>()));
}

// The N-step loss from a problem file, simulated by Radau IIA: the measured velocity that starts
// every window is the central difference of the noise-free position, off by about dt^2 / 6 times
// the third derivative (~1e-4 relative), which biases the estimates by about that much; 2e-3
// leaves margin. Windows start from sample 5: at sample 0 the velocity is a one-sided difference,
// off by half a sample's acceleration (0.0075 m/s), which alone moved the mass by 1.7 %.
TEST_F(GeneratedCli, NStepLossThroughAnImplicitSchemeRecoversKnownParameters) {
  const RunResult r =
      Fit(PushedProblem("[estimation]\n"
                        "method = \"n_step\"\n"
                        "scheme = \"radau_iia\"\n"
                        "substeps = 2\n"
                        "[estimation.n_step]\n"
                        "steps = 20\n"
                        "stride = 5\n"
                        "first_start = 5\n"
                        "channels = [\"load.q\"]\n"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir_ / "out/result.json");
  EXPECT_EQ(result["formulation"]["method"], "n_step");
  EXPECT_EQ(result["formulation"]["step_scheme"], "radau_iia");
  EXPECT_EQ(result["formulation"]["starts"], "25");  // 5, 10, ..., 125 <= 149 - 20
  constexpr double kNStepRecovery = 2e-3;
  EXPECT_NEAR(Value(result, "load.mass"), kTrueMass, kNStepRecovery * kTrueMass);
  EXPECT_NEAR(Value(result, "friction.fv"), kTrueViscous, kNStepRecovery * kTrueViscous);
  EXPECT_TRUE(std::isfinite(result["parameters"]["load.mass"]["std_error"].get<double>()));
}

// A strong prior toward the initial value holds the mass there while the viscous coefficient
// still fits; the term is reported. lambda = 1e8 against a data term of order 1: the mass moves
// by about (data gradient) / (2 lambda) ~ 1e-8.
TEST_F(GeneratedCli, RegularizationTowardTheInitialValueHoldsAParameter) {
  const RunResult r =
      Fit(PushedProblem("[estimation]\n"
                        "method = \"multiple_shooting\"\n"
                        "[[estimation.regularization]]\n"
                        "name = \"prior\"\n"
                        "parameters = [\"load.*\"]\n"
                        "weight = 1e8\n"
                        "toward = \"initial\"\n"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Json result = ReadJson(dir_ / "out/result.json");
  EXPECT_TRUE(result["formulation"].contains("regularization.prior")) << result["formulation"];
  constexpr double kHeld = 1e-6;
  EXPECT_NEAR(Value(result, "load.mass"), 1.0, kHeld);
  EXPECT_GT(std::fabs(Value(result, "friction.fv") - 1.0), 0.1);  // moved from its start
}

TEST_F(GeneratedCli, BadStepRegularizationAndDifferentiationSettingsAreBadInput) {
  struct Case {
    std::string estimation, expected;
  };
  const Case cases[] = {
      {"[estimation]\nmethod = \"multiple_shooting\"\nnewton_iterations = 3\n",
       "applies to the implicit schemes only"},
      {"[estimation]\nmethod = \"multiple_shooting\"\nscheme = \"radau\"\n",
       "expected one of 'rk4', 'backward_euler', 'trapezoidal', 'radau_iia', got 'radau'"},
      {"[estimation]\nmethod = \"n_step\"\n[estimation.n_step]\nchannels = [\"load.v\"]\n",
       "'load.v' is not a model state"},
      {"[estimation]\nmethod = \"multiple_shooting\"\n[[estimation.regularization]]\n"
       "parameters = [\"net.*\"]\nweight = 1.0\n",
       "pattern 'net.*' matches no free parameter"},
      {"[estimation]\nmethod = \"multiple_shooting\"\n[[estimation.regularization]]\n"
       "parameters = [\"load.mas\"]\nweight = 1.0\n",
       "did you mean 'load.mass'"},
      {"[estimation]\nmethod = \"multiple_shooting\"\n[[estimation.regularization]]\n"
       "parameters = [\"load.mass\"]\n",
       "missing key 'weight'"},
      {"[estimation]\nmethod = \"equation_error\"\n[estimation.equation_error]\n"
       "fft_cutoff_bin = 10\n",
       "'fft_cutoff_bin' applies to differentiation = 'fft' only"},
      {"[estimation]\nmethod = \"equation_error\"\n[estimation.equation_error]\n"
       "differentiation = \"fft\"\nlowpass_hz = 5.0\n",
       "expected lowpass_hz = 0, got 5"},
  };
  for (const Case& c : cases) {
    const RunResult r = Fit(PushedProblem(c.estimation), "bad");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir_ / "bad"));
  }
}

TEST_F(GeneratedCli, UnknownIntegratorKeyIsBadInputWithItsLine) {
  const RunResult r =
      Fit(PushedProblem("[estimation]\n"
                        "method = \"single_shooting\"\n"
                        "[estimation.integrator]\n"
                        "method = \"cvodes\"\n"
                        "relative_tolerence = 1e-8\n"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("relative_tolerence"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("relative_tolerance"), std::string::npos) << r.output;  // suggestion
}

TEST_F(GeneratedCli, SolverFailureExits3AndStillWritesResultJson) {
  const RunResult r = Fit(PushedProblem() + "[estimation.ipopt]\nmax_iterations = 1\n");
  ASSERT_EQ(r.exit_code, 3) << r.output;
  const Json result = ReadJson(dir_ / "out/result.json");
  EXPECT_EQ(result["status"]["result"], "solver_failure");
  EXPECT_EQ(result["status"]["exit_code"], 3);
  EXPECT_FALSE(result["status"]["solver_success"].get<bool>());
  EXPECT_EQ(result["status"]["solver_status"], "Maximum_Iterations_Exceeded");
  EXPECT_FALSE(result["status"]["message"].get<std::string>().empty());
}

TEST_F(GeneratedCli, BadInputExits2AndLeavesEarlierResultsUntouched) {
  fs::create_directories(dir_ / "out/plots");
  const std::string earlier = "{\"earlier\": true}\n";
  WriteText(dir_ / "out/result.json", earlier);
  WriteText(dir_ / "out/plots/first_outputs.svg", "earlier plot");
  // A problem-file defect, a data defect (NaN) and a command-line defect.
  const RunResult typo = Fit(PushedProblem() + "[estimation.ipopt]\ntolerence = 1e-6\n");
  EXPECT_EQ(typo.exit_code, 2) << typo.output;
  EXPECT_NE(typo.output.find("pushed.toml:"), std::string::npos) << typo.output;
  WriteText(dir_ / "pushed.csv", PushedCsv("nan"));
  const RunResult nan = Fit(PushedProblem());
  EXPECT_EQ(nan.exit_code, 2) << nan.output;
  EXPECT_NE(nan.output.find("expected a finite value, got nan"), std::string::npos) << nan.output;
  const RunResult usage = RunGraybox("fit pushed.toml", dir_ / "log4.txt", dir_.path().string());
  EXPECT_EQ(usage.exit_code, 2) << usage.output;  // --out is required
  const RunResult missing =
      RunGraybox("fit nowhere.toml --out out", dir_ / "log5.txt", dir_.path().string());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  // Nothing was touched: same files, same contents, no temporaries.
  EXPECT_EQ(ReadText(dir_ / "out/result.json"), earlier);
  EXPECT_EQ(ReadText(dir_ / "out/plots/first_outputs.svg"), "earlier plot");
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "out")) {
    files += entry.is_regular_file() ? 1 : 0;
  }
  EXPECT_EQ(files, 2);
}

TEST_F(GeneratedCli, OutputPathThatIsAFileIsBadInput) {
  WriteText(dir_ / "taken", "a file");
  const RunResult r = Fit(PushedProblem(), "taken");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_EQ(ReadText(dir_ / "taken"), "a file");
}

}  // namespace
}  // namespace graybox::apps_testing
