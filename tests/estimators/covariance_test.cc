// Gauss-Newton covariance: closed form on linear least squares, coverage on a simulation-error
// fit, and warnings for unidentifiable parameter combinations.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "graybox/estimators/covariance.h"
#include "graybox/estimators/integrators.h"
#include "graybox/estimators/multiple_shooting.h"
#include "graybox/estimators/solvers.h"
#include "test_models.h"

namespace graybox::estimators {
namespace {

constexpr unsigned kSeed = 3;

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
  EXPECT_TRUE(rep.warnings.empty());
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

TEST(Covariance, CollinearColumnsRaiseAWarning) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 100;
  Eigen::MatrixXd x(n, 2);
  Eigen::VectorXd r(n);
  for (int i = 0; i < n; ++i) {
    const double v = g(rng);
    x.row(i) << v, v * (1.0 + 1e-6 * g(rng));
    r[i] = 0.1 * g(rng);
  }
  const UncertaintyReport rep =
      CovarianceFromJacobian(x, r, Params({"a", "b"}, Eigen::Vector2d(1, 1)), {0, 1});
  ASSERT_FALSE(rep.warnings.empty());
  EXPECT_NE(rep.FullReport().find("high correlation"), std::string::npos) << rep.FullReport();
}

// x' = -a x + b u, y = x (test_models.h's LagModel): the simulation-error covariance brackets
// the truth.
TEST(Covariance, SimulationErrorIntervalsCoverTheTruth) {
  const models::StateSpaceModel truth_model = testing::LagModel();
  const Eigen::Vector2d truth(2.0, 3.0);
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  ExperimentData ex;
  ex.name = "lag";
  ex.dt = 0.01;
  ex.u.resize(2000, 1);
  for (int k = 0; k < 2000; ++k) ex.u(k, 0) = std::sin(0.013 * k) + 0.5 * std::sin(0.07 * k);
  ex.x0 = Eigen::VectorXd::Constant(1, 0.2);
  ex.y = SimulateRk4(truth_model, ex.x0, ex.u, truth, ex.dt).y;
  constexpr double kNoise = 0.01;
  for (int k = 0; k < 2000; ++k) ex.y(k, 0) += kNoise * g(rng);
  models::StateSpaceModel start = truth_model;
  start.parameters[0].value = 1.2;
  start.parameters[1].value = 4.0;
  MultipleShootingOptions options;
  options.segment_length = 50;
  const ShootingProblem problem = BuildMultipleShooting(start, {ex}, options);
  const SolverResult r = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  const Eigen::VectorXd p = problem.Parameters(r.w);
  const UncertaintyReport rep = SimulationCovariance(start, {ex}, p, {problem.InitialState(r.w, 0)},
                                                     problem.output_weights, options.step);
  // The weighted residual standard deviation is the noise over the output std.
  const double y_std = std::sqrt((ex.y.array() - ex.y.mean()).square().mean());
  EXPECT_NEAR(std::sqrt(rep.residual_variance), kNoise / y_std, 0.1 * kNoise / y_std);
  constexpr double kSigmas = 4.0;  // deterministic seed; 4 sigma leaves no room for flakiness
  for (int i = 0; i < 2; ++i) {
    const ParameterEstimate& e = rep.parameters[i];
    EXPECT_GT(e.std_error, 0.0);
    EXPECT_LT(std::fabs(e.value - truth[i]), kSigmas * e.std_error) << e.name;
    EXPECT_LT(e.std_error, 0.01 * truth[i]) << e.name;  // the data pin both down tightly
  }
}

}  // namespace
}  // namespace graybox::estimators
