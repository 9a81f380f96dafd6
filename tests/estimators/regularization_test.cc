// Regularisation of the free parameters: the penalty's value, the ridge solution in closed form
// with Ceres and Ipopt, and the errors for bad terms.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>

#include "graybox/estimators/nlp/regularization.h"
#include "graybox/estimators/solvers/solvers.h"

namespace graybox::estimators {
namespace {

using expr::Expr;
using expr::Function;

constexpr unsigned kSeed = 5;

std::vector<models::ModelParameter> Parameters(const Eigen::VectorXd& values,
                                               const Eigen::VectorXd& scales) {
  std::vector<models::ModelParameter> params;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    models::ModelParameter p;
    p.name = "block.p" + std::to_string(i);
    p.value = values[i];
    p.scale = scales[i];
    p.lower = -1e6;
    p.upper = 1e6;
    params.push_back(p);
  }
  return params;
}

// Linear least squares on the scaled variables: r = a^T w - b per row, rows as element data.
struct LinearProblem {
  Eigen::MatrixXd a;  // rows x n
  Eigen::VectorXd b;
  ParameterMap map;
  Nlp nlp;
};

LinearProblem MakeLinearProblem(const Eigen::MatrixXd& a, const Eigen::VectorXd& b,
                                const ParameterMap& map) {
  const int n = static_cast<int>(a.cols());
  std::vector<double> w0, lb, ub;
  std::vector<std::string> names;
  map.AppendVariables(&w0, &lb, &ub, &names);
  auto vec = [](std::vector<double>& v) {
    return Eigen::VectorXd(
        Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  LinearProblem p{a, b, map, Nlp(vec(w0), vec(lb), vec(ub), names)};
  const std::vector<Expr> z = Expr::Symbols("z", n), d = Expr::Symbols("d", n + 1);
  Expr r = -d[n];
  for (int j = 0; j < n; ++j) r = r + d[j] * z[j];
  ElementGroup g{"data",
                 Function("row", {{"z", z}, {"d", d}}, {{"r", {r}}}),
                 Eigen::MatrixXi(n, a.rows()),
                 Eigen::MatrixXd(n + 1, a.rows()),
                 Eigen::VectorXd(),
                 Eigen::VectorXd()};
  for (Eigen::Index k = 0; k < a.rows(); ++k) {
    for (int j = 0; j < n; ++j) g.index(j, k) = j;
    g.data.col(k) << a.row(k).transpose(), b[k];
  }
  p.nlp.AddGroup(std::move(g));
  return p;
}

TEST(Regularization, PenaltyValueIsLambdaTimesSquaredDistance) {
  const Eigen::Vector3d values(2.0, -3.0, 0.5), scales(10.0, 1.0, 0.1);
  const ParameterMap map = ParameterMap::FromModel(Parameters(values, scales));
  Nlp nlp(values.cwiseQuotient(scales), Eigen::Vector3d::Constant(-1e9),
          Eigen::Vector3d::Constant(1e9));
  RegularizationOptions options;
  options.terms.push_back({"decay", 0.25, RegularizationReference::kZero, {0, 2}});
  options.terms.push_back({"prior", 4.0, RegularizationReference::kInitial, {1}});
  AddRegularization(map, options, &nlp);
  EXPECT_EQ(nlp.NumResiduals(), 3);
  // Move every parameter by +1 in its own units.
  const Eigen::Vector3d w = (values + Eigen::Vector3d::Ones()).cwiseQuotient(scales);
  double f = 0.0;
  ASSERT_TRUE(nlp.Objective(w.data(), &f).ok);
  const double expected = 0.25 * (3.0 * 3.0 + 1.5 * 1.5) + 4.0 * (1.0 * 1.0);
  constexpr double kExact = 1e-13;  // a few roundings of order-one numbers
  EXPECT_NEAR(f, expected, kExact * expected);
}

// Ridge regression: minimise 1/2 |A w - b|^2 + lambda |S w - ref|^2 (S = diag(scale)) has the
// solution (A^T A + 2 lambda S^2) w = A^T b + 2 lambda S ref; both solvers reach it.
TEST(Regularization, RidgeSolutionInClosedFormWithCeresAndIpopt) {
  std::mt19937 rng(kSeed);
  std::normal_distribution<double> g(0.0, 1.0);
  const int rows = 30, n = 4;
  Eigen::MatrixXd a(rows, n);
  Eigen::VectorXd b(rows);
  for (int k = 0; k < rows; ++k) {
    for (int j = 0; j < n; ++j) a(k, j) = g(rng);
    b[k] = g(rng);
  }
  a.col(3) = a.col(2);  // columns 2 and 3 collinear: only their sum is determined by the data
  const Eigen::Vector4d values(1.0, 2.0, -1.0, 0.5), scales(1.0, 2.0, 0.5, 1.0);
  const ParameterMap map = ParameterMap::FromModel(Parameters(values, scales));
  for (RegularizationReference ref :
       {RegularizationReference::kZero, RegularizationReference::kInitial}) {
    LinearProblem p = MakeLinearProblem(a, b, map);
    const double lambda = 0.3;
    RegularizationOptions options;
    options.terms.push_back({"all", lambda, ref, {0, 1, 2, 3}});
    AddRegularization(map, options, &p.nlp);
    const Eigen::Vector4d r =
        ref == RegularizationReference::kZero ? Eigen::Vector4d::Zero() : values;
    const Eigen::MatrixXd s2 = scales.cwiseAbs2().asDiagonal();
    const Eigen::VectorXd expected =
        (a.transpose() * a + 2 * lambda * s2)
            .ldlt()
            .solve(a.transpose() * b + 2 * lambda * scales.cwiseProduct(r));
    const SolverResult ceres = SolveWithCeres(p.nlp);
    const SolverResult ipopt = SolveWithIpopt(p.nlp);
    ASSERT_TRUE(ceres.success) << ceres.FullReport();
    ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
    constexpr double kSolverTolerance = 1e-7;  // Ipopt's tol 1e-8 on a well-scaled problem
    EXPECT_LT((ceres.w - expected).norm(), kSolverTolerance * expected.norm())
        << RegularizationReferenceName(ref);
    EXPECT_LT((ipopt.w - expected).norm(), kSolverTolerance * expected.norm())
        << RegularizationReferenceName(ref);
  }
}

TEST(Regularization, BadTermsAreRejectedWithTheirName) {
  std::vector<models::ModelParameter> params =
      Parameters(Eigen::Vector2d(1.0, 2.0), Eigen::Vector2d::Ones());
  params[1].free = false;
  const ParameterMap map = ParameterMap::FromModel(params);
  auto message = [&](const RegularizationTerm& term) {
    Nlp nlp(Eigen::VectorXd::Ones(1), Eigen::VectorXd::Constant(1, -10),
            Eigen::VectorXd::Constant(1, 10));
    RegularizationOptions options;
    options.terms.push_back(term);
    try {
      AddRegularization(map, options, &nlp);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message({"t", 1.0, RegularizationReference::kZero, {1}})
                .find("term 't': parameter 'block.p1' is fixed; expected a free parameter"),
            std::string::npos);
  EXPECT_NE(message({"t", -1.0, RegularizationReference::kZero, {0}})
                .find("expected a finite weight >= 0, got -1"),
            std::string::npos);
  EXPECT_NE(message({"t", 1.0, RegularizationReference::kZero, {0, 0}}).find("appears twice"),
            std::string::npos);
  EXPECT_NE(message({"t", 1.0, RegularizationReference::kZero, {7}})
                .find("expected a parameter index in [0, 2), got 7"),
            std::string::npos);
  EXPECT_THROW(ParseRegularizationReference("inital"), std::invalid_argument);
  try {
    ParseRegularizationReference("inital");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'initial'"), std::string::npos);
  }
}

}  // namespace
}  // namespace graybox::estimators
