// Gauss-Newton covariance: closed form on linear least squares, per-channel noise in output
// units, unidentifiable combinations named (not every error blanked), numerical failures
// reported as failures, coverage on a simulation-error fit, one answer for the constraint and
// the penalty form of multiple shooting (its continuity rows read from the residual labels), and
// fixed initial states honoured.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <iostream>
#include <memory>
#include <random>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/formulations/multiple_shooting.h"
#include "graybox/estimators/formulations/single_shooting.h"
#include "graybox/estimators/integrators/integrators.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr unsigned kSeed = 3;
constexpr double kInvSqrt2 = 0.70710678118654752;

std::vector<models::ModelParameter> Params(const std::vector<std::string>& names,
                                           const Eigen::VectorXd& values) {
  std::vector<models::ModelParameter> p(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    p[i].name = names[i];
    p[i].info.unit = "1";
    p[i].value = values[static_cast<Eigen::Index>(i)];
  }
  return p;
}

// r = w[0] - 1: a prior on the first variable, computed by user code (a ResidualBlock).
class Prior : public ResidualBlock {
 public:
  int NumResiduals() const override { return 1; }
  NlpEvalStatus Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* r,
                         Eigen::MatrixXd* jacobian) const override {
    r->resize(1);
    (*r)[0] = z[0] - 1.0;
    if (jacobian != nullptr) *jacobian = Eigen::MatrixXd::Ones(1, 1);
    return {};
  }
};

const ParameterEstimate& Named(const UncertaintyReport& u, const std::string& name) {
  for (const auto& e : u.parameters) {
    if (e.name == name) return e;
  }
  throw std::invalid_argument("no parameter " + name);
}

TEST(Covariance, RelativeStdErrorIsReportedOnlyWhereItSaysSomething) {
  ParameterEstimate p;
  p.value = -2.0;
  p.std_error = 0.1;
  constexpr double kRounding = 1e-12;
  EXPECT_NEAR(p.RelativeStdPercent(), 5.0, kRounding);
  // A value near zero (an output weight of ~1e-17 printed 4.19e17 %): not a relative error.
  p.value = 1e-17;
  EXPECT_TRUE(std::isnan(p.RelativeStdPercent()));
  // At the floor it is reported (1000 %), just below it not.
  p.value = kRelativeErrorFloor * p.std_error;
  EXPECT_NEAR(p.RelativeStdPercent(), 1000.0, 1000.0 * kRounding);
  p.value = 0.99 * kRelativeErrorFloor * p.std_error;
  EXPECT_TRUE(std::isnan(p.RelativeStdPercent()));
  // Fixed, unknown or zero.
  p.value = 2.0;
  p.free = false;
  EXPECT_TRUE(std::isnan(p.RelativeStdPercent()));
  p.free = true;
  p.std_error = std::nan("");
  EXPECT_TRUE(std::isnan(p.RelativeStdPercent()));
  p.value = 0.0;
  p.std_error = 0.0;
  EXPECT_TRUE(std::isnan(p.RelativeStdPercent()));
}

TEST(Covariance, LinearLeastSquaresMatchesTheClosedForm) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 200;
  Eigen::MatrixXd x(n, 3);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) {
    x.row(i) << 1.0, g(rng), g(rng);
    r[i] = 0.1 * g(rng);
  }
  const UncertaintyReport rep =
      CovarianceFromJacobian(x, r, Params({"a", "b", "c"}, Eigen::Vector3d(1, 2, 3)), {0, 1, 2});
  const double s2 = r.squaredNorm() / (n - 3);
  const Eigen::MatrixXd expected = s2 * (x.transpose() * x).inverse();
  constexpr double kInverseAgreement = 1e-12;  // two well-conditioned 3x3 inverses
  EXPECT_LT((rep.covariance - expected).norm(), kInverseAgreement * expected.norm());
  EXPECT_NEAR(rep.parameters[1].ci_high - rep.parameters[1].value,
              1.959963984540054 * std::sqrt(expected(1, 1)), 1e-12);
  EXPECT_TRUE(rep.ok);
  EXPECT_TRUE(rep.warnings.empty());
  EXPECT_TRUE(rep.unidentifiable.empty());
}

// Two output channels with noise 0.01 and 1 fitted with equal weights: the per-channel variances
// give the sandwich A^-1 (sum_c sigma_c^2 J_c^T J_c) A^-1, here in closed form for one parameter
// and a nuisance column; the pooled variance would be wrong by the mix of the two.
TEST(Covariance, PerChannelVariancesGiveTheSandwich) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 400;  // rows, alternating channels 0 and 1
  Eigen::MatrixXd j(n, 2);
  Eigen::VectorXd r(n);
  std::vector<int> channel(n);
  for (int i = 0; i < n; ++i) {
    channel[i] = i % 2;
    j.row(i) << (channel[i] == 0 ? 10.0 : 0.1) * g(rng), 1.0;  // the clean channel informs
    r[i] = (channel[i] == 0 ? 0.01 : 1.0) * g(rng);
  }
  CovarianceOptions options;
  options.row_channels = channel;
  const UncertaintyReport rep =
      CovarianceFromJacobian(j, r, Params({"a"}, Eigen::VectorXd::Ones(1)), {0}, options);
  // Closed form.
  const double correction = static_cast<double>(n) / (n - 2);
  double ss[2] = {0, 0};
  for (int i = 0; i < n; ++i) ss[channel[i]] += r[i] * r[i];
  Eigen::VectorXd var(n);
  for (int i = 0; i < n; ++i) var[i] = correction * ss[channel[i]] / (n / 2);
  const Eigen::MatrixXd a_inv = (j.transpose() * j).inverse();
  const Eigen::MatrixXd sandwich = a_inv * j.transpose() * var.asDiagonal() * j * a_inv;
  constexpr double kClosedForm = 1e-10;
  EXPECT_NEAR(rep.covariance(0, 0), sandwich(0, 0), kClosedForm * sandwich(0, 0));
  // The pooled variance mixes the noisy channel into the clean one's information: far too large.
  const UncertaintyReport pooled =
      CovarianceFromJacobian(j, r, Params({"a"}, Eigen::VectorXd::Ones(1)), {0});
  EXPECT_GT(pooled.covariance(0, 0), 100.0 * rep.covariance(0, 0));
  options.row_channels.pop_back();
  EXPECT_THROW(CovarianceFromJacobian(j, r, Params({"a"}, Eigen::VectorXd::Ones(1)), {0}, options),
               std::invalid_argument);
}

// Residuals weighted per channel, w_c (y - y_measured) with w = (100 1/m, 0.5 1/V): the report
// gives each channel's noise in its own unit, sigma_c / w_c, which is the noise that was added.
TEST(Covariance, ChannelNoiseIsReportedInTheOutputsUnits) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 4000;
  const double weight[2] = {100.0, 0.5}, noise[2] = {1e-3, 2.0};  // m and V
  Eigen::MatrixXd j(n, 2);
  Eigen::VectorXd r(n);
  std::vector<int> channel(n);
  for (int i = 0; i < n; ++i) {
    const int c = i % 2;
    channel[i] = c;
    j.row(i) << weight[c] * g(rng), weight[c] * g(rng);
    r[i] = weight[c] * noise[c] * g(rng);
  }
  CovarianceOptions options;
  options.row_channels = channel;
  options.channel_weights = Eigen::Vector2d(weight[0], weight[1]);
  options.channel_names = {"position", "command"};
  options.channel_units = {"m", "V"};
  const UncertaintyReport rep =
      CovarianceFromJacobian(j, r, Params({"a", "b"}, Eigen::Vector2d(1, 1)), {0, 1}, options);
  ASSERT_EQ(rep.channels.size(), 2u);
  const double correction = static_cast<double>(n) / (n - 2);
  constexpr double kRounding = 1e-12;
  constexpr double kSampling = 0.05;  // 2000 draws per channel: the std estimate is within ~2 %
  for (int c = 0; c < 2; ++c) {
    double ss = 0.0;
    for (int i = c; i < n; i += 2) ss += r[i] * r[i];
    const ChannelNoise& ch = rep.channels[c];
    EXPECT_EQ(ch.num_residuals, n / 2);
    EXPECT_NEAR(ch.weighted_sigma, std::sqrt(correction * ss / (n / 2)),
                kRounding * ch.weighted_sigma);
    EXPECT_NEAR(ch.sigma, ch.weighted_sigma / weight[c], kRounding * ch.sigma);
    EXPECT_NEAR(ch.sigma, noise[c], kSampling * noise[c]) << ch.name;
  }
  EXPECT_EQ(rep.channels[1].unit, "V");
  EXPECT_NE(rep.BriefReport().find("command 2"), std::string::npos) << rep.BriefReport();
  EXPECT_NE(rep.FullReport().find("noise sigma"), std::string::npos) << rep.FullReport();
  options.channel_weights[1] = -1.0;
  EXPECT_THROW(
      CovarianceFromJacobian(j, r, Params({"a", "b"}, Eigen::Vector2d(1, 1)), {0, 1}, options),
      std::invalid_argument);
}

// y = (a + b) x1 + c x2: only a + b and c are determined. The null space of the information is
// the direction (1, -1, 0) / sqrt 2, named "0.71*a - 0.71*b"; a and b have no standard error, c
// keeps the closed-form one of the identifiable model y = s x1 + c x2 (with the same sigma^2).
TEST(Covariance, UnidentifiableCombinationIsNamedAndTheRestKeepTheirErrors) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 300;
  Eigen::MatrixXd j(n, 3), x(n, 2);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) {
    const double x1 = g(rng), x2 = g(rng);
    j.row(i) << x1, x1, x2;
    x.row(i) << x1, x2;
    r[i] = 0.1 * g(rng);
  }
  const auto params = Params({"a", "b", "c"}, Eigen::Vector3d(1, 2, 3));
  const double s2 = r.squaredNorm() / (n - 3);
  const double c_variance = s2 * (x.transpose() * x).inverse()(1, 1);
  constexpr double kDirection = 1e-6;   // null vector of an exactly singular 3x3 matrix
  constexpr double kClosedForm = 1e-9;  // pseudo-inverse against the 2x2 inverse
  for (const bool per_channel : {false, true}) {
    CovarianceOptions options;
    if (per_channel) options.row_channels.assign(n, 0);  // one channel: the same numbers
    const UncertaintyReport rep = CovarianceFromJacobian(j, r, params, {0, 1, 2}, options);
    std::cout << rep.FullReport();
    ASSERT_TRUE(rep.ok) << rep.failure;
    ASSERT_EQ(rep.unidentifiable.size(), 1u);
    EXPECT_EQ(rep.unidentifiable[0], "0.71*a - 0.71*b");
    ASSERT_EQ(rep.null_space.cols(), 1);
    EXPECT_NEAR(rep.null_space(0, 0), kInvSqrt2, kDirection);
    EXPECT_NEAR(rep.null_space(1, 0), -kInvSqrt2, kDirection);
    EXPECT_NEAR(rep.null_space(2, 0), 0.0, kDirection);
    EXPECT_TRUE(std::isnan(rep.parameters[0].std_error));
    EXPECT_TRUE(std::isnan(rep.parameters[1].std_error));
    EXPECT_TRUE(std::isnan(rep.parameters[0].ci_low));
    EXPECT_NEAR(rep.parameters[2].std_error, std::sqrt(c_variance),
                kClosedForm * std::sqrt(c_variance));
    EXPECT_GT(rep.condition_number, CovarianceOptions().max_condition);
    ASSERT_EQ(rep.warnings.size(), 1u);
    EXPECT_NE(rep.warnings[0].find("0.71*a - 0.71*b"), std::string::npos) << rep.warnings[0];
  }
  // The same from the information matrix.
  const UncertaintyReport info =
      CovarianceFromInformation(j.transpose() * j, s2, n, params, {0, 1, 2});
  ASSERT_EQ(info.unidentifiable.size(), 1u);
  EXPECT_EQ(info.unidentifiable[0], "0.71*a - 0.71*b");
  EXPECT_NEAR(info.parameters[2].std_error, std::sqrt(c_variance),
              kClosedForm * std::sqrt(c_variance));
}

// Columns equal to 1e-6: the condition number (~1e12) is beyond max_condition, so the two are an
// unidentifiable combination (their sum is determined); a milder 1e-2 difference is identifiable
// but flagged as highly correlated.
TEST(Covariance, CollinearColumnsAreNamedAndCorrelatedOnesWarned) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 100;
  for (const double difference : {1e-6, 1e-2}) {
    Eigen::MatrixXd x(n, 2);
    Eigen::VectorXd r(n);
    for (int i = 0; i < n; ++i) {
      const double v = g(rng);
      x.row(i) << v, v * (1.0 + difference * g(rng));
      r[i] = 0.1 * g(rng);
    }
    const UncertaintyReport rep =
        CovarianceFromJacobian(x, r, Params({"a", "b"}, Eigen::Vector2d(1, 1)), {0, 1});
    std::cout << rep.FullReport();
    ASSERT_TRUE(rep.ok);
    ASSERT_FALSE(rep.warnings.empty());
    if (difference < 1e-4) {
      ASSERT_EQ(rep.unidentifiable.size(), 1u);
      EXPECT_EQ(rep.unidentifiable[0], "0.71*a - 0.71*b");
      EXPECT_NE(rep.FullReport().find("poorly identifiable"), std::string::npos);
    } else {
      EXPECT_TRUE(rep.unidentifiable.empty());
      EXPECT_TRUE(std::isfinite(rep.parameters[0].std_error));
      EXPECT_NE(rep.FullReport().find("high correlation"), std::string::npos) << rep.FullReport();
    }
  }
}

// A non-finite Jacobian entry is a numerical failure: ok = false with the reason, NaN errors, and
// no identifiability verdict (the old code reported "poorly identifiable: condition number inf").
TEST(Covariance, NonFiniteJacobianIsAFailureNotAnIdentifiabilityVerdict) {
  Eigen::MatrixXd j = Eigen::MatrixXd::Random(50, 3);
  const Eigen::VectorXd r = 0.1 * Eigen::VectorXd::Random(50);
  j(17, 1) = std::numeric_limits<double>::infinity();
  const UncertaintyReport rep =
      CovarianceFromJacobian(j, r, Params({"a", "b", "c"}, Eigen::Vector3d(1, 2, 3)), {0, 1, 2});
  std::cout << rep.FullReport();
  EXPECT_FALSE(rep.ok);
  EXPECT_EQ(rep.failure.rfind("the covariance could not be computed because", 0), 0u);
  EXPECT_NE(rep.failure.find("row 17, d r / d b"), std::string::npos) << rep.failure;
  EXPECT_TRUE(rep.warnings.empty());
  EXPECT_TRUE(rep.unidentifiable.empty());
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(std::isnan(rep.parameters[i].std_error));
  EXPECT_EQ(rep.BriefReport().rfind("covariance failed: ", 0), 0u);
}

// x' = -a x + b u, y = x (test_models.h's LagModel): the simulation-error covariance brackets
// the truth, and the noise comes back in the output's unit.
TEST(Covariance, SimulationErrorIntervalsCoverTheTruth) {
  const models::StateSpaceModel truth_model = testing::LagModel();
  const Eigen::Vector2d truth(2.0, 3.0);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  Experiment ex;
  ex.name = "lag";
  ex.dt = 0.01;
  ex.u.resize(2000, 1);
  for (int k = 0; k < 2000; ++k) ex.u(k, 0) = std::sin(0.013 * k) + 0.5 * std::sin(0.07 * k);
  ExperimentSetup setup;
  setup.x0 = Eigen::VectorXd::Constant(1, 0.2);
  ex.y = SimulateRk4(truth_model, setup.x0, ex.u, truth, ex.dt).y;
  constexpr double kNoise = 0.01;
  for (int k = 0; k < 2000; ++k) ex.y(k, 0) += kNoise * g(rng);
  models::StateSpaceModel start = truth_model;
  start.parameters[0].value = 1.2;
  start.parameters[1].value = 4.0;
  MultipleShootingOptions options;
  options.segment_length = 50;
  const ShootingProblem problem = BuildMultipleShooting(start, {ex}, {setup}, options);
  const SolverResult r = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  const Eigen::VectorXd p = problem.Parameters(r.w);
  const UncertaintyReport rep = SimulationCovariance(start, {ex}, p, {problem.InitialState(r.w, 0)},
                                                     problem.output_weights, options.step);
  ASSERT_TRUE(rep.ok) << rep.failure;
  // The weighted residual standard deviation is the noise over the output std; in the output's
  // own unit it is the noise.
  const double y_std = std::sqrt((ex.y.array() - ex.y.mean()).square().mean());
  EXPECT_NEAR(std::sqrt(rep.residual_variance), kNoise / y_std, 0.1 * kNoise / y_std);
  ASSERT_EQ(rep.channels.size(), 1u);
  EXPECT_EQ(rep.channels[0].name, "y0");
  EXPECT_NEAR(rep.channels[0].sigma, kNoise, 0.1 * kNoise);
  constexpr double kSigmas = 4.0;  // deterministic seed; 4 sigma leaves no room for flakiness
  for (int i = 0; i < 2; ++i) {
    const ParameterEstimate& e = rep.parameters[i];
    EXPECT_GT(e.std_error, 0.0);
    EXPECT_LT(std::fabs(e.value - truth[i]), kSigmas * e.std_error) << e.name;
    EXPECT_LT(e.std_error, 0.01 * truth[i]) << e.name;  // the data pin both down tightly
  }
}

// The same lag fitted by multiple shooting with continuity as constraints (Ipopt) and as
// residuals weighted 1e6 (Ceres): NlpCovariance treats both continuity forms as the exact
// constraints they stand for, so both give the whole-record simulation's covariance (same RK4
// map, free initial state eliminated in both), whatever the weight.
TEST(Covariance, BothContinuityFormsGiveTheSimulationCovariance) {
  const models::StateSpaceModel truth_model = testing::LagModel();
  const Eigen::Vector2d truth(2.0, 3.0);
  std::mt19937 rng(kSeed + 1);
  std::normal_distribution<double> g(0.0, 1.0);
  Experiment ex;
  ex.name = "lag";
  ex.dt = 0.01;
  ex.u.resize(1500, 1);
  for (int k = 0; k < 1500; ++k) ex.u(k, 0) = std::sin(0.013 * k) + 0.5 * std::sin(0.07 * k);
  ExperimentSetup setup;
  setup.x0 = Eigen::VectorXd::Constant(1, 0.2);
  ex.y = SimulateRk4(truth_model, setup.x0, ex.u, truth, ex.dt).y;
  for (int k = 0; k < 1500; ++k) ex.y(k, 0) += 0.01 * g(rng);
  MultipleShootingOptions options;
  options.segment_length = 25;
  const ShootingProblem constrained = BuildMultipleShooting(truth_model, {ex}, {setup}, options);
  options.continuity_as_constraints = false;
  options.continuity_weight = 1e6;
  const ShootingProblem penalised = BuildMultipleShooting(truth_model, {ex}, {setup}, options);
  const SolverResult ri = SolveWithIpopt(constrained.nlp);
  CeresOptions ceres;
  ceres.max_iterations = 500;
  const SolverResult rc = SolveWithCeres(penalised.nlp, ceres);
  ASSERT_TRUE(ri.success) << ri.FullReport();
  ASSERT_TRUE(rc.success) << rc.FullReport();
  EXPECT_EQ(ContinuityResidualRows(penalised).size(), 59u);  // 60 segments, 1 state
  const UncertaintyReport ui = NlpCovariance(constrained, ri.w);
  const UncertaintyReport uc = NlpCovariance(penalised, rc.w);
  const UncertaintyReport us = SimulationCovariance(truth_model, {ex}, constrained.Parameters(ri.w),
                                                    {constrained.InitialState(ri.w, 0)},
                                                    constrained.output_weights, options.step);
  std::cout << ui.FullReport() << uc.FullReport() << us.FullReport();
  ASSERT_TRUE(ui.ok && uc.ok && us.ok);
  // The Ipopt optimum is continuous to 1e-8 and is the simulation's; the Ceres one leaves gaps of
  // ~(output residual) / 1e6, which move its parameters and errors by ~1e-5 relative.
  constexpr double kSameTrajectory = 1e-6, kPenaltyGaps = 1e-3;
  EXPECT_EQ(ui.num_residuals, 1500);
  EXPECT_EQ(uc.num_residuals, 1500);
  for (int i = 0; i < 2; ++i) {
    const double si = ui.parameters[i].std_error;
    EXPECT_NEAR(si, us.parameters[i].std_error, kSameTrajectory * si);
    EXPECT_NEAR(uc.parameters[i].std_error, si, kPenaltyGaps * si);
  }
  EXPECT_NEAR(ui.channels[0].sigma, us.channels[0].sigma, kSameTrajectory * us.channels[0].sigma);
  // A penalised continuity left among the noise residuals would be a different problem: the
  // information of a weight-1e6 penalty is near that of the constraint, so only sigma^2 and the
  // residual count move; the rows are recognised from their residual labels instead.
  CovarianceOptions none;
  none.constraint_residual_rows = {};
  const UncertaintyReport raw = NlpCovariance(penalised.nlp, rc.w, penalised.parameters, none);
  EXPECT_EQ(raw.num_residuals, 1500 + 59);

  // A residual added without a label cannot be told apart: an error, not a guess. Labelled as a
  // channel of its own it is neither an output nor continuity ("other residuals").
  ShootingProblem extra = BuildMultipleShooting(truth_model, {ex}, {setup}, options);
  const int prior_row = extra.nlp.NumResiduals();
  extra.nlp.AddResidualBlock("prior", {0}, std::make_shared<const Prior>());
  EXPECT_THROW(ContinuityResidualRows(extra), std::invalid_argument);
  EXPECT_THROW(NlpCovariance(extra, rc.w), std::invalid_argument);
  extra.nlp.LabelResidual(prior_row, {-1, -1, extra.nlp.ResidualChannel("prior.a")});
  EXPECT_EQ(ContinuityResidualRows(extra), ContinuityResidualRows(penalised));
  const UncertaintyReport with_prior = NlpCovariance(extra, rc.w);
  ASSERT_TRUE(with_prior.ok) << with_prior.failure;
  ASSERT_EQ(with_prior.channels.size(), 2u);
  EXPECT_EQ(with_prior.channels[1].num_residuals, 1);
}

// x' = b u, y = x + o: a velocity integrator read through a sensor with an offset o. With the
// initial state known (fixed in the fit), b and o are both determined; with x0 free, o and x0 are
// the same thing (d y / d o = d y / d x0 = 1), so o is unidentifiable, named as confounded with
// the initial state, while b keeps its error.
class DriftingSensor : public models::BlockBase<DriftingSensor> {
 public:
  DriftingSensor() {
    info_.type = "test.drifting_sensor";
    info_.description = "integrator read through a sensor with an offset";
    info_.reference = "test";
    info_.inputs = {{"u", "m/s", "velocity command", -1, 1}};
    info_.outputs = {{"y", "m", "measured position", -1, 1}};
    info_.states = {{"x", "m", "position", -1, 1}};
    info_.parameters = {{"b", "1", "velocity gain", 1.0, 0.1, 10.0},
                        {"o", "m", "sensor offset", 0.1, -1.0, 1.0}};
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    a.xdot[0] = a.p[0] * a.u[0];
    a.y[0] = a.x[0] + a.p[1];
  }
};

TEST(Covariance, FixedInitialStatesLeaveTheirColumnsOut) {
  models::Model m("drifting_sensor");
  m.AddInput("u", "m/s");
  m.AddBlock("sensor", std::make_shared<DriftingSensor>(), {"u"}, {"position"});
  m.AddOutput("position");
  const models::StateSpaceModel model = m.Build();
  const Eigen::Vector2d truth(1.3, 0.05);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  constexpr int kN = 1000;
  constexpr double kNoise = 1e-3;
  Experiment ex;
  ex.name = "drift";
  ex.dt = 0.01;
  ex.u.resize(kN, 1);
  for (int k = 0; k < kN; ++k) ex.u(k, 0) = std::sin(0.02 * k);
  ExperimentSetup setup;
  setup.x0 = Eigen::VectorXd::Zero(1);
  ex.y = SimulateRk4(model, setup.x0, ex.u, truth, ex.dt).y;
  for (int k = 0; k < kN; ++k) ex.y(k, 0) += kNoise * g(rng);
  // Single shooting keeps x0 fixed by default.
  const ShootingProblem problem = BuildSingleShooting(model, {ex}, {setup});
  const SolverResult r = SolveWithCeres(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  const Eigen::VectorXd p = problem.Parameters(r.w);
  CovarianceOptions fixed;
  fixed.free_initial_states = false;
  const UncertaintyReport uf =
      SimulationCovariance(model, {ex}, p, {setup.x0}, problem.output_weights, {}, fixed);
  const UncertaintyReport ufree =
      SimulationCovariance(model, {ex}, p, {setup.x0}, problem.output_weights, {});
  const UncertaintyReport unlp = NlpCovariance(problem, r.w);  // no x0 variables either
  std::cout << uf.FullReport() << ufree.FullReport() << unlp.FullReport();
  ASSERT_TRUE(uf.ok && ufree.ok && unlp.ok);
  EXPECT_LT(uf.condition_number, CovarianceOptions().max_condition);
  constexpr double kSigmas = 4.0;
  for (int i = 0; i < 2; ++i) {
    const ParameterEstimate& e = uf.parameters[i];
    EXPECT_TRUE(std::isfinite(e.std_error)) << e.name;
    EXPECT_LT(std::fabs(e.value - truth[i]), kSigmas * e.std_error) << e.name;
    // The single-shooting NLP's own covariance is the same computation.
    constexpr double kSameJacobian = 1e-8;
    EXPECT_NEAR(unlp.parameters[i].std_error, e.std_error, kSameJacobian * e.std_error);
  }
  // With x0 free: o is confounded with it, b is unaffected (in both cases its column is projected
  // orthogonally to the constant column), up to the degrees of freedom N - 3 against N - 2.
  ASSERT_EQ(ufree.unidentifiable.size(), 1u);
  EXPECT_EQ(ufree.unidentifiable[0].rfind("1*sensor.o (confounded", 0), 0u)
      << ufree.unidentifiable[0];
  EXPECT_TRUE(std::isnan(Named(ufree, "sensor.o").std_error));
  constexpr double kDofRatioOnly = 1e-8;
  const double dof_ratio = std::sqrt((kN - 2.0) / (kN - 3.0));
  EXPECT_NEAR(Named(ufree, "sensor.b").std_error, Named(uf, "sensor.b").std_error * dof_ratio,
              kDofRatioOnly * Named(uf, "sensor.b").std_error);
}

// A position-controlled axis M qdd = kp (r - q) - kd qd - fv qd - fc tanh(s qd), output the
// position and the command, at rest for the first 0.5 s. At rest qd is exactly 0, where the
// linearisation has the slope fc s / M: with s = 1e6 it is 1e6 1/s, far beyond RK4's stability
// limit at 1 ms, so the forward sensitivities overflow while the state stays exactly at rest.
// That is a numerical failure, not an identifiability verdict; with s = 100 the same record is
// well conditioned.
class SteepAxis : public models::BlockBase<SteepAxis> {
 public:
  explicit SteepAxis(double steepness) : steepness_(steepness) {
    info_.type = "test.steep_axis";
    info_.description = "position-controlled mass with tanh Coulomb friction";
    info_.reference = "test";
    info_.inputs = {{"r", "m", "reference position", -1, 1}};
    info_.outputs = {{"command", "N", "controller force", -10, 10}};
    info_.states = {{"q", "m", "position", -1, 1}, {"qd", "m/s", "velocity", -1, 1}};
    info_.parameters = {{"M", "kg", "mass", 1.0, 0.1, 10.0},
                        {"fv", "N s/m", "viscous friction", 2.0, 0.0, 100.0},
                        {"fc", "N", "Coulomb friction", 1.0, 0.0, 100.0}};
  }
  template <typename S>
  void Compute(const models::BlockArgs<S>& a) const {
    using std::tanh;
    const S force = 400.0 * (a.u[0] - a.x[0]) - 40.0 * a.x[1];
    a.xdot[0] = a.x[1];
    a.xdot[1] = (force - a.p[1] * a.x[1] - a.p[2] * tanh(steepness_ * a.x[1])) / a.p[0];
    a.y[0] = force;
  }

 private:
  double steepness_;
};

TEST(Covariance, SteepFrictionAtRestIsANumericalFailureNotAnIdentifiabilityVerdict) {
  constexpr int kN = 3000;
  Experiment ex;
  ex.name = "axis";
  ex.dt = 1e-3;
  ex.u.resize(kN, 1);
  for (int k = 0; k < kN; ++k) {
    const double t = k * ex.dt;
    ex.u(k, 0) = t < 0.5 ? 0.0 : 0.1 * (1.0 - std::cos(2.0 * (t - 0.5)));
  }
  ExperimentSetup setup;
  setup.x0 = Eigen::Vector2d::Zero();
  const Eigen::Vector3d p(1.0, 2.0, 1.0);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const double steepness : {1e6, 100.0}) {
    models::Model m("axis");
    m.AddInput("r", "m");
    m.AddBlock("axis", std::make_shared<SteepAxis>(steepness), {"r"}, {"command"});
    m.AddOutput("axis.q");
    m.AddOutput("command");
    const models::StateSpaceModel model = m.Build();
    ex.y = SimulateRk4(model, setup.x0, ex.u, p, ex.dt).y;
    ASSERT_TRUE(ex.y.allFinite());  // the state itself is fine
    for (int k = 0; k < kN; ++k) {
      ex.y(k, 0) += 1e-5 * g(rng);
      ex.y(k, 1) += 1e-2 * g(rng);
    }
    const Eigen::Vector2d weights(1e4, 1.0);
    const UncertaintyReport u = SimulationCovariance(model, {ex}, p, {setup.x0}, weights, {});
    // Multiple shooting at the true parameters (nodes simulated from them): its Jacobian
    // overflows within the 20-sample segments of the rest phase.
    const ShootingProblem ms = BuildMultipleShooting(model, {ex}, {setup});
    const UncertaintyReport un = NlpCovariance(ms, ms.nlp.w0());
    std::cout << "steepness " << steepness << ":\n" << u.FullReport() << un.FullReport();
    if (steepness > 1e3) {
      for (const UncertaintyReport* r : {&u, &un}) {
        EXPECT_FALSE(r->ok);
        EXPECT_EQ(r->failure.rfind("the covariance could not be computed because", 0), 0u);
        EXPECT_TRUE(r->warnings.empty());
        EXPECT_TRUE(r->unidentifiable.empty());
        for (int i : r->free_indices) EXPECT_TRUE(std::isnan(r->parameters[i].std_error));
      }
      EXPECT_NE(u.failure.find("sensitivity"), std::string::npos) << u.failure;
      EXPECT_NE(u.failure.find("while the simulated state is finite"), std::string::npos);
    } else {
      for (const UncertaintyReport* r : {&u, &un}) {
        EXPECT_TRUE(r->ok) << r->failure;
        EXPECT_LT(r->condition_number, 1e4);
        for (int i : r->free_indices) EXPECT_TRUE(std::isfinite(r->parameters[i].std_error));
      }
    }
  }
}

TEST(Covariance, OptionsAreValidated) {
  const Eigen::MatrixXd j = Eigen::MatrixXd::Identity(3, 1);
  const Eigen::VectorXd r = Eigen::VectorXd::Zero(3);
  const auto params = Params({"a"}, Eigen::VectorXd::Ones(1));
  CovarianceOptions o;
  o.max_condition = 0.5;
  EXPECT_THROW(CovarianceFromJacobian(j, r, params, {0}, o), std::invalid_argument);
  o = {};
  o.null_space_coefficient = 1.0;
  EXPECT_THROW(CovarianceFromJacobian(j, r, params, {0}, o), std::invalid_argument);
  o = {};
  o.row_channels = {0, -1, 0};
  EXPECT_THROW(CovarianceFromJacobian(j, r, params, {0}, o), std::invalid_argument);
  EXPECT_THROW(CovarianceFromJacobian(j, r, params, {1}), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::estimators
