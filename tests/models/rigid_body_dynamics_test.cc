// Tests of the generic rigid-body recursions on double: structural properties of M, consistency of
// the Newton-Euler and composite-rigid-body algorithms, a closed-form double pendulum, both DH
// conventions, prismatic joints, and energy conservation.
#include "graybox/models/rigid_body_dynamics.h"

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "graybox/models/kuka_kr300.h"
#include "graybox/models/serial_chain.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using testing::RandomChain;
using testing::RandomVector;
using testing::TestSeed;

// Two evaluations of the same quantity by different algorithms (CRBA vs RNEA, standard vs
// modified DH, closed form vs recursion) agree to rounding: ~1e-16 times the magnitudes involved
// times a few hundred flops.
constexpr double kAlgorithmRelTol = 1e-12;
// Random configurations per property.
constexpr int kNumDraws = 25;

// |a - b| <= tol * max(1, |a|, |b|) elementwise, with a message naming the entry.
::testing::AssertionResult NearRel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << "size mismatch";
  }
  const double scale = std::max({1.0, a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff()});
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.cols(); ++j) {
      if (!(std::fabs(a(i, j) - b(i, j)) <= tol * scale)) {
        return ::testing::AssertionFailure()
               << "entry (" << i << "," << j << "): " << a(i, j) << " vs " << b(i, j)
               << ", difference " << std::fabs(a(i, j) - b(i, j)) << " > " << tol * scale;
      }
    }
  }
  return ::testing::AssertionSuccess();
}

std::vector<SerialChain> TestChains(std::mt19937& rng) {
  std::vector<SerialChain> chains;
  chains.push_back(RandomChain(rng, 1, DhConvention::kStandard));
  chains.push_back(RandomChain(rng, 3, DhConvention::kStandard, 2));
  chains.push_back(RandomChain(rng, 6, DhConvention::kModified, 3));
  chains.push_back(RandomChain(rng, kMaxDof, DhConvention::kStandard, 4));
  chains.push_back(KukaKr300R2500());
  chains.push_back(KukaKr300R2500(0.0, InertiaReference::kCenterOfMass));
  return chains;
}

TEST(MassMatrix, SymmetricPositiveDefiniteOnRandomConfigurations) {
  std::mt19937 rng(TestSeed());
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " dof " + std::to_string(chain.dof()));
    for (int k = 0; k < kNumDraws; ++k) {
      const Eigen::VectorXd q = RandomVector(rng, chain.dof(), -3.0, 3.0);
      const Eigen::MatrixXd m = MassMatrix<double>(chain, q);
      EXPECT_TRUE(NearRel(m, m.transpose(), 0.0)) << "M is built exactly symmetric";
      const double min_eig = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues()[0];
      EXPECT_GT(min_eig, 0.0);
    }
  }
}

TEST(InverseDynamics, EqualsMassMatrixTimesAccelerationPlusBias) {
  std::mt19937 rng(TestSeed());
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " dof " + std::to_string(chain.dof()));
    const int n = chain.dof();
    for (int k = 0; k < kNumDraws; ++k) {
      const Eigen::VectorXd q = RandomVector(rng, n, -3.0, 3.0);
      const Eigen::VectorXd qd = RandomVector(rng, n, -2.0, 2.0);
      const Eigen::VectorXd qdd = RandomVector(rng, n, -5.0, 5.0);
      const Eigen::VectorXd tau = InverseDynamics<double>(chain, q, qd, qdd);
      const Eigen::MatrixXd m = MassMatrix<double>(chain, q);
      const Eigen::VectorXd bias = BiasForces<double>(chain, q, qd);
      EXPECT_TRUE(NearRel(tau, m * qdd + bias, kAlgorithmRelTol));
      // The split of the bias: C qd + g.
      const Eigen::VectorXd coriolis = CoriolisForces<double>(chain, q, qd);
      const Eigen::VectorXd gravity = GravityTorques<double>(chain, q);
      EXPECT_TRUE(NearRel(bias, coriolis + gravity, kAlgorithmRelTol));
      // C qd is quadratic in qd.
      EXPECT_TRUE(NearRel(CoriolisForces<double>(chain, q, Eigen::VectorXd(2.0 * qd)),
                          4.0 * coriolis, kAlgorithmRelTol));
      // M columns from the Newton-Euler recursion (no velocity, no gravity): independent of CRBA.
      for (int j = 0; j < n; ++j) {
        const Eigen::VectorXd e = Eigen::VectorXd::Unit(n, j);
        const Eigen::VectorXd col = InverseDynamics<double>(chain, q, Eigen::VectorXd::Zero(n), e) -
                                    GravityTorques<double>(chain, q);
        EXPECT_TRUE(NearRel(col, m.col(j), kAlgorithmRelTol)) << "column " << j;
      }
    }
  }
}

TEST(ForwardDynamics, InvertsInverseDynamics) {
  std::mt19937 rng(TestSeed());
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " dof " + std::to_string(chain.dof()));
    const int n = chain.dof();
    for (int k = 0; k < kNumDraws; ++k) {
      const Eigen::VectorXd q = RandomVector(rng, n, -3.0, 3.0);
      const Eigen::VectorXd qd = RandomVector(rng, n, -2.0, 2.0);
      const Eigen::VectorXd qdd = RandomVector(rng, n, -5.0, 5.0);
      const Eigen::VectorXd tau = InverseDynamics<double>(chain, q, qd, qdd);
      const Eigen::VectorXd qdd2 = ForwardDynamics<double>(chain, q, qd, tau);
      // The solve loses log10(cond(M)) digits; cond(M) <= 1e4 for these chains.
      constexpr double kSolveRelTol = 1e-9;
      EXPECT_TRUE(NearRel(qdd2, qdd, kSolveRelTol));
    }
  }
}

TEST(SolveSpd, MatchesEigenLlt) {
  std::mt19937 rng(TestSeed());
  for (int n = 1; n <= kMaxDof; ++n) {
    const Eigen::MatrixXd r =
        Eigen::MatrixXd::NullaryExpr(n, n, [&] { return testing::Uniform(rng, -1.0, 1.0); });
    const Eigen::MatrixXd a = r * r.transpose() + Eigen::MatrixXd::Identity(n, n);
    const Eigen::VectorXd b = RandomVector(rng, n, -1.0, 1.0);
    const Eigen::VectorXd x = SolveSpd<double>(a, b);
    EXPECT_TRUE(NearRel(x, a.llt().solve(b), kAlgorithmRelTol)) << "n = " << n;
  }
}

TEST(GravityTorques, AreTheGradientOfThePotentialEnergy) {
  std::mt19937 rng(TestSeed());
  // Central differences with h = 1e-5: truncation h^2 |U'''| ~ 1e-10 |U|, rounding eps |U| / h ~
  // 1e-11 |U|; relative to the torque scale 1e-6 leaves a wide margin and still catches sign and
  // factor errors.
  constexpr double kStep = 1e-5;
  constexpr double kFdRelTol = 1e-6;
  for (const SerialChain& chain : TestChains(rng)) {
    SCOPED_TRACE(chain.name() + " dof " + std::to_string(chain.dof()));
    const int n = chain.dof();
    const Eigen::VectorXd q = RandomVector(rng, n, -3.0, 3.0);
    Eigen::VectorXd fd(n);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd qp = q, qm = q;
      qp[j] += kStep;
      qm[j] -= kStep;
      fd[j] =
          (PotentialEnergy<double>(chain, qp) - PotentialEnergy<double>(chain, qm)) / (2.0 * kStep);
    }
    EXPECT_TRUE(NearRel(GravityTorques<double>(chain, q), fd, kFdRelTol));
  }
}

TEST(DhConventions, ModifiedDescriptionOfTheSameMechanismGivesTheSameDynamics) {
  std::mt19937 rng(TestSeed());
  for (int prismatic_every : {0, 2}) {
    const SerialChain standard = RandomChain(rng, 6, DhConvention::kStandard, prismatic_every);
    const SerialChain modified = testing::ToModifiedDh(standard);
    for (int k = 0; k < kNumDraws; ++k) {
      const Eigen::VectorXd q = RandomVector(rng, 6, -3.0, 3.0);
      const Eigen::VectorXd qd = RandomVector(rng, 6, -2.0, 2.0);
      const Eigen::VectorXd qdd = RandomVector(rng, 6, -5.0, 5.0);
      EXPECT_TRUE(NearRel(InverseDynamics<double>(standard, q, qd, qdd),
                          InverseDynamics<double>(modified, q, qd, qdd), kAlgorithmRelTol));
      EXPECT_TRUE(NearRel(MassMatrix<double>(standard, q), MassMatrix<double>(modified, q),
                          kAlgorithmRelTol));
      EXPECT_NEAR(PotentialEnergy<double>(standard, q), PotentialEnergy<double>(modified, q),
                  kAlgorithmRelTol * 100.0);
      // Standard frame {i} = modified frame {i} * Tx(a_i) Rx(alpha_i), for every link.
      const LinkTransforms<double> ts = ForwardKinematics<double>(standard, q);
      const LinkTransforms<double> tm = ForwardKinematics<double>(modified, q);
      for (int i = 0; i < 6; ++i) {
        Eigen::Matrix4d tail = Eigen::Matrix4d::Identity();
        const double ca = std::cos(standard.link(i).alpha), sa = std::sin(standard.link(i).alpha);
        tail.topLeftCorner<3, 3>() << 1, 0, 0, 0, ca, -sa, 0, sa, ca;
        tail(0, 3) = standard.link(i).a;
        EXPECT_TRUE(NearRel(ts.base_from_link[i], tm.base_from_link[i] * tail, kAlgorithmRelTol))
            << "link " << i + 1;
      }
    }
  }
}

// Planar two-link arm, standard DH (alpha = d = 0, a_i = l_i), joints about z, gravity -g0 y.
// Link i: mass m_i, COM at distance lc_i from joint i along the link (frame {i} sits at the distal
// end, so c_i = (lc_i - l_i, 0, 0)), inertia I_i about its COM (z component), rotor inertia Ia_i.
TEST(DoublePendulum, MatchesClosedFormMassCoriolisAndGravity) {
  constexpr double l1 = 0.7, l2 = 0.5, lc1 = 0.3, lc2 = 0.2, m1 = 3.0, m2 = 2.0;
  constexpr double i1 = 0.11, i2 = 0.07, ia1 = 0.4, ia2 = 0.25, g0 = 9.81;
  std::vector<Link> links(2);
  links[0].a = l1;
  links[0].mass = m1;
  links[0].center_of_mass = Eigen::Vector3d(lc1 - l1, 0.0, 0.0);
  links[0].inertia = Eigen::Vector3d(0.05, 0.09, i1).asDiagonal();
  links[0].rotor_inertia = ia1;
  links[1].a = l2;
  links[1].mass = m2;
  links[1].center_of_mass = Eigen::Vector3d(lc2 - l2, 0.0, 0.0);
  links[1].inertia = Eigen::Vector3d(0.02, 0.06, i2).asDiagonal();
  links[1].rotor_inertia = ia2;
  const SerialChain chain("double pendulum", DhConvention::kStandard, links,
                          Eigen::Vector3d(0.0, -g0, 0.0));

  std::mt19937 rng(TestSeed());
  for (int k = 0; k < kNumDraws; ++k) {
    const Eigen::Vector2d q = RandomVector(rng, 2, -3.0, 3.0);
    const Eigen::Vector2d qd = RandomVector(rng, 2, -2.0, 2.0);
    const double c2 = std::cos(q[1]), s2 = std::sin(q[1]);
    Eigen::Matrix2d m;
    m(0, 0) = m1 * lc1 * lc1 + m2 * (l1 * l1 + lc2 * lc2 + 2 * l1 * lc2 * c2) + i1 + i2 + ia1;
    m(0, 1) = m2 * (lc2 * lc2 + l1 * lc2 * c2) + i2;
    m(1, 0) = m(0, 1);
    m(1, 1) = m2 * lc2 * lc2 + i2 + ia2;
    const double h = m2 * l1 * lc2 * s2;
    const Eigen::Vector2d coriolis(-h * (2 * qd[0] * qd[1] + qd[1] * qd[1]), h * qd[0] * qd[0]);
    const Eigen::Vector2d gravity(
        (m1 * lc1 + m2 * l1) * g0 * std::cos(q[0]) + m2 * lc2 * g0 * std::cos(q[0] + q[1]),
        m2 * lc2 * g0 * std::cos(q[0] + q[1]));
    EXPECT_TRUE(NearRel(MassMatrix<double>(chain, q), m, kAlgorithmRelTol));
    EXPECT_TRUE(NearRel(CoriolisForces<double>(chain, q, qd), coriolis, kAlgorithmRelTol));
    EXPECT_TRUE(NearRel(GravityTorques<double>(chain, q), gravity, kAlgorithmRelTol));
    // Tip position.
    const LinkTransforms<double> t = ForwardKinematics<double>(chain, q);
    const Eigen::Vector3d tip(l1 * std::cos(q[0]) + l2 * std::cos(q[0] + q[1]),
                              l1 * std::sin(q[0]) + l2 * std::sin(q[0] + q[1]), 0.0);
    EXPECT_TRUE(NearRel(t.base_from_link[1].topRightCorner<3, 1>(), tip, kAlgorithmRelTol));
    EXPECT_NEAR(
        PotentialEnergy<double>(chain, q),
        g0 * (m1 * lc1 * std::sin(q[0]) + m2 * (l1 * std::sin(q[0]) + lc2 * std::sin(q[0] + q[1]))),
        kAlgorithmRelTol * 100.0);
  }
}

// A frictionless arm released with zero torque conserves T + U. Classical RK4 with step h has a
// local energy error O(h^5); over 2 s with h = 1 ms the relative drift measured is ~1e-10 for
// these arms, so 1e-7 catches any modelling inconsistency (a wrong Coriolis term drifts at O(1)).
TEST(Energy, IsConservedWithoutTorqueUnderRk4) {
  constexpr double kStep = 1e-3;
  constexpr double kDuration = 2.0;
  constexpr double kEnergyRelTol = 1e-7;
  std::mt19937 rng(TestSeed());
  std::vector<SerialChain> chains;
  chains.push_back(RandomChain(rng, 4, DhConvention::kStandard, 3));
  chains.push_back(RandomChain(rng, 5, DhConvention::kModified, 2));
  chains.push_back(KukaKr300R2500(150.0));
  for (const SerialChain& chain : chains) {
    SCOPED_TRACE(chain.name() + " dof " + std::to_string(chain.dof()));
    const int n = chain.dof();
    Eigen::VectorXd q = RandomVector(rng, n, -1.5, 1.5);
    Eigen::VectorXd qd = RandomVector(rng, n, -1.0, 1.0);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(n);
    const auto accel = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& v) {
      return Eigen::VectorXd(ForwardDynamics<double>(chain, x, v, zero));
    };
    const auto energy = [&] {
      return KineticEnergy<double>(chain, q, qd) + PotentialEnergy<double>(chain, q);
    };
    const double e0 = energy();
    const double kinetic0 = KineticEnergy<double>(chain, q, qd);
    double max_drift = 0.0;
    for (int step = 0; step < static_cast<int>(kDuration / kStep); ++step) {
      testing::Rk4Step(accel, kStep, &q, &qd);
      max_drift = std::max(max_drift, std::fabs(energy() - e0));
    }
    // Relative to the energy that moves around (the initial kinetic energy plus the potential
    // energy range is of the same order); use |e0| + T0 so a zero total energy cannot mask drift.
    const double rel = max_drift / (std::fabs(e0) + kinetic0);
    std::cout << "[ energy   ] " << chain.name() << ": relative drift " << rel << "\n";
    EXPECT_LT(rel, kEnergyRelTol);
  }
}

TEST(RigidBodyDynamics, WrongSizesThrow) {
  const SerialChain chain = KukaKr300R2500();
  const Eigen::VectorXd q5 = Eigen::VectorXd::Zero(5), q6 = Eigen::VectorXd::Zero(6);
  try {
    InverseDynamics<double>(chain, q5, q6, q6);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("expected q of size 6"), std::string::npos) << what;
    EXPECT_NE(what.find("got 5"), std::string::npos) << what;
  }
  EXPECT_THROW(MassMatrix<double>(chain, q5), std::invalid_argument);
  EXPECT_THROW(ForwardDynamics<double>(chain, q6, q6, q5), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::models
