// Tests of the linear-in-parameters form (regressor.h): Y theta equals the recursive Newton-Euler
// inverse dynamics on random chains in both DH conventions, the parameter vector round-trips to
// the chain's bodies, and dynamics with SYMBOLIC inertial parameters agree with the numeric ones
// (the Jacobian of the symbolic tau with respect to theta is Y).
#include "graybox/models/regressor.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/expr/function.h"
#include "graybox/models/kuka_kr300.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using expr::Expr;
using expr::Function;
using testing::RandomChain;
using testing::RandomVector;
using testing::TestSeed;

// Y theta and the Newton-Euler recursion are two different summation orders of the same products:
// rounding only, ~1e-16 per operation times a few hundred operations, relative to the largest
// torque. The brief asks for 1e-12.
constexpr double kRegressorRelTol = 1e-12;
// Symbolic versus numeric evaluation of the same template: the tape performs the same IEEE
// operations up to reassociation by simplification, so the results agree to a few ulps.
constexpr double kSymbolicRelTol = 1e-12;
constexpr int kNumDraws = 20;

// max |a - b| <= tol * max(1, max |a|, max |b|).
::testing::AssertionResult NearRel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << "size mismatch " << a.rows() << "x" << a.cols()
                                         << " vs " << b.rows() << "x" << b.cols();
  }
  const double scale = std::max({1.0, a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()});
  const double err = (a - b).cwiseAbs().maxCoeff();
  if (err <= tol * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "max difference " << err << " > " << tol * scale;
}

std::vector<SerialChain> TestChains(std::mt19937& rng) {
  std::vector<SerialChain> chains;
  for (DhConvention c : {DhConvention::kStandard, DhConvention::kModified}) {
    chains.push_back(RandomChain(rng, 1, c));
    chains.push_back(RandomChain(rng, 2, c));
    chains.push_back(RandomChain(rng, 4, c, 2));  // joints 2 and 4 prismatic
    chains.push_back(RandomChain(rng, 6, c, 3));
    chains.push_back(RandomChain(rng, kMaxDof, c, 5));
  }
  chains.push_back(KukaKr300R2500());
  return chains;
}

TEST(Regressor, TimesParametersEqualsNewtonEulerOnRandomChains) {
  std::mt19937 rng(TestSeed());
  double worst = 0.0;  // max relative difference, printed for the record
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " " + ToString(chain.convention()) + " dof " +
                 std::to_string(chain.dof()));
    const int n = chain.dof();
    for (int k = 0; k < kNumDraws; ++k) {
      const JointVector<double> q = RandomVector(rng, n, -3.0, 3.0);
      const JointVector<double> qd = RandomVector(rng, n, -2.0, 2.0);
      const JointVector<double> qdd = RandomVector(rng, n, -5.0, 5.0);
      const Eigen::VectorXd tau = InverseDynamics(chain, q, qd, qdd);

      const auto y = Regressor(chain, q, qd, qdd);
      ASSERT_EQ(y.rows(), n);
      ASSERT_EQ(y.cols(), 11 * n);
      const Eigen::VectorXd theta = InertialParameters(chain);
      EXPECT_TRUE(NearRel(Eigen::MatrixXd(y) * theta, tau, kRegressorRelTol));
      worst = std::max(worst, (Eigen::MatrixXd(y) * theta - tau).cwiseAbs().maxCoeff() /
                                  std::max(1.0, tau.cwiseAbs().maxCoeff()));

      // Without rotor columns: tau = Y theta + diag(I_a) qdd.
      const auto y10 = Regressor(chain, q, qd, qdd, InertialParameterSet::kRigidBody);
      ASSERT_EQ(y10.cols(), 10 * n);
      const Eigen::VectorXd theta10 = InertialParameters(chain, InertialParameterSet::kRigidBody);
      Eigen::VectorXd rotor(n);
      for (int i = 0; i < n; ++i) rotor[i] = chain.link(i).rotor_inertia * qdd[i];
      EXPECT_TRUE(NearRel(Eigen::MatrixXd(y10) * theta10 + rotor, tau, kRegressorRelTol));
    }
  }
  std::cout << "[ info     ] max |Y theta - RNEA| / max(1, |tau|) = " << worst << "\n";
}

// Linearity in the parameters, checked with parameters that are NOT the chain's: Y theta equals
// the Newton-Euler recursion on the bodies built from an arbitrary theta.
TEST(Regressor, LinearInArbitraryParameters) {
  std::mt19937 rng(TestSeed());
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " " + ToString(chain.convention()));
    const int n = chain.dof();
    for (int k = 0; k < 5; ++k) {
      const Eigen::VectorXd theta = RandomVector(rng, 11 * n, -1.0, 1.0);
      const auto bodies = BodiesFromInertialParameters<double>(chain, theta);
      const JointVector<double> q = RandomVector(rng, n, -3.0, 3.0);
      const JointVector<double> qd = RandomVector(rng, n, -2.0, 2.0);
      const JointVector<double> qdd = RandomVector(rng, n, -5.0, 5.0);
      const Eigen::VectorXd tau = InverseDynamics(chain, bodies, q, qd, qdd);
      EXPECT_TRUE(
          NearRel(Eigen::MatrixXd(Regressor(chain, q, qd, qdd)) * theta, tau, kRegressorRelTol));
    }
  }
}

TEST(InertialParameters, RoundTripToTheChainBodies) {
  std::mt19937 rng(TestSeed());
  for (const SerialChain& chain : TestChains(rng)) {
    for (InertialParameterSet set :
         {InertialParameterSet::kRigidBody, InertialParameterSet::kWithRotorInertia}) {
      const auto bodies = BodiesFromInertialParameters<double>(
          chain, Eigen::VectorXd(InertialParameters(chain, set)), set);
      for (int i = 0; i < chain.dof(); ++i) {
        const BodyParameters<double>& expected = chain.body(i);
        const BodyParameters<double>& got = bodies[static_cast<std::size_t>(i)];
        EXPECT_NEAR(got.mass, expected.mass, 1e-15 * expected.mass);
        EXPECT_TRUE(NearRel(got.first_moment, expected.first_moment, kRegressorRelTol));
        EXPECT_TRUE(NearRel(got.inertia, expected.inertia, kRegressorRelTol));
        EXPECT_EQ(got.rotor_inertia, expected.rotor_inertia);
      }
    }
  }
}

TEST(InertialParameters, NamesUnitsAndOrder) {
  const SerialChain kuka = KukaKr300R2500();
  const auto names = InertialParameterNames(kuka, InertialParameterSet::kWithRotorInertia);
  ASSERT_EQ(names.size(), 66u);
  EXPECT_EQ(names[0], "l1.m");
  EXPECT_EQ(names[1], "l1.mcx");
  EXPECT_EQ(names[4], "l1.Ixx");
  EXPECT_EQ(names[5], "l1.Ixy");
  EXPECT_EQ(names[9], "l1.Izz");
  EXPECT_EQ(names[10], "l1.Ia");
  EXPECT_EQ(names[11], "l2.m");
  EXPECT_EQ(names[65], "l6.Ia");
  const auto units = InertialParameterUnits(kuka, InertialParameterSet::kRigidBody);
  ASSERT_EQ(units.size(), 60u);
  EXPECT_EQ(units[0], "kg");
  EXPECT_EQ(units[2], "kg m");
  EXPECT_EQ(units[9], "kg m^2");
  // The KUKA table, read about the link origin, is theta itself (kuka_kr300.h).
  const Eigen::VectorXd theta = InertialParameters(kuka);
  EXPECT_EQ(theta[0], 395.40);
  EXPECT_DOUBLE_EQ(theta[kFirstMomentX], 395.40 * -0.353);
  EXPECT_EQ(theta[kInertiaYY], 29.799119);
  EXPECT_EQ(theta[kInertiaXZ], 4.404062);
  EXPECT_DOUBLE_EQ(theta[kRotorInertia], 0.00923 * kKukaGearRatios[0] * kKukaGearRatios[0]);
}

TEST(InertialParameters, WrongSizeThrows) {
  const SerialChain kuka = KukaKr300R2500();
  try {
    BodiesFromInertialParameters<double>(kuka, Eigen::VectorXd::Zero(60));
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("expected theta of size 66"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(Regressor<double>(kuka, Eigen::VectorXd::Zero(5), Eigen::VectorXd::Zero(6),
                                 Eigen::VectorXd::Zero(6)),
               std::invalid_argument);
}

// Inverse dynamics, mass matrix and forward dynamics with the inertial parameters as symbols:
// one Function of (q, qd, qdd or tau, theta) agrees with the numeric evaluation, and d tau/d theta
// is the regressor.
TEST(SymbolicParameters, DynamicsAgreeWithNumericAndJacobianIsTheRegressor) {
  std::mt19937 rng(TestSeed());
  std::vector<SerialChain> chains;
  chains.push_back(RandomChain(rng, 3, DhConvention::kStandard, 2));
  chains.push_back(RandomChain(rng, 4, DhConvention::kModified, 3));
  chains.push_back(KukaKr300R2500());
  for (const SerialChain& chain : chains) {
    SCOPED_TRACE(chain.name() + " " + ToString(chain.convention()));
    const int n = chain.dof();
    const int np = NumInertialParameters(chain, InertialParameterSet::kWithRotorInertia);
    const std::vector<Expr> qs = Expr::Symbols("q", n), qds = Expr::Symbols("qd", n),
                            as = Expr::Symbols("a", n), ps = Expr::Symbols("theta", np);
    const JointVector<Expr> q = Eigen::Map<const JointVector<Expr>>(qs.data(), n);
    const JointVector<Expr> qd = Eigen::Map<const JointVector<Expr>>(qds.data(), n);
    const JointVector<Expr> a = Eigen::Map<const JointVector<Expr>>(as.data(), n);
    const BodyParameterArray<Expr> bodies =
        BodiesFromInertialParameters(chain, ps.data(), InertialParameterSet::kWithRotorInertia);
    const JointVector<Expr> tau = InverseDynamics(chain, bodies, q, qd, a);
    const JointVector<Expr> qdd = ForwardDynamics(chain, bodies, q, qd, a);  // a read as torque
    const JointMatrix<Expr> m = MassMatrix(chain, bodies, q);
    std::vector<Expr> m_entries(m.data(), m.data() + n * n);
    const Function f("dyn", {{"q", qs}, {"qd", qds}, {"a", as}, {"theta", ps}},
                     {{"tau", std::vector<Expr>(tau.data(), tau.data() + n)},
                      {"qdd", std::vector<Expr>(qdd.data(), qdd.data() + n)},
                      {"m", m_entries}});
    const Function jac = f.Jacobian("tau", "theta");
    for (int k = 0; k < 3; ++k) {
      // Parameters near the chain's (so M stays positive definite), arbitrary states.
      Eigen::VectorXd theta = InertialParameters(chain);
      for (int j = 0; j < np; ++j) theta[j] *= 1.0 + 0.05 * testing::Uniform(rng, -1.0, 1.0);
      const Eigen::VectorXd qv = RandomVector(rng, n, -3.0, 3.0);
      const Eigen::VectorXd qdv = RandomVector(rng, n, -2.0, 2.0);
      const Eigen::VectorXd av = RandomVector(rng, n, -5.0, 5.0);
      const auto out = f({qv, qdv, av, theta});
      const auto nb = BodiesFromInertialParameters<double>(chain, theta);
      const JointVector<double> qj = qv, qdj = qdv, aj = av;
      EXPECT_TRUE(NearRel(out[0], Eigen::VectorXd(InverseDynamics(chain, nb, qj, qdj, aj)),
                          kSymbolicRelTol));
      EXPECT_TRUE(NearRel(out[1], Eigen::VectorXd(ForwardDynamics(chain, nb, qj, qdj, aj)),
                          kSymbolicRelTol));
      const Eigen::MatrixXd mv = MassMatrix(chain, nb, qj);
      EXPECT_TRUE(
          NearRel(Eigen::Map<const Eigen::MatrixXd>(out[2].data(), n, n), mv, kSymbolicRelTol));
      // The Jacobian (sparse, CCS) densified equals Y.
      const auto jv = jac({qv, qdv, av, theta});
      const expr::Sparsity& sp = jac.OutputSparsity(0);
      Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, np);
      for (int c = 0; c < np; ++c) {
        for (int e = sp.colind()[c]; e < sp.colind()[c + 1]; ++e) dense(sp.row()[e], c) = jv[0][e];
      }
      EXPECT_TRUE(NearRel(dense, Eigen::MatrixXd(Regressor(chain, qj, qdj, aj)), kSymbolicRelTol));
    }
  }
}

// The symbolic regressor (Scalar = Expr) evaluates to the numeric one.
TEST(Regressor, SymbolicEqualsNumeric) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = RandomChain(rng, 3, DhConvention::kStandard, 3);
  const int n = chain.dof();
  const std::vector<Expr> x = Expr::Symbols("x", 3 * n);
  const JointVector<Expr> q = Eigen::Map<const JointVector<Expr>>(x.data(), n);
  const JointVector<Expr> qd = Eigen::Map<const JointVector<Expr>>(x.data() + n, n);
  const JointVector<Expr> qdd = Eigen::Map<const JointVector<Expr>>(x.data() + 2 * n, n);
  const auto y = Regressor(chain, q, qd, qdd);
  const Function f("y", {{"x", x}},
                   {{"y", std::vector<Expr>(y.data(), y.data() + y.rows() * y.cols())}});
  const Eigen::VectorXd xv = RandomVector(rng, 3 * n, -2.0, 2.0);
  const Eigen::VectorXd yv = f({xv})[0];
  const JointVector<double> qv = xv.head(n), qdv = xv.segment(n, n), qddv = xv.tail(n);
  EXPECT_TRUE(NearRel(Eigen::Map<const Eigen::MatrixXd>(yv.data(), n, 11 * n),
                      Eigen::MatrixXd(Regressor(chain, qv, qdv, qddv)), kSymbolicRelTol));
}

}  // namespace
}  // namespace graybox::models
