// The elastic coupling (mechanics.elastic_coupling, graybox/models/loads.h) against independent
// and closed forms: its nominal values put the coupled mode at the option's frequency and damping
// ratio; inserted on a rigid body's force it simulates like drive.two_mass with the same inertias,
// stiffness and damping; the centre of mass moves as the rigid body of inertia M + J at any
// stiffness, and the body itself approaches that rigid body as K grows; units follow the motion;
// bad options are rejected naming the option. The shared suite (block_registry_test.cc) adds
// metadata, roles, double == Expr and finite-difference checks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <Eigen/Core>

#include "graybox/models/block.h"
#include "graybox/models/drives.h"
#include "graybox/models/loads.h"
#include "graybox/models/mechanics.h"
#include "graybox/models/model.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using Eigen::VectorXd;

constexpr double kPi = 3.14159265358979323846;

// The nominal values are a few products and one square root of the options: a few ulps.
constexpr double kRoundoff = 1e-13;
// RK4 commutes with a linear change of variables, and (q, e) -> (q_m = q + e, q_l = q) is one, so
// the coupled model and drive.two_mass take the same discrete steps: they differ by rounding
// only, which grows at most linearly over the 2000 steps (2000 * 1e-16 = 2e-13 of the states'
// size; observed 1e-15); 1e-10 relative leaves a wide margin and is still far below what any
// change of the equations does (a 1 % error in the M of the deflection equation fails it).
constexpr double kSameStepsTolerance = 1e-10;
// The centre of mass q + J e / (J + M) obeys (M + J) qdd = F; its RK4 steps are those of the rigid
// body (same argument), so again rounding only, over 25000 steps.
constexpr double kCentreOfMassTolerance = 1e-10;
// A damped oscillator started by a force step overshoots its static deflection by less than a
// factor 2; the body's deviation from the rigid axis is J / (J + M) times the deflection.
constexpr double kOvershoot = 2.0;
// Ten times the mode frequency makes the deviation (omega_in / omega)^2 a hundred times smaller;
// a factor 50 allows for the transient and the RK4 error.
constexpr double kStiffnessGainFactor = 50.0;

std::unique_ptr<Block> Make(const BlockOptions& options) {
  return BlockRegistry::Global().Create(kElasticCoupling, options);
}

BlockOptions Options(double axis_inertia, const std::string& motion = "", double frequency = 0.0) {
  BlockOptions o;
  o.numbers["axis_inertia"] = {axis_inertia};
  if (!motion.empty()) o.words["motion"] = motion;
  if (frequency > 0.0) o.numbers["frequency"] = {frequency};
  return o;
}

// A seeded multisine force [N m]: amplitudes in [1, 3], frequencies in [f_lo, f_hi] Hz.
struct Multisine {
  std::vector<double> amplitude, frequency, phase;
  double operator()(double t) const {
    double f = 0.0;
    for (std::size_t i = 0; i < amplitude.size(); ++i) {
      f += amplitude[i] * std::sin(2.0 * kPi * frequency[i] * t + phase[i]);
    }
    return f;
  }
  double Peak() const {
    double s = 0.0;
    for (double a : amplitude) s += a;
    return s;
  }
};

Multisine RandomMultisine(std::mt19937& rng, double f_lo, double f_hi) {
  Multisine m;
  for (int i = 0; i < 3; ++i) {
    m.amplitude.push_back(testing::Uniform(rng, 1.0, 3.0));
    m.frequency.push_back(testing::Uniform(rng, f_lo, f_hi));
    m.phase.push_back(testing::Uniform(rng, 0.0, 2.0 * kPi));
  }
  return m;
}

// One classical RK4 step of xdot = f(t, x), the force evaluated at the stage times.
using Rhs = std::function<VectorXd(double, const VectorXd&)>;
VectorXd Rk4Step(const Rhs& f, double t, const VectorXd& x, double h) {
  const VectorXd k1 = f(t, x);
  const VectorXd k2 = f(t + 0.5 * h, x + 0.5 * h * k1);
  const VectorXd k3 = f(t + 0.5 * h, x + 0.5 * h * k2);
  const VectorXd k4 = f(t + h, x + h * k3);
  return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

// The rigid body "body" (mechanics.mass, rotational, inertia M) reading the external force "F",
// with the coupling inserted for it: the body reads "coupling.out".
Model CoupledAxis(double m, double j, double k, double c) {
  Model model("coupled");
  BlockOptions rotational;
  rotational.words["motion"] = "rotational";
  model.AddInput("F", "N m", "net torque on the axis", -10.0, 10.0);
  model.AddBlock("body", kMassBlock, rotational, {"F"}, {});
  model.SetParameter("body.mass", m);
  model.InsertForReaders("F", "coupling",
                         std::shared_ptr<const Block>(Make(Options(m, "rotational"))), {"body"});
  model.SetParameter("coupling.J", j);
  model.SetParameter("coupling.K", k);
  model.SetParameter("coupling.c", c);
  model.AddOutput("body.q");
  model.AddOutput("coupling.out");
  return model;
}

// The model's states along RK4 steps from rest: row i is the state after i steps.
Eigen::MatrixXd Simulate(const StateSpaceModel& ss, const Multisine& force, double h, int steps) {
  const VectorXd p = ss.ParameterValues();
  const Rhs f = [&](double t, const VectorXd& x) -> VectorXd {
    return ss.dynamics({x, VectorXd::Constant(1, force(t)), p})[0];
  };
  Eigen::MatrixXd states(steps + 1, ss.NumStates());
  VectorXd x = VectorXd::Zero(ss.NumStates());
  states.row(0) = x.transpose();
  for (int i = 0; i < steps; ++i) {
    x = Rk4Step(f, i * h, x, h);
    states.row(i + 1) = x.transpose();
  }
  return states;
}

// A rigid rotational body of inertia `inertia` driven by `force`: columns q, qd.
Eigen::MatrixXd SimulateRigid(double inertia, const Multisine& force, double h, int steps) {
  const Rhs f = [&](double t, const VectorXd& x) -> VectorXd {
    return Eigen::Vector2d(x[1], force(t) / inertia);
  };
  Eigen::MatrixXd states(steps + 1, 2);
  VectorXd x = VectorXd::Zero(2);
  states.row(0) = x.transpose();
  for (int i = 0; i < steps; ++i) {
    x = Rk4Step(f, i * h, x, h);
    states.row(i + 1) = x.transpose();
  }
  return states;
}

double MaxAbs(const VectorXd& v) { return v.cwiseAbs().maxCoeff(); }

TEST(ElasticCoupling, NominalValuesPlaceTheModeAtTheFrequency) {
  for (const auto& [m, motion, f0] : {std::tuple<double, std::string, double>{0.5, "", 0.0},
                                      {95.1, "prismatic", 35.0},
                                      {2.0e3, "rotational", 4.0}}) {
    SCOPED_TRACE(motion + " M = " + std::to_string(m));
    const auto block = Make(Options(m, motion, f0));
    const double f = f0 > 0.0 ? f0 : kDefaultCouplingFrequency;
    const std::vector<double> p = block->NominalParameters();
    ASSERT_EQ(p.size(), 3u);
    const double j = p[0], k = p[1], c = p[2];
    EXPECT_NEAR(j, kDefaultCouplingInertiaRatio * m, kRoundoff * m);
    const double j_eff = j * m / (j + m);
    const double omega = 2.0 * kPi * f;
    EXPECT_NEAR(std::sqrt(k * (1.0 / j + 1.0 / m)), omega, kRoundoff * omega);
    EXPECT_NEAR(c / (2.0 * std::sqrt(k * j_eff)), kDefaultCouplingDamping, kRoundoff);
    for (const ParameterInfo& par : block->info().parameters) {
      EXPECT_FALSE(par.HasNeutral()) << par.name << ": the block has no neutral configuration";
      EXPECT_GT(par.upper, par.nominal) << par.name;
    }
    EXPECT_GT(block->info().parameters[0].lower, 0.0) << "J divides";
    EXPECT_GT(block->info().parameters[1].lower, 0.0);
    EXPECT_EQ(block->info().parameters[2].lower, 0.0);
    // The linearisation in (e, ed) at F = 0: [[0, 1], [-K/J_eff, -c/J_eff]], whose eigenvalues
    // -zeta omega +- i omega sqrt(1 - zeta^2) have modulus omega and real part -zeta omega.
    Eigen::Matrix2d a;
    for (int col = 0; col < 2; ++col) {
      const Eigen::Vector2d x = Eigen::Vector2d::Unit(col);
      const double u = 0.0;
      Eigen::Vector2d xdot;
      double y = 0.0;
      block->Evaluate(BlockArgs<double>{x.data(), &u, p.data(), xdot.data(), &y});
      a.col(col) = xdot;
    }
    const double modulus = std::sqrt(a.determinant());
    EXPECT_NEAR(modulus, omega, 1e-12 * omega);
    EXPECT_NEAR(-0.5 * a.trace() / modulus, kDefaultCouplingDamping, 1e-12);
    EXPECT_FALSE(block->info().stiff);
  }
}

TEST(ElasticCoupling, UnitsAndRolesFollowTheMotion) {
  const auto rotational = Make(Options(0.5));
  const auto prismatic = Make(Options(95.1, "prismatic"));
  for (const auto* b : {rotational.get(), prismatic.get()}) {
    ASSERT_EQ(b->NumInputs(), 1) << "InsertForReaders needs one input";
    ASSERT_EQ(b->NumOutputs(), 1) << "InsertForReaders needs one output";
    ASSERT_EQ(b->NumStates(), 2);
    EXPECT_EQ(b->info().inputs[0].role, SignalRole::kForce);
    EXPECT_EQ(b->info().outputs[0].role, SignalRole::kForce);
    for (const SignalInfo& s : b->info().states) {
      EXPECT_EQ(s.role, SignalRole::kNone) << s.name << ": a deflection is not an axis";
    }
  }
  auto units = [](const Block& b) {
    std::vector<std::string> u = {b.info().states[0].unit, b.info().states[1].unit,
                                  b.info().inputs[0].unit, b.info().outputs[0].unit};
    for (const ParameterInfo& p : b.info().parameters) u.push_back(p.unit);
    return u;
  };
  EXPECT_EQ(units(*rotational), (std::vector<std::string>{"rad", "rad/s", "N m", "N m", "kg m^2",
                                                          "N m/rad", "N m s/rad"}));
  EXPECT_EQ(units(*prismatic),
            (std::vector<std::string>{"m", "m/s", "N", "N", "kg", "N/m", "N s/m"}));
  // Typical ranges: the spring's extension under the typical force, and omega times it.
  const std::vector<double> p = rotational->NominalParameters();
  const SignalInfo& e = rotational->info().states[0];
  const SignalInfo& ed = rotational->info().states[1];
  const double force = rotational->info().inputs[0].typical_max;
  EXPECT_NEAR(e.typical_max, force / p[1], kRoundoff * e.typical_max);
  EXPECT_NEAR(ed.typical_max, 2.0 * kPi * kDefaultCouplingFrequency * e.typical_max,
              kRoundoff * ed.typical_max);
}

// The built model has one axis: the body's velocity is its only velocity-role state.
TEST(ElasticCoupling, InsertedForTheBodyAddsNoAxis) {
  const Model model = CoupledAxis(0.5, 0.12, 900.0, 0.8);
  ASSERT_EQ(model.Blocks().size(), 2u);
  EXPECT_EQ(model.Blocks()[0].inputs, std::vector<std::string>{"coupling.out"});
  EXPECT_EQ(model.Blocks()[1].inputs, std::vector<std::string>{"F"});
  const StateSpaceModel ss = model.Build();
  std::vector<std::string> velocities;
  for (const SignalDescription& s : ss.signals) {
    if (s.source == SignalSource::kState && s.info.role == SignalRole::kVelocity) {
      velocities.push_back(s.info.name);
    }
  }
  EXPECT_EQ(velocities, std::vector<std::string>{"body.qd"});
  EXPECT_EQ(ss.signals[ss.SignalIndex("coupling.out")].info.role, SignalRole::kForce);
}

// (1) The rigid body with the coupling inserted against drive.two_mass with J, I = M, Ke = K,
// d = c driven by the same torque on the motor side: q = q_l, q + e = q_m, F_c = tau_s.
TEST(ElasticCoupling, SimulatesLikeTheTwoMassDrive) {
  constexpr double kM = 0.5, kJ = 0.12, kK = 900.0, kC = 0.8;  // mode at 15.3 Hz, zeta 0.043
  constexpr double kStep = 1e-3;                               // omega h = 0.096
  constexpr int kSteps = 2000;
  std::mt19937 rng(testing::TestSeed());
  const Multisine force = RandomMultisine(rng, 0.5, 20.0);  // excites the mode too
  const StateSpaceModel ss = CoupledAxis(kM, kJ, kK, kC).Build();
  const Eigen::MatrixXd coupled = Simulate(ss, force, kStep, kSteps);
  const int q = ss.StateIndex("body.q"), e = ss.StateIndex("coupling.e");

  const auto drive = BlockRegistry::Global().Create(kTwoMassDrive);
  const VectorXd p = (VectorXd(4) << kJ, kM, kK, kC).finished();
  const Rhs f = [&](double t, const VectorXd& x) -> VectorXd {
    const Eigen::Vector2d u(force(t), 0.0);
    VectorXd xdot(4), y(5);
    drive->Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), xdot.data(), y.data()});
    return xdot;
  };
  VectorXd x = VectorXd::Zero(4);  // q_m, qd_m, q_l, qd_l
  VectorXd q_l(kSteps + 1), q_m(kSteps + 1), tau_s(kSteps + 1), f_c(kSteps + 1);
  const VectorXd ones = VectorXd::Ones(1);
  for (int i = 0; i <= kSteps; ++i) {
    if (i > 0) x = Rk4Step(f, (i - 1) * kStep, x, kStep);
    q_m[i] = x[0];
    q_l[i] = x[2];
    tau_s[i] = kK * (x[0] - x[2]) + kC * (x[1] - x[3]);
    const VectorXd xi = coupled.row(i).transpose();
    f_c[i] = ss.output({xi, ones * force(i * kStep), ss.ParameterValues()})[0][1];
  }
  const VectorXd body_q = coupled.col(q), motor_q = coupled.col(q) + coupled.col(e);
  const double range = MaxAbs(q_l);
  ASSERT_GT(range, 0.0);
  EXPECT_LT(MaxAbs(body_q - q_l), kSameStepsTolerance * range);
  EXPECT_LT(MaxAbs(motor_q - q_m), kSameStepsTolerance * MaxAbs(q_m));
  EXPECT_LT(MaxAbs(f_c - tau_s), kSameStepsTolerance * MaxAbs(tau_s));
  // Not a rigid response: the deflection is visible against the body's travel.
  EXPECT_GT(MaxAbs(coupled.col(e)), 1e-4 * range);
}

// (2a) At any stiffness the centre of mass q + J e / (J + M) moves as the rigid body M + J.
TEST(ElasticCoupling, CentreOfMassMovesAsTheRigidBody) {
  constexpr double kM = 0.5, kJ = 0.12, kK = 900.0, kC = 0.8;
  constexpr double kStep = 1e-3;
  constexpr int kSteps = 2000;
  std::mt19937 rng(testing::TestSeed());
  const Multisine force = RandomMultisine(rng, 0.5, 20.0);
  const StateSpaceModel ss = CoupledAxis(kM, kJ, kK, kC).Build();
  const Eigen::MatrixXd coupled = Simulate(ss, force, kStep, kSteps);
  const Eigen::MatrixXd rigid = SimulateRigid(kM + kJ, force, kStep, kSteps);
  const VectorXd centre = coupled.col(ss.StateIndex("body.q")) +
                          kJ / (kJ + kM) * coupled.col(ss.StateIndex("coupling.e"));
  EXPECT_LT(MaxAbs(centre - rigid.col(0)), kCentreOfMassTolerance * MaxAbs(rigid.col(0)));
}

// (2b) As K grows the body's motion approaches the rigid body of inertia M + J (not M): the
// deviation is J e / (J + M), e ~ F / (J omega^2), so it shrinks as 1 / omega^2.
TEST(ElasticCoupling, StiffLimitIsTheRigidBodyOfInertiaMPlusJ) {
  constexpr double kM = 0.5, kJ = 0.12;
  constexpr double kDuration = 1.0;  // [s]
  std::mt19937 rng(testing::TestSeed());
  const Multisine force = RandomMultisine(rng, 0.5, 5.0);
  const double j_eff = kJ * kM / (kJ + kM);
  std::vector<double> deviation;
  for (const double f_mode : {200.0, 2000.0}) {
    SCOPED_TRACE("mode at " + std::to_string(f_mode) + " Hz");
    const double omega = 2.0 * kPi * f_mode;
    const double k = omega * omega * j_eff;
    const double c = 2.0 * kDefaultCouplingDamping * std::sqrt(k * j_eff);
    const double h = 0.5 / omega;  // RK4 resolves the mode (loads.h: omega h <= 0.5)
    const int steps = static_cast<int>(std::ceil(kDuration / h));
    const StateSpaceModel ss = CoupledAxis(kM, kJ, k, c).Build();
    const Eigen::MatrixXd coupled = Simulate(ss, force, h, steps);
    const Eigen::MatrixXd rigid = SimulateRigid(kM + kJ, force, h, steps);
    const Eigen::MatrixXd lighter = SimulateRigid(kM, force, h, steps);
    const VectorXd q = coupled.col(ss.StateIndex("body.q"));
    const double dev = MaxAbs(q - rigid.col(0));
    deviation.push_back(dev);
    EXPECT_LE(dev, kOvershoot * force.Peak() / ((kJ + kM) * omega * omega));
    // And it is the heavier body: M alone is far off.
    EXPECT_GT(MaxAbs(q - lighter.col(0)), 100.0 * dev);
  }
  EXPECT_GT(deviation[0] / deviation[1], kStiffnessGainFactor);
}

// (3) Bad options name the option, what was expected and what was given.
TEST(ElasticCoupling, RejectsBadOptions) {
  auto message = [](const BlockOptions& o) -> std::string {
    try {
      Make(o);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "(no exception)";
  };
  auto expect_all = [](const std::string& msg, const std::vector<std::string>& parts) {
    for (const std::string& part : parts) {
      EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
    }
  };
  const std::string block = "block '" + std::string(kElasticCoupling) + "'";

  BlockOptions missing;
  missing.numbers["frequency"] = {20.0};
  expect_all(message(missing), {block, "'axis_inertia'", "expected", "got none"});

  expect_all(message(Options(-1.0)), {block, "'axis_inertia'", "expected a number > 0", "got -1"});

  BlockOptions zero = Options(0.5);
  zero.numbers["frequency"] = {0.0};
  expect_all(message(zero), {block, "'frequency'", "expected a number > 0", "got 0"});
  BlockOptions negative = Options(0.5);
  negative.numbers["frequency"] = {-20.0};
  expect_all(message(negative), {block, "'frequency'", "expected a number > 0", "got -20"});

  expect_all(message(Options(0.5, "linear")),
             {block, "'motion'", "expected one of 'rotational', 'prismatic'", "got 'linear'"});
  expect_all(message(Options(0.5, "prismatc")), {"did you mean 'prismatic'?"});

  BlockOptions typo = Options(0.5);
  typo.numbers["frequncy"] = {20.0};
  expect_all(message(typo), {block, "unknown option 'frequncy'", "did you mean 'frequency'?"});
}

}  // namespace
}  // namespace graybox::models
