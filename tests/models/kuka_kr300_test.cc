// Tests of the KUKA KR300 R2500 roblue model: constants and counterbalance against SOURCE.md, the
// symbolic (graybox::expr::Expr) instantiation against the double one, and its derivatives against
// finite differences.
#include "graybox/models/kuka_kr300.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "graybox/expr.h"
#include "graybox/models/rigid_body_dynamics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using expr::Expr;
using expr::Function;
using testing::RandomVector;
using testing::TestSeed;

constexpr double kDegree = kKukaPi / 180.0;

// SOURCE.md rounds its example torques to 1 N m.
constexpr double kHwcExampleTolNm = 1.0;
// The tape evaluates the same operations as the double code, in a different order (hash-consing
// shares subexpressions, constants are folded), so results agree to a few hundred ulps.
constexpr double kSymbolicRelTol = 1e-12;
constexpr int kNumDraws = 20;

TEST(KukaKr300, ConstantsMatchSource) {
  const SerialChain chain = KukaKr300R2500();
  ASSERT_EQ(chain.dof(), 6);
  EXPECT_EQ(chain.convention(), DhConvention::kStandard);
  EXPECT_EQ(chain.gravity(), Eigen::Vector3d(0.0, 0.0, 9.81));
  EXPECT_DOUBLE_EQ(chain.link(0).gear_ratio, 256.857142857142857);
  EXPECT_DOUBLE_EQ(chain.link(5).gear_ratio, 154.323134328358209);
  EXPECT_DOUBLE_EQ(chain.link(0).rotor_inertia,
                   0.00923 * 256.857142857142857 * 256.857142857142857);
  EXPECT_DOUBLE_EQ(chain.link(5).mass, 167.78);
  EXPECT_DOUBLE_EQ(chain.link(5).center_of_mass.z(), (15000.0 - 17.78 * 50.0) / 167.78 * 1e-3);
  EXPECT_DOUBLE_EQ(chain.link(2).theta, kKukaPi);  // DH q3 + pi/2 with q3_global = q3 + pi/2
  EXPECT_DOUBLE_EQ(chain.link(1).theta, -kKukaPi / 2);
  EXPECT_DOUBLE_EQ(chain.link(1).inertia(0, 2), -4.396607);  // L2xz
  EXPECT_DOUBLE_EQ(chain.link(2).inertia(1, 2), -0.606384);  // L3yz
  EXPECT_EQ(chain.link(0).inertia_reference, InertiaReference::kLinkOrigin);
  // The 200 kg payload of the MATLAB model.
  EXPECT_DOUBLE_EQ(KukaKr300R2500(200.0).link(5).mass, 217.78);
}

TEST(KukaKr300, HwcTorqueMatchesSourceExamples) {
  struct Example {
    double q2_global_deg, torque_nm;
  };
  for (const Example& e : {Example{-90.0, 632.0}, Example{-60.0, 4197.0}, Example{-120.0, -3074.0},
                           Example{-140.0, -5235.0}}) {
    const double tau = KukaHwcTorque(e.q2_global_deg * kDegree);
    std::cout << "[ hwc      ] q2_global = " << e.q2_global_deg << " deg: " << tau << " N m\n";
    EXPECT_NEAR(tau, e.torque_nm, kHwcExampleTolNm) << "q2_global = " << e.q2_global_deg;
  }
}

TEST(KukaKr300, ForwardDynamicsInvertsInverseDynamics) {
  std::mt19937 rng(TestSeed());
  // cond(M) ~ 1e3 for the KUKA: the round trip loses three digits.
  constexpr double kRoundTripRelTol = 1e-10;
  for (int k = 0; k < kNumDraws; ++k) {
    const Eigen::VectorXd q = RandomVector(rng, 6, -1.5, 1.5);
    const Eigen::VectorXd qd = RandomVector(rng, 6, -1.0, 1.0);
    const Eigen::VectorXd qdd = RandomVector(rng, 6, -3.0, 3.0);
    const Eigen::VectorXd tau_m = KukaInverseDynamics<double>(q, qd, qdd);
    const Eigen::VectorXd qdd2 = KukaForwardDynamics<double>(q, qd, tau_m);
    EXPECT_LT((qdd2 - qdd).cwiseAbs().maxCoeff(), kRoundTripRelTol * (1.0 + qdd.norm()));
  }
}

// The symbolic forward and inverse models as Functions of (q, qd, tau_m) and (q, qd, qdd).
struct SymbolicKuka {
  Function forward, inverse;
};

SymbolicKuka BuildSymbolicKuka() {
  const expr::ExprVector q = expr::SymbolVector("q", 6), qd = expr::SymbolVector("qd", 6);
  const expr::ExprVector tau = expr::SymbolVector("tau_m", 6), qdd = expr::SymbolVector("qdd", 6);
  const JointVector<Expr> fwd = KukaForwardDynamics<Expr>(q, qd, tau);
  const JointVector<Expr> inv = KukaInverseDynamics<Expr>(q, qd, qdd);
  SymbolicKuka s;
  s.forward = Function("kuka_forward_dynamics",
                       {{"q", expr::ToStdVector(q)},
                        {"qd", expr::ToStdVector(qd)},
                        {"tau_m", expr::ToStdVector(tau)}},
                       {{"qdd", expr::ToStdVector(fwd)}});
  s.inverse = Function(
      "kuka_inverse_dynamics",
      {{"q", expr::ToStdVector(q)}, {"qd", expr::ToStdVector(qd)}, {"qdd", expr::ToStdVector(qdd)}},
      {{"tau_m", expr::ToStdVector(inv)}});
  return s;
}

const SymbolicKuka& Symbolic() {
  static const SymbolicKuka s = BuildSymbolicKuka();
  return s;
}

double MaxRelDiff(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

TEST(KukaKr300, SymbolicInstantiationEqualsDouble) {
  const SymbolicKuka& s = Symbolic();
  std::cout << "[ sizes    ] forward: " << s.forward.NumNodes() << " nodes, "
            << s.forward.NumInstructions() << " instructions; inverse: " << s.inverse.NumNodes()
            << " nodes, " << s.inverse.NumInstructions() << " instructions\n";
  std::mt19937 rng(TestSeed());
  double worst_fwd = 0.0, worst_inv = 0.0;
  for (int k = 0; k < kNumDraws; ++k) {
    const Eigen::VectorXd q = RandomVector(rng, 6, -1.5, 1.5);
    const Eigen::VectorXd qd = RandomVector(rng, 6, -1.0, 1.0);
    const Eigen::VectorXd tau_m = RandomVector(rng, 6, -20.0, 20.0);
    const Eigen::VectorXd qdd = RandomVector(rng, 6, -3.0, 3.0);
    const Eigen::VectorXd fwd_sym = s.forward({q, qd, tau_m})[0];
    const Eigen::VectorXd fwd_num = KukaForwardDynamics<double>(q, qd, tau_m);
    const Eigen::VectorXd inv_sym = s.inverse({q, qd, qdd})[0];
    const Eigen::VectorXd inv_num = KukaInverseDynamics<double>(q, qd, qdd);
    worst_fwd = std::max(worst_fwd, MaxRelDiff(fwd_sym, fwd_num));
    worst_inv = std::max(worst_inv, MaxRelDiff(inv_sym, inv_num));
  }
  std::cout << "[ symbolic ] max relative difference: forward " << worst_fwd << ", inverse "
            << worst_inv << "\n";
  EXPECT_LT(worst_fwd, kSymbolicRelTol);
  EXPECT_LT(worst_inv, kSymbolicRelTol);
}

TEST(KukaKr300, ForwardDynamicsJacobianMatchesFiniteDifferences) {
  const SymbolicKuka& s = Symbolic();
  std::mt19937 rng(TestSeed());
  for (int k = 0; k < 3; ++k) {
    const std::vector<Eigen::VectorXd> point = {RandomVector(rng, 6, -1.5, 1.5),
                                                RandomVector(rng, 6, -1.0, 1.0),
                                                RandomVector(rng, 6, -20.0, 20.0)};
    for (const char* input : {"q", "qd", "tau_m"}) {
      // Default options: central differences with h = cbrt(eps) max(1, |x|), tolerance 1e-6 on
      // |analytic - fd| / max(1, |analytic|) (see derivative_check.h for the error budget).
      const expr::DerivativeCheckResult r = expr::CheckJacobian(s.forward, "qdd", input, point);
      std::cout << "[ jacobian ] " << r.BriefReport() << "\n";
      EXPECT_TRUE(r.ok) << r.FullReport();
    }
  }
}

TEST(KukaKr300, InverseDynamicsJacobianMatchesFiniteDifferences) {
  const SymbolicKuka& s = Symbolic();
  std::mt19937 rng(TestSeed());
  const std::vector<Eigen::VectorXd> point = {RandomVector(rng, 6, -1.5, 1.5),
                                              RandomVector(rng, 6, -1.0, 1.0),
                                              RandomVector(rng, 6, -3.0, 3.0)};
  for (const char* input : {"q", "qd", "qdd"}) {
    const expr::DerivativeCheckResult r = expr::CheckJacobian(s.inverse, "tau_m", input, point);
    std::cout << "[ jacobian ] " << r.BriefReport() << "\n";
    EXPECT_TRUE(r.ok) << r.FullReport();
  }
}

TEST(KukaKr300, MassMatrixIsPositiveDefiniteOverTheWorkspace) {
  std::mt19937 rng(TestSeed());
  const SerialChain chain = KukaKr300R2500();
  for (int k = 0; k < 200; ++k) {
    const Eigen::VectorXd q = RandomVector(rng, 6, -kKukaPi, kKukaPi);
    const Eigen::MatrixXd m = MassMatrix<double>(chain, q);
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues()[0], 0.0);
  }
}

}  // namespace
}  // namespace graybox::models
