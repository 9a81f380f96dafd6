// Localize: synthetic residuals whose location is known (a low-velocity friction the model lacks,
// a sinusoid, white noise, a delayed input), argument checks, and the EMPS closed loop.
#include "graybox/diagnosis/localization.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;

constexpr double kPi = 3.14159265358979323846;
// Shares are sums of the same non-negative numbers divided by their total: exact to rounding.
constexpr double kShareTolerance = 1e-9;
// Seed of every random draw here; GRAYBOX_TEST_SEED overrides it.
unsigned Seed() {
  const char* s = std::getenv("GRAYBOX_TEST_SEED");
  const unsigned seed = s ? static_cast<unsigned>(std::strtoul(s, nullptr, 10)) : 20240610u;
  std::cout << "seed " << seed << " (GRAYBOX_TEST_SEED overrides)\n";
  return seed;
}

// A sliding mass pushed by a measured force, braked by viscous friction; the output is the net
// force on the mass ("force" = input - fv qd, what m times an accelerometer on the load reads).
models::StateSpaceModel AxisModel(models::Model* out = nullptr) {
  models::Model m("axis");
  m.AddInput("force", "N", "drive force", -2.0, 2.0);
  m.AddBlock("load", "mechanics.mass", {}, {"force"}, {});
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  m.AddBlock("friction", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  m.SetParameter("load.mass", 1.0);
  m.SetParameter("friction.fv", 2.0);
  m.AddOutput("force");
  if (out) *out = m;
  return m.Build();
}

// The model simulated on input u (N x 1, dt) from rest: a validation split with states and inputs.
est::SplitEvaluation SimulateAxis(const Eigen::VectorXd& u, double dt) {
  models::Model model("axis");
  AxisModel(&model);
  const est::Problem problem = est::MakeProblem("axis", model);
  est::Experiment experiment;
  experiment.name = "synthetic";
  experiment.dt = dt;
  experiment.u = u;
  experiment.y = Eigen::MatrixXd::Zero(u.size(), 1);  // replaced below
  const est::SplitData split = est::MakeSplit("validation", est::SplitRole::kValidation, experiment,
                                              Eigen::VectorXd::Zero(2));
  std::vector<est::SplitEvaluation> evals =
      est::Simulate(problem, {split}, problem.built.ParameterValues());
  return evals.at(0);
}

Eigen::VectorXd Time(int n, double dt) { return Eigen::VectorXd::LinSpaced(n, 0.0, (n - 1) * dt); }

void ExpectPartitionsSumToOne(const Localization& loc) {
  std::map<std::tuple<std::string, std::string, std::string>, std::pair<double, double>> sums;
  for (const LocalizationEntry& e : loc.entries) {
    const std::string channel = e.kind == "channel" ? "" : e.channel;
    auto& s = sums[{channel, e.kind, e.partition}];
    s.first += e.energy_share;
    s.second += e.sample_share;
  }
  for (const auto& [key, s] : sums) {
    EXPECT_NEAR(s.first, 1.0, kShareTolerance)
        << std::get<0>(key) << " " << std::get<1>(key) << " " << std::get<2>(key);
    EXPECT_NEAR(s.second, 1.0, kShareTolerance)
        << std::get<0>(key) << " " << std::get<1>(key) << " " << std::get<2>(key);
  }
}

TEST(NormalQuantile, MatchesTables) {
  // Normal tables to 4 decimals.
  constexpr double kTableTolerance = 5e-5;
  EXPECT_NEAR(NormalQuantileTwoSided(0.99), 2.5758, kTableTolerance);
  EXPECT_NEAR(NormalQuantileTwoSided(0.95), 1.9600, kTableTolerance);
  EXPECT_THROW(NormalQuantileTwoSided(1.0), std::invalid_argument);
}

// The truth has a low-velocity friction the model lacks: a Coulomb force with a breakaway peak,
//   f(v) = (fc + (fs - fc) exp(-(v / vs)^2)) tanh(v / vd),
// whose part linear in v a least-squares fit of the model's viscous coefficient has absorbed.
// The measured net force is the simulated one minus what remains; it must be located at the
// velocity's reversals or near zero, where the breakaway peak acts.
TEST(Localize, UnmodelledLowVelocityFrictionIsFoundAtReversals) {
  constexpr double kDt = 1e-3;                                      // [s]
  constexpr int kSamples = 20000;                                   // 20 s
  constexpr double kAmplitude = 1.5, kFrequency = 0.4;              // force [N], [Hz]
  constexpr double kFc = 0.05, kFs = 0.3, kVs = 0.01, kVd = 0.002;  // [N], [N], [m/s], [m/s]
  const Eigen::VectorXd t = Time(kSamples, kDt);
  const Eigen::VectorXd u = (2.0 * kPi * kFrequency * t).array().sin() * kAmplitude;
  est::SplitEvaluation s = SimulateAxis(u, kDt);
  ASSERT_TRUE(s.simulation_ok);
  const Eigen::VectorXd v = s.states.col(1);
  Eigen::VectorXd f(kSamples);
  for (int k = 0; k < kSamples; ++k) {
    f[k] = (kFc + (kFs - kFc) * std::exp(-std::pow(v[k] / kVs, 2))) * std::tanh(v[k] / kVd);
  }
  const double beta = f.dot(v) / v.squaredNorm();  // the viscous fit absorbs beta v
  s.measured = s.simulated - (f - beta * v);

  const models::StateSpaceModel model = AxisModel();
  const Localization loc = Localize(model, model.ParameterValues(), {s});
  std::cout << loc.FullReport();
  ExpectPartitionsSumToOne(loc);
  EXPECT_FALSE(loc.used_all_splits);
  const std::vector<LocalizationEntry> regimes = loc.Entries("regime");
  ASSERT_FALSE(regimes.empty());
  const LocalizationEntry& top = regimes.front();
  EXPECT_EQ(top.signal, "load.qd");
  EXPECT_TRUE(top.label.find("reversal") != std::string::npos ||
              top.label.find("near zero") != std::string::npos)
      << top.label;
  EXPECT_GT(top.concentration, 1.0);
}

// A sinusoidal residual at f0 puts > 80 % of the residual spectrum in the band containing f0.
TEST(Localize, SinusoidalResidualFallsInItsBand) {
  constexpr double kDt = 1e-3;
  constexpr int kSamples = 8192;
  const Eigen::VectorXd t = Time(kSamples, kDt);
  const Eigen::VectorXd u = (2.0 * kPi * 0.5 * t).array().sin();
  est::SplitEvaluation s = SimulateAxis(u, kDt);
  constexpr double kF0 = 20.0;  // [Hz]
  s.measured = s.simulated + 0.1 * (2.0 * kPi * kF0 * t).array().sin().matrix();
  const models::StateSpaceModel model = AxisModel();
  const Localization loc = Localize(model, model.ParameterValues(), {s});
  ExpectPartitionsSumToOne(loc);
  int found = 0;
  for (const BandEnergy& b : loc.bands) {
    if (kF0 >= b.f_low && kF0 < b.f_high) {
      ++found;
      constexpr double kMinShare = 0.8;  // the brief's mark; Hann leakage is far below 20 %
      EXPECT_GT(b.residual_share, kMinShare) << b.f_low << " - " << b.f_high << " Hz";
    }
  }
  EXPECT_EQ(found, 1);
  EXPECT_EQ(loc.Entries("band").front().lower <= kF0 && kF0 < loc.Entries("band").front().upper,
            true);
}

// White noise is white: few autocorrelation lags beyond z / sqrt(N). A residual equal to the
// input delayed by d samples peaks in the cross-correlation at lag +d.
TEST(Localize, WhitenessAndInputCorrelation) {
  constexpr double kDt = 1e-3;
  constexpr int kSamples = 10000;
  constexpr int kDelay = 7;  // [samples]
  std::mt19937 rng(Seed());
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd u(kSamples), noise(kSamples);
  for (int k = 0; k < kSamples; ++k) u[k] = normal(rng);
  for (int k = 0; k < kSamples; ++k) noise[k] = normal(rng);
  est::SplitEvaluation s = SimulateAxis(u, kDt);
  const models::StateSpaceModel model = AxisModel();

  s.measured = s.simulated + 0.01 * noise;
  const Localization white = Localize(model, model.ParameterValues(), {s});
  ASSERT_EQ(white.whiteness.size(), 1u);
  // With 99 % bounds about 1 % of 50 lags fall outside; 5 % allows for the draw.
  constexpr double kMaxOutside = 0.05;
  EXPECT_LT(white.whiteness[0].fraction_outside, kMaxOutside);
  EXPECT_NEAR(white.whiteness[0].bound, 2.5758 / std::sqrt(kSamples), 1e-4);

  Eigen::VectorXd delayed = Eigen::VectorXd::Zero(kSamples);
  delayed.tail(kSamples - kDelay) = u.head(kSamples - kDelay);
  s.measured = s.simulated + delayed;
  const Localization lagged = Localize(model, model.ParameterValues(), {s});
  ASSERT_EQ(lagged.cross_correlations.size(), 1u);
  const CrossCorrelation& cc = lagged.cross_correlations[0];
  EXPECT_EQ(cc.input, "force");
  EXPECT_EQ(cc.peak_lag, kDelay);
  // r = 1 up to the 7 samples cut off and the sample means: well above 0.99.
  constexpr double kMinPeak = 0.99;
  EXPECT_GT(cc.peak, kMinPeak);
  // A delayed white input is a coloured residual only at lag 0 shifts: the autocorrelation of a
  // white sequence stays white.
  EXPECT_LT(lagged.whiteness[0].fraction_outside, kMaxOutside);
}

TEST(Localize, NoValidationSplitUsesAllAndSaysSo) {
  constexpr double kDt = 1e-3;
  const Eigen::VectorXd t = Time(2000, kDt);
  est::SplitEvaluation s = SimulateAxis((2.0 * kPi * t).array().sin(), kDt);
  s.role = est::SplitRole::kEstimation;
  s.measured = s.simulated + 0.01 * (2.0 * kPi * 5.0 * t).array().cos().matrix();
  const models::StateSpaceModel model = AxisModel();
  const Localization loc = Localize(model, model.ParameterValues(), {s});
  EXPECT_TRUE(loc.used_all_splits);
  EXPECT_NE(loc.BriefReport().find("no validation or test split"), std::string::npos);
}

std::string ThrowMessage(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Localize, BadSizesThrowNamingExpectedAndGot) {
  constexpr double kDt = 1e-3;
  const Eigen::VectorXd t = Time(500, kDt);
  const est::SplitEvaluation good = SimulateAxis((2.0 * kPi * t).array().sin(), kDt);
  const models::StateSpaceModel model = AxisModel();
  const Eigen::VectorXd p = model.ParameterValues();

  est::SplitEvaluation s = good;
  s.simulated = Eigen::MatrixXd::Zero(500, 3);
  EXPECT_EQ(ThrowMessage([&] { Localize(model, p, {s}); }),
            "Localize: split 'validation': simulated has 3 columns; expected 1 (the model's "
            "outputs)");
  s = good;
  s.states = Eigen::MatrixXd::Zero(499, 2);
  EXPECT_EQ(ThrowMessage([&] { Localize(model, p, {s}); }),
            "Localize: split 'validation': states has 499 rows; expected 500 (the samples of "
            "time)");
  s = good;
  s.inputs = Eigen::MatrixXd::Zero(500, 2);
  EXPECT_NE(ThrowMessage([&] { Localize(model, p, {s}); }).find("expected 1"), std::string::npos);
  EXPECT_EQ(ThrowMessage([&] { Localize(model, Eigen::VectorXd::Zero(5), {good}); }),
            "Localize: values has 5 entries; expected 2 (the model's parameters)");
  EXPECT_NE(ThrowMessage([&] { Localize(model, p, {}); }).find("got none"), std::string::npos);
  LocalizationOptions bad;
  bad.confidence = 1.5;
  EXPECT_EQ(ThrowMessage([&] { Localize(model, p, {good}, bad); }),
            "LocalizationOptions::confidence: expected a number in (0, 1), got 1.5");
}

// EMPS closed loop fitted by multiple shooting, localised on its test split (pulses): printed,
// with structural checks only (no tuned numbers).
TEST(Localize, EmpsClosedLoopTestSplit) {
  const std::string path = std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop.toml";
  const est::Problem problem = est::LoadProblem(path);
  const std::vector<est::SplitData> splits = est::LoadData(problem);
  est::FitOptions options;
  options.compute_covariance = false;
  const est::FitResult fit = est::Fit(problem, splits, options);
  ASSERT_TRUE(fit.IsSolutionUsable()) << fit.BriefReport();
  const Localization loc = Localize(problem.built, fit.values, fit.evaluations);
  std::cout << loc.FullReport(8);
  std::cout << "top 5 entries:\n";
  for (size_t i = 0; i < 5 && i < loc.entries.size(); ++i) {
    const LocalizationEntry& e = loc.entries[i];
    std::cout << "  " << e.kind << " | " << e.channel << " | " << e.label << " | energy "
              << e.energy_share << " | samples " << e.sample_share << " | x" << e.concentration
              << " | score " << e.score << "\n";
  }
  EXPECT_FALSE(loc.used_all_splits);
  ASSERT_EQ(loc.splits.size(), 1u);
  EXPECT_EQ(loc.splits[0], "test_pulses");
  EXPECT_EQ(loc.channels.size(), 2u);
  ExpectPartitionsSumToOne(loc);
  for (size_t i = 1; i < loc.entries.size(); ++i) {
    EXPECT_GE(loc.entries[i - 1].score, loc.entries[i].score);
  }
}

}  // namespace
}  // namespace graybox::diagnosis
