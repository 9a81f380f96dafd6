// Equation error: the inverse-dynamics form reproduces ordinary least squares exactly when the
// model is linear in its parameters, with Ipopt and Ceres alike.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "graybox/estimators/analysis/covariance.h"
#include "graybox/estimators/formulations/equation_error.h"
#include "graybox/estimators/solvers/solvers.h"

namespace graybox::estimators {
namespace {

using expr::Expr;
using expr::Function;

constexpr unsigned kSeed = 5;

// tau = M qdd + Fv qd + Fc tanh(qd / 0.01) + offset (the EMPS structure).
Function DriveInverseDynamics() {
  const auto q = Expr::Symbols("q", 1), qd = Expr::Symbols("qd", 1), qdd = Expr::Symbols("qdd", 1),
             p = Expr::Symbols("p", 4);
  return Function("drive_id", {{"q", q}, {"qd", qd}, {"qdd", qdd}, {"p", p}},
                  {{"tau", {p[0] * qdd[0] + p[1] * qd[0] + p[2] * tanh(qd[0] / 0.01) + p[3]}}});
}

std::vector<models::ModelParameter> DriveParameters() {
  std::vector<models::ModelParameter> ps(4);
  const char* names[] = {"M", "Fv", "Fc", "offset"};
  const double start[] = {50.0, 100.0, 10.0, 1.0};
  for (int i = 0; i < 4; ++i) {
    ps[i].name = names[i];
    ps[i].info.unit = "1";
    ps[i].value = start[i];
    ps[i].scale = std::max(1.0, std::fabs(start[i]));
    ps[i].lower = -1e6;
    ps[i].upper = 1e6;
  }
  return ps;
}

TEST(EquationError, LinearInParametersEqualsOrdinaryLeastSquares) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 3000;
  InverseDynamicsData d;
  d.q = Eigen::MatrixXd::Zero(n, 1);
  d.qd.resize(n, 1);
  d.qdd.resize(n, 1);
  d.tau.resize(n, 1);
  Eigen::MatrixXd x(n, 4);
  const Eigen::Vector4d truth(95.1, 203.5, 20.4, -3.2);
  for (int k = 0; k < n; ++k) {
    const double t = 1e-3 * k;
    d.qd(k, 0) = 0.2 * std::sin(3.0 * t) + 0.05 * std::sin(11.0 * t);
    d.qdd(k, 0) = 0.6 * std::cos(3.0 * t) + 0.55 * std::cos(11.0 * t);
    x.row(k) << d.qdd(k, 0), d.qd(k, 0), std::tanh(d.qd(k, 0) / 0.01), 1.0;
    d.tau(k, 0) = x.row(k).dot(truth) + 0.5 * g(rng);
  }
  const Eigen::Vector4d ols = x.colPivHouseholderQr().solve(d.tau.col(0));
  const EquationErrorProblem problem =
      BuildInverseDynamicsEquationError(DriveInverseDynamics(), DriveParameters(), {d});
  const SolverResult ceres = SolveWithCeres(problem.nlp);
  const SolverResult ipopt = SolveWithIpopt(problem.nlp);
  ASSERT_TRUE(ceres.success) << ceres.FullReport();
  ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
  const Eigen::VectorXd pc = problem.Parameters(ceres.w), pi = problem.Parameters(ipopt.w);
  constexpr double kOlsAgreement = 1e-8;  // the same linear least-squares problem, solved twice
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(pc[i], ols[i], kOlsAgreement * (1.0 + std::fabs(ols[i]))) << i;
    EXPECT_NEAR(pi[i], ols[i], kOlsAgreement * (1.0 + std::fabs(ols[i]))) << i;
  }
  // The IDIM-LS standard deviations: sigma^2 (X^T X)^-1 with sigma from the residuals.
  Eigen::VectorXd r(problem.nlp.NumResiduals());
  problem.nlp.Residuals(ceres.w.data(), r.data());
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(r.size(), 4);
  Eigen::VectorXd values(problem.nlp.ResidualJacobianRows().size());
  problem.nlp.ResidualJacobianValues(ceres.w.data(), values.data());
  for (std::size_t k = 0; k < problem.nlp.ResidualJacobianRows().size(); ++k) {
    const int col = problem.nlp.ResidualJacobianCols()[k];
    jac(problem.nlp.ResidualJacobianRows()[k], col) += values[k] / problem.parameters.scale[col];
  }
  auto params = DriveParameters();
  for (int i = 0; i < 4; ++i) params[i].value = pc[i];
  const UncertaintyReport rep = CovarianceFromJacobian(jac, r, params, {0, 1, 2, 3});
  const Eigen::VectorXd e = d.tau.col(0) - x * ols;
  const Eigen::MatrixXd cov = e.squaredNorm() / (n - 4) * (x.transpose() * x).inverse();
  constexpr double kStdAgreement = 1e-6;
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(rep.parameters[i].std_error, std::sqrt(cov(i, i)),
                kStdAgreement * std::sqrt(cov(i, i)))
        << i;
  }
}

TEST(EquationError, SizeMismatchesAreRejected) {
  InverseDynamicsData d;
  d.q = Eigen::MatrixXd::Zero(10, 1);
  d.qd = Eigen::MatrixXd::Zero(10, 1);
  d.qdd = Eigen::MatrixXd::Zero(9, 1);
  d.tau = Eigen::MatrixXd::Zero(10, 1);
  EXPECT_THROW(BuildInverseDynamicsEquationError(DriveInverseDynamics(), DriveParameters(), {d}),
               std::invalid_argument);
}

}  // namespace
}  // namespace graybox::estimators
