// The element-assembled NLP and its two backends.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/nlp_check.h"
#include "graybox/estimators/solvers/solvers.h"
#include "graybox/expr/expr.h"

namespace graybox::estimators {
namespace {

using expr::Expr;
using expr::Function;

constexpr unsigned kSeed = 7;

// HS071 (Hock-Schittkowski 71) as one element reading all four variables:
// min x1 x4 (x1 + x2 + x3) + x3  s.t.  x1 x2 x3 x4 >= 25,  sum x_i^2 = 40,  1 <= x <= 5.
Nlp Hs071() {
  const std::vector<Expr> z = Expr::Symbols("x", 4);
  const Function fn(
      "hs071", {{"z", z}, {"d", {}}},
      {{"f", {z[0] * z[3] * (z[0] + z[1] + z[2]) + z[2]}},
       {"c", {z[0] * z[1] * z[2] * z[3], z[0] * z[0] + z[1] * z[1] + z[2] * z[2] + z[3] * z[3]}}});
  Nlp nlp(Eigen::Vector4d(1, 5, 5, 1), Eigen::Vector4d::Constant(1.0),
          Eigen::Vector4d::Constant(5.0));
  ElementGroup g;
  g.name = "hs071";
  g.fn = fn;
  g.index = Eigen::MatrixXi(4, 1);
  g.index << 0, 1, 2, 3;
  g.data = Eigen::MatrixXd(0, 1);
  g.lbc = Eigen::Vector2d(25.0, 40.0);
  g.ubc = Eigen::Vector2d(2e19, 40.0);
  nlp.AddGroup(g);
  return nlp;
}

// y_k = a exp(b t_k) + noise, one residual element per sample sharing (a, b).
Nlp ExponentialFit(int n, double noise, std::mt19937* rng) {
  const std::vector<Expr> z = Expr::Symbols("ab", 2);
  const std::vector<Expr> d = Expr::Symbols("ty", 2);
  const Function fn("exp_fit", {{"z", z}, {"d", d}}, {{"r", {z[0] * exp(z[1] * d[0]) - d[1]}}});
  std::normal_distribution<double> eps(0.0, noise);
  ElementGroup g;
  g.name = "samples";
  g.fn = fn;
  g.index = Eigen::MatrixXi(2, n);
  g.data = Eigen::MatrixXd(2, n);
  for (int k = 0; k < n; ++k) {
    const double t = 2.0 * k / n;
    g.index(0, k) = 0;
    g.index(1, k) = 1;
    g.data(0, k) = t;
    g.data(1, k) = 1.5 * std::exp(-0.7 * t) + eps(*rng);
  }
  g.lbc.resize(0);
  g.ubc.resize(0);
  Nlp nlp(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(-10, -10), Eigen::Vector2d(10, 10));
  nlp.AddGroup(g);
  return nlp;
}

TEST(Nlp, Hs071ReachesTheKnownOptimumWithIpopt) {
  const Nlp nlp = Hs071();
  const SolverResult r = SolveWithIpopt(nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  constexpr double kHs071Optimum = 17.014017145179164;  // published optimum of HS071
  constexpr double kOptimumTolerance = 1e-7;            // Ipopt tol 1e-8 on the scaled NLP error
  EXPECT_NEAR(r.cost, kHs071Optimum, kOptimumTolerance);
  EXPECT_NEAR(r.w[0], 1.0, 1e-6);
  // Ipopt relaxes bounds by bound_relax_factor = 1e-8 relative: up to 25e-8 at the bound 25.
  constexpr double kRelaxedBoundViolation = 1e-8 * 40.0;
  EXPECT_LT(r.constraint_violation, kRelaxedBoundViolation);
  EXPECT_LT(r.iterations, 20);
}

// Assembled derivatives against central differences of the assembled values.
TEST(Nlp, AssembledDerivativesMatchFiniteDifferences) {
  const Nlp nlp = Hs071();
  const Eigen::Vector4d w(1.3, 4.2, 3.7, 1.9);
  const Eigen::Vector2d lambda(0.7, -1.1);
  const double sigma = 0.9;
  constexpr double kStep = 1e-6;
  constexpr double kFdTolerance = 1e-6;  // central differences, O(h^2) ~ 1e-12 relative
  Eigen::Vector4d grad;
  ASSERT_TRUE(nlp.Gradient(w.data(), grad.data()).ok);
  Eigen::VectorXd jac(nlp.JacobianRows().size());
  ASSERT_TRUE(nlp.JacobianValues(w.data(), jac.data()).ok);
  Eigen::MatrixXd dense_jac = Eigen::MatrixXd::Zero(2, 4);
  for (std::size_t k = 0; k < nlp.JacobianRows().size(); ++k) {
    dense_jac(nlp.JacobianRows()[k], nlp.JacobianCols()[k]) += jac[k];
  }
  Eigen::VectorXd hess(nlp.HessianRows().size());
  ASSERT_TRUE(nlp.HessianValues(w.data(), sigma, lambda.data(), hess.data()).ok);
  Eigen::Matrix4d dense_hess = Eigen::Matrix4d::Zero();
  for (std::size_t k = 0; k < nlp.HessianRows().size(); ++k) {
    EXPECT_GE(nlp.HessianRows()[k], nlp.HessianCols()[k]);
    dense_hess(nlp.HessianRows()[k], nlp.HessianCols()[k]) += hess[k];
    if (nlp.HessianRows()[k] != nlp.HessianCols()[k]) {
      dense_hess(nlp.HessianCols()[k], nlp.HessianRows()[k]) += hess[k];
    }
  }
  for (int j = 0; j < 4; ++j) {
    Eigen::Vector4d wp = w, wm = w;
    wp[j] += kStep;
    wm[j] -= kStep;
    double fp, fm;
    Eigen::Vector2d gp, gm;
    Eigen::Vector4d dp, dm;
    nlp.Objective(wp.data(), &fp);
    nlp.Objective(wm.data(), &fm);
    nlp.Constraints(wp.data(), gp.data());
    nlp.Constraints(wm.data(), gm.data());
    nlp.Gradient(wp.data(), dp.data());
    nlp.Gradient(wm.data(), dm.data());
    EXPECT_NEAR(grad[j], (fp - fm) / (2 * kStep), kFdTolerance * (1 + std::fabs(grad[j])));
    for (int i = 0; i < 2; ++i) {
      EXPECT_NEAR(dense_jac(i, j), (gp[i] - gm[i]) / (2 * kStep),
                  kFdTolerance * (1 + std::fabs(dense_jac(i, j))));
    }
    // Hessian column j of sigma f + lambda^T g: FD of the Lagrangian gradient.
    Eigen::VectorXd jp(nlp.JacobianRows().size()), jm(nlp.JacobianRows().size());
    nlp.JacobianValues(wp.data(), jp.data());
    nlp.JacobianValues(wm.data(), jm.data());
    Eigen::Vector4d lgp = sigma * dp, lgm = sigma * dm;
    for (std::size_t k = 0; k < nlp.JacobianRows().size(); ++k) {
      lgp[nlp.JacobianCols()[k]] += lambda[nlp.JacobianRows()[k]] * jp[k];
      lgm[nlp.JacobianCols()[k]] += lambda[nlp.JacobianRows()[k]] * jm[k];
    }
    for (int i = 0; i < 4; ++i) {
      EXPECT_NEAR(dense_hess(i, j), (lgp[i] - lgm[i]) / (2 * kStep),
                  kFdTolerance * (1 + std::fabs(dense_hess(i, j))));
    }
  }
}

TEST(Nlp, IpoptAndCeresAgreeOnLeastSquares) {
  std::mt19937 rng(kSeed);
  const Nlp nlp = ExponentialFit(200, 0.01, &rng);
  const SolverResult ipopt = SolveWithIpopt(nlp);
  const SolverResult ceres = SolveWithCeres(nlp);
  ASSERT_TRUE(ipopt.success) << ipopt.FullReport();
  ASSERT_TRUE(ceres.success) << ceres.FullReport();
  constexpr double kAgreement = 1e-6;  // both converge to the same minimiser to ~1e-8
  EXPECT_NEAR(ipopt.w[0], ceres.w[0], kAgreement);
  EXPECT_NEAR(ipopt.w[1], ceres.w[1], kAgreement);
  EXPECT_NEAR(ipopt.cost, ceres.cost, kAgreement * ipopt.cost);
  constexpr double kRecovery = 0.02;  // noise 0.01 on 200 samples
  EXPECT_NEAR(ceres.w[0], 1.5, kRecovery);
  EXPECT_NEAR(ceres.w[1], -0.7, kRecovery);
}

// f = x^4 / 4 - x^2 / 2 from x = 0.1, where f'' = 3 x^2 - 1 < 0: Ipopt perturbs the Hessian to
// take its first step (IterationSummary::hessian_perturbation > 0) and none near the minimum x = 1,
// where f'' = 2.
TEST(Nlp, IpoptReportsItsHessianPerturbationPerIteration) {
  const std::vector<Expr> z = Expr::Symbols("x", 1);
  const Function fn("double_well", {{"z", z}, {"d", {}}},
                    {{"f", {0.25 * z[0] * z[0] * z[0] * z[0] - 0.5 * z[0] * z[0]}}});
  Nlp nlp(Eigen::VectorXd::Constant(1, 0.1), Eigen::VectorXd::Constant(1, -1e20),
          Eigen::VectorXd::Constant(1, 1e20));
  nlp.AddGroup({"double_well", fn, Eigen::MatrixXi::Zero(1, 1), Eigen::MatrixXd(0, 1),
                Eigen::VectorXd(0), Eigen::VectorXd(0)});
  const SolverResult r = SolveWithIpopt(nlp);
  ASSERT_TRUE(r.success) << r.FullReport();
  constexpr double kMinimumTolerance = 1e-6;
  EXPECT_NEAR(r.w[0], 1.0, kMinimumTolerance);
  ASSERT_GE(r.history.size(), 2u);
  EXPECT_GT(r.history[1].hessian_perturbation, 0.0) << "the first step needs a perturbed Hessian";
  EXPECT_EQ(r.history.back().hessian_perturbation, 0.0);
  for (const IterationSummary& it : r.history) EXPECT_FALSE(it.restoration);
}

// log(x) is NaN for x < 0: a trial step there must make Ipopt back off, not crash.
TEST(Nlp, NonFiniteTrialPointsAreReturnedToTheSolver) {
  const std::vector<Expr> z = Expr::Symbols("x", 1);
  const Function fn("log", {{"z", z}, {"d", {}}}, {{"f", {square(log(z[0]) - 1.0) + 0.01 / z[0]}}});
  Nlp nlp(Eigen::VectorXd::Constant(1, 0.05), Eigen::VectorXd::Constant(1, -1e20),
          Eigen::VectorXd::Constant(1, 1e20));
  ElementGroup g{"log",
                 fn,
                 Eigen::MatrixXi::Zero(1, 1),
                 Eigen::MatrixXd(0, 1),
                 Eigen::VectorXd(0),
                 Eigen::VectorXd(0)};
  nlp.AddGroup(g);
  double f = 0.0;
  const double bad = -1.0;
  const NlpEvalStatus s = nlp.Objective(&bad, &f);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("group 'log' instance 0"), std::string::npos) << s.message;
  const SolverResult r = SolveWithIpopt(nlp);
  EXPECT_TRUE(r.success) << r.FullReport();
  EXPECT_GT(r.w[0], 0.0);
}

// One group of kInstances elements (more than two of the Nlp's batches of 128 instances, so full
// batches and a shorter last one): z = (a, x_e) with a shared, d = (t_e, y_e);
// f_e = 0.1 sin(a x_e), c_e = x_e - a t_e, r_e = a exp(x_e t_e) - y_e + log(x_e).
constexpr int kInstances = 300;
double ElementF(double a, double x) { return 0.1 * std::sin(a * x); }
double ElementC(double a, double x, double t) { return x - a * t; }
double ElementR(double a, double x, double t, double y) {
  return a * std::exp(x * t) - y + std::log(x);
}

Nlp ManyInstances() {
  const std::vector<Expr> z = Expr::Symbols("ax", 2);
  const std::vector<Expr> d = Expr::Symbols("ty", 2);
  const Function fn("element", {{"z", z}, {"d", d}},
                    {{"f", {0.1 * sin(z[0] * z[1])}},
                     {"c", {z[1] - z[0] * d[0]}},
                     {"r", {z[0] * exp(z[1] * d[0]) - d[1] + log(z[1])}}});
  Eigen::VectorXd w0(1 + kInstances);
  w0[0] = 0.8;
  for (int e = 0; e < kInstances; ++e) w0[1 + e] = 0.5 + 0.003 * e;
  Nlp nlp(w0, Eigen::VectorXd::Constant(w0.size(), -1e20),
          Eigen::VectorXd::Constant(w0.size(), 1e20));
  ElementGroup g;
  g.name = "many";
  g.fn = fn;
  g.index = Eigen::MatrixXi(2, kInstances);
  g.data = Eigen::MatrixXd(2, kInstances);
  for (int e = 0; e < kInstances; ++e) {
    g.index(0, e) = 0;
    g.index(1, e) = 1 + e;
    g.data(0, e) = 0.01 * e;
    g.data(1, e) = std::cos(0.05 * e);
  }
  g.lbc = Eigen::VectorXd::Zero(1);
  g.ubc = Eigen::VectorXd::Zero(1);
  nlp.AddGroup(g);
  return nlp;
}

// The instances are evaluated in batches (several points per tape instruction): values equal the
// element formulas in doubles to rounding in every batch, the derivatives pass the
// finite-difference checks, and a non-finite value names its instance.
TEST(Nlp, BatchedInstancesMatchTheElementFormulas) {
  constexpr double kRounding = 1e-13;  // relative; the batch tape may round differently
  const Nlp nlp = ManyInstances();
  const Eigen::VectorXd w = nlp.w0();
  const double a = w[0];
  double f = 0.0, f_expected = 0.0;
  ASSERT_TRUE(nlp.Objective(w.data(), &f).ok);
  Eigen::VectorXd c(kInstances), r(kInstances);
  ASSERT_TRUE(nlp.Constraints(w.data(), c.data()).ok);
  ASSERT_TRUE(nlp.Residuals(w.data(), r.data()).ok);
  for (int e = 0; e < kInstances; ++e) {
    const double x = w[1 + e], t = 0.01 * e, y = std::cos(0.05 * e);
    const double re = ElementR(a, x, t, y);
    f_expected += ElementF(a, x) + 0.5 * re * re;
    EXPECT_NEAR(c[e], ElementC(a, x, t), kRounding * std::max(1.0, std::fabs(c[e]))) << e;
    EXPECT_NEAR(r[e], re, kRounding * std::max(1.0, std::fabs(re))) << e;
  }
  EXPECT_NEAR(f, f_expected, kRounding * std::fabs(f_expected));
  NlpDerivativeCheckOptions check;
  check.leading_columns = 1;
  check.sampled_columns = 40;  // instances spread over every batch
  for (const auto& result : CheckNlpDerivatives(nlp, w, check)) {
    EXPECT_TRUE(result.ok) << result.FullReport();
    EXPECT_GT(result.entries_checked, 0) << result.what;
  }
  Eigen::VectorXd bad = w;
  bad[1 + 200] = -1.0;  // log of a negative number in instance 200 (the second batch)
  const NlpEvalStatus s = nlp.Residuals(bad.data(), r.data());
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("group 'many' instance 200:"), std::string::npos) << s.message;
  Eigen::VectorXd h(nlp.HessianRows().size());
  const Eigen::VectorXd lambda = Eigen::VectorXd::Ones(kInstances);
  const NlpEvalStatus hs = nlp.HessianValues(bad.data(), 1.0, lambda.data(), h.data());
  EXPECT_FALSE(hs.ok);
  EXPECT_NE(hs.message.find("group 'many' instance 200:"), std::string::npos) << hs.message;
}

TEST(Nlp, InfeasibleBoundsAndBadSizesAreRejected) {
  Nlp nlp(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1), {"a", "b"});
  try {
    nlp.CheckBounds();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("variable 'a': infeasible bounds"), std::string::npos)
        << e.what();
  }
  const std::vector<Expr> z = Expr::Symbols("x", 2);
  ElementGroup g{"g",
                 Function("f", {{"z", z}, {"d", {}}}, {{"r", {z[0]}}}),
                 Eigen::MatrixXi::Zero(3, 1),
                 Eigen::MatrixXd(0, 1),
                 Eigen::VectorXd(0),
                 Eigen::VectorXd(0)};
  EXPECT_THROW(nlp.AddGroup(g), std::invalid_argument);  // index has 3 rows, z has 2
  g.index = Eigen::MatrixXi::Zero(2, 1);                 // reads variable 0 twice
  EXPECT_THROW(nlp.AddGroup(g), std::invalid_argument);
  IpoptOptions bad;
  bad.pass_through["mu_stratgy"] = "adaptive";
  const Nlp hs = Hs071();
  try {
    SolveWithIpopt(hs, bad);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'mu_strategy'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace graybox::estimators
