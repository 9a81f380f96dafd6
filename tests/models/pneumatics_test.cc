// Closed-form checks of the pneumatic blocks (graybox/models/pneumatics.h, seed 004 chapter 3):
// the orifice's regimes and their joins, reverse flow, the chamber's pressure rate, the
// slider-crank geometry, the arm's torque balance and wiring, the three valve-area models, and
// option validation. The shared suite (block_registry_test.cc) adds metadata, double == Expr and
// finite-difference checks of every registered block.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/pneumatics.h"
#include "test_util.h"

namespace graybox::models {
namespace {

namespace pn = pneumatics;
using expr::Expr;
using expr::Function;

constexpr double kPi = 3.14159265358979323846;

// The same formula evaluated twice with the same operations: equal to the last bit.
// Algebraically equal formulae evaluated differently: a few ulps, amplified by the cancellation
// in 1 - r^((k-1)/k) (at most 1/s_lam ~ 350 just outside the laminar band), so 1e-12 relative.
constexpr double kRearrangedFormulaTolerance = 1e-12;
// The same formula reached through different call paths: equal unless the compiler fuses
// multiply-adds differently in the two (-ffp-contract with FMA hardware), a few ulps.
constexpr double kSameFormulaTolerance = 1e-14;
// A1 (p - p_atm) - A2 (p - p_atm) with A1 = A2 is exactly 0 without fused multiply-adds; with them
// it is the rounding error of one product, ~1e-16 * 804 mm^2 * 500 kPa, times 1e-6 * 20 mm/rad.
constexpr double kCancelledTorque = 1e-14;  // N m
// Table 3.2 prints beta = 0.029: half a unit of its last digit.
constexpr double kTableBetaRounding = 0.0005;
// The seed quotes the critical ratio as 0.528: half a unit of its last digit.
constexpr double kSeedCriticalRatioRounding = 0.0005;
// Central differences with relative step kFdStep on functions whose third derivative is bounded
// on the scale of the pressures (the nearest join is >= 1e-3 away in pressure ratio at the
// points checked): truncation (kFdStep / 1e-3)^2 ~ 1e-6 at worst, rounding ~1e-10.
constexpr double kFdStep = 1e-6;
constexpr double kFdTolerance = 1e-5;
// Distance from a join at which one-sided derivatives are compared; a C1 join makes their
// difference O(kJoinOffset) relative, a mere C0 join O(1).
constexpr double kJoinOffset = 1e-7;
constexpr double kC1JumpTolerance = 1e-5;

// ---- helpers ----------------------------------------------------------------------------------

pn::OrificeConstants<double> NominalConstants() {
  return {pn::kNominalAlpha, pn::kNominalKappa, pn::kNominalTemperature, pn::kDefaultLaminarWidth};
}

// mdot / (area * p_up) in kg/s per (mm^2 kPa): the natural scale of the flow and its partials.
double FlowScale(const pn::OrificeConstants<double>& c) {
  return pn::kSquareMillimetre * pn::kKilopascal * c.alpha / std::sqrt(c.temperature);
}

// The orifice as a Function of (p_a, p_b) with fixed area and constants, and its Jacobian.
struct OrificeProbe {
  explicit OrificeProbe(double area, const pn::OrificeConstants<double>& c = NominalConstants())
      : area_(area), constants_(c) {
    const std::vector<Expr> p = Expr::Symbols("p", 2);
    const pn::OrificeConstants<Expr> ce{c.alpha, c.kappa, c.temperature, c.laminar_width};
    const Expr mdot = pn::OrificeMassFlow(p[0], p[1], Expr(area), ce);
    f_ = Function("orifice", {{"p", p}}, {{"mdot", {mdot}}});
    jac_ = f_.Jacobian("mdot", "p");
  }
  double Value(double pa, double pb) const {
    return pn::OrificeMassFlow(pa, pb, area_, constants_);
  }
  double ExprValue(double pa, double pb) const { return f_({Eigen::Vector2d(pa, pb)})[0][0]; }
  // (d mdot / d p_a, d mdot / d p_b) from the tape.
  Eigen::Vector2d Gradient(double pa, double pb) const {
    const Eigen::VectorXd nz = jac_({Eigen::Vector2d(pa, pb)})[0];
    const expr::Sparsity& sp = jac_.OutputSparsity(0);
    const std::vector<int> col = sp.ColumnOfNonzeros();
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int k = 0; k < sp.nnz(); ++k) g[col[k]] = nz[k];
    return g;
  }
  Eigen::Vector2d CentralDifference(double pa, double pb) const {
    const double ha = kFdStep * pa, hb = kFdStep * pb;
    return {(Value(pa + ha, pb) - Value(pa - ha, pb)) / ((pa + ha) - (pa - ha)),
            (Value(pa, pb + hb) - Value(pa, pb - hb)) / ((pb + hb) - (pb - hb))};
  }
  double area_;
  pn::OrificeConstants<double> constants_;
  Function f_, jac_;
};

std::unique_ptr<Block> Make(const std::string& type, const BlockOptions& options = {}) {
  return BlockRegistry::Global().Create(type, options);
}

int ParameterIndex(const Block& b, const std::string& name) {
  for (int i = 0; i < b.NumParameters(); ++i) {
    if (b.info().parameters[i].name == name) return i;
  }
  ADD_FAILURE() << "no parameter '" << name << "' in " << b.info().type;
  return 0;
}

struct Output {
  Eigen::VectorXd xdot, y;
};

Output Evaluate(const Block& b, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                const Eigen::VectorXd& p) {
  Output out{Eigen::VectorXd::Zero(b.NumStates()), Eigen::VectorXd::Zero(b.NumOutputs())};
  b.Evaluate(BlockArgs<double>{x.data(), u.data(), p.data(), out.xdot.data(), out.y.data()});
  return out;
}

Eigen::VectorXd Nominal(const Block& b) {
  const std::vector<double> p = b.NominalParameters();
  return Eigen::Map<const Eigen::VectorXd>(p.data(), static_cast<int>(p.size()));
}

// The block as a Function of (x, u, p) with outputs "xdot" and "y" (as in the shared suite).
Function AsFunction(const Block& b) {
  const std::vector<Expr> x = Expr::Symbols("x", b.NumStates());
  const std::vector<Expr> u = Expr::Symbols("u", b.NumInputs());
  const std::vector<Expr> p = Expr::Symbols("p", b.NumParameters());
  std::vector<Expr> xdot(b.NumStates()), y(b.NumOutputs());
  b.Evaluate(BlockArgs<Expr>{x.data(), u.data(), p.data(), xdot.data(), y.data()});
  return Function(b.info().type, {{"x", x}, {"u", u}, {"p", p}}, {{"xdot", xdot}, {"y", y}});
}

// ---- orifice ----------------------------------------------------------------------------------

TEST(PneumaticOrifice, CriticalRatioOfAirIsTheSeeds0528) {
  const double r_cr = pn::CriticalPressureRatio(1.4);
  EXPECT_NEAR(r_cr, 0.528, kSeedCriticalRatioRounding);
  EXPECT_NEAR(r_cr, std::pow(2.0 / 2.4, 3.5), 1e-15);
}

TEST(PneumaticOrifice, DerivedChokedConstantIsTable32Beta) {
  // beta = alpha psi(r_cr) = alpha (2/(k+1))^(1/(k-1)) sqrt((k-1)/(k+1)).
  const double k = pn::kNominalKappa;
  const double psi_cr =
      std::pow(2.0 / (k + 1.0), 1.0 / (k - 1.0)) * std::sqrt((k - 1.0) / (k + 1.0));
  EXPECT_NEAR(pn::kNominalAlpha * psi_cr, 0.029, kTableBetaRounding);
}

TEST(PneumaticOrifice, ChokedFlowIsIndependentOfDownstreamPressure) {
  const pn::OrificeConstants<double> c = NominalConstants();
  const double k = c.kappa;
  const double psi_cr =
      std::pow(2.0 / (k + 1.0), 1.0 / (k - 1.0)) * std::sqrt((k - 1.0) / (k + 1.0));
  const double r_cr = pn::CriticalPressureRatio(k);
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 20; ++trial) {
    const double area = testing::Uniform(rng, 0.1, 2.0);
    const double p_up = testing::Uniform(rng, 250.0, 700.0);
    const double choked = pn::OrificeMassFlow(p_up, 0.05 * p_up, area, c);
    EXPECT_NEAR(choked, FlowScale(c) * area * p_up * psi_cr, kRearrangedFormulaTolerance * choked);
    for (int j = 0; j < 5; ++j) {
      const double p_down = p_up * testing::Uniform(rng, 0.05, r_cr);
      EXPECT_EQ(pn::OrificeMassFlow(p_up, p_down, area, c), choked) << "p_down " << p_down;
    }
    // At the critical ratio itself (up to the rounding of r_cr * p_up / p_up): either branch.
    EXPECT_NEAR(pn::OrificeMassFlow(p_up, r_cr * p_up, area, c), choked,
                kSameFormulaTolerance * choked);
  }
}

TEST(PneumaticOrifice, UnchokedFlowIsEquation31OutsideTheLaminarBand) {
  const pn::OrificeConstants<double> c = NominalConstants();
  const double k = c.kappa;
  const double r_cr = pn::CriticalPressureRatio(k);
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 50; ++trial) {
    const double area = testing::Uniform(rng, 0.1, 2.0);
    const double p_up = testing::Uniform(rng, 150.0, 700.0);
    const double r = testing::Uniform(rng, r_cr, 1.0 - c.laminar_width);
    // eq. 3.1 as printed: alpha P_u sqrt((P_d/P_u)^(2/k) - (P_d/P_u)^((k+1)/k)).
    const double eq31 =
        FlowScale(c) * area * p_up * std::sqrt(std::pow(r, 2.0 / k) - std::pow(r, (k + 1.0) / k));
    EXPECT_NEAR(pn::OrificeMassFlow(p_up, r * p_up, area, c), eq31,
                kRearrangedFormulaTolerance * eq31)
        << "ratio " << r;
  }
}

TEST(PneumaticOrifice, FlowAndDerivativeAreContinuousAtTheCriticalRatio) {
  const OrificeProbe probe(1.5);
  const double r_cr = pn::CriticalPressureRatio(pn::kNominalKappa);
  for (double p_up : {200.0, 450.0, 700.0}) {
    const double below = r_cr * (1.0 - kJoinOffset) * p_up;          // choked
    const double above = r_cr * (1.0 + kJoinOffset) * p_up;          // unchoked
    const double scale = FlowScale(probe.constants_) * probe.area_;  // d mdot / d p scale
    const double f_below = probe.ExprValue(p_up, below), f_above = probe.ExprValue(p_up, above);
    // psi'(r_cr) = 0: the value changes only to second order across the join.
    EXPECT_NEAR(f_above, f_below, kC1JumpTolerance * kJoinOffset * f_below);
    const Eigen::Vector2d g_below = probe.Gradient(p_up, below);
    const Eigen::Vector2d g_above = probe.Gradient(p_up, above);
    EXPECT_EQ(g_below[1], 0.0);  // choked: no dependence on the downstream pressure
    EXPECT_NEAR(g_above[1], g_below[1], kC1JumpTolerance * scale);
    EXPECT_NEAR(g_above[0], g_below[0], kC1JumpTolerance * scale);
  }
}

TEST(PneumaticOrifice, LaminarCubicJoinsTheSquareRootInC1) {
  const OrificeProbe probe(1.0);
  const double w = probe.constants_.laminar_width;
  const double scale = FlowScale(probe.constants_) * probe.area_;
  for (double p_up : {150.0, 600.0}) {
    const double inside = (1.0 - w) * (1.0 + kJoinOffset) * p_up;
    const double outside = (1.0 - w) * (1.0 - kJoinOffset) * p_up;
    const double f_in = probe.ExprValue(p_up, inside), f_out = probe.ExprValue(p_up, outside);
    const Eigen::Vector2d g_in = probe.Gradient(p_up, inside);
    const Eigen::Vector2d g_out = probe.Gradient(p_up, outside);
    // Value: differs by the slope times the step; slope continuous to O(offset * curvature).
    EXPECT_NEAR(f_in - f_out, g_in[1] * (inside - outside), kC1JumpTolerance * std::fabs(f_in));
    EXPECT_NEAR(g_in[0], g_out[0], kC1JumpTolerance * scale * 100.0);
    EXPECT_NEAR(g_in[1], g_out[1], kC1JumpTolerance * scale * 100.0);
  }
}

TEST(PneumaticOrifice, ZeroFlowAtEqualPressuresWithTheDocumentedFiniteSlope) {
  const OrificeProbe probe(0.8);
  const pn::OrificeConstants<double> c = probe.constants_;
  const double gamma = (c.kappa - 1.0) / c.kappa;
  const double s_lam = 1.0 - std::pow(1.0 - c.laminar_width, gamma);
  const double slope = FlowScale(c) * probe.area_ * 1.25 * gamma / std::sqrt(s_lam);
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 10; ++trial) {
    const double p = testing::Uniform(rng, 101.0, 700.0);
    EXPECT_EQ(probe.Value(p, p), 0.0);
    EXPECT_EQ(probe.ExprValue(p, p), 0.0);
    const Eigen::Vector2d g = probe.Gradient(p, p);
    EXPECT_TRUE(std::isfinite(g[0]) && std::isfinite(g[1]));
    EXPECT_NEAR(g[0], slope, kRearrangedFormulaTolerance * slope);
    EXPECT_NEAR(g[1], -slope, kRearrangedFormulaTolerance * slope);
  }
}

TEST(PneumaticOrifice, ReverseFlowIsAntisymmetric) {
  const pn::OrificeConstants<double> c = NominalConstants();
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 200; ++trial) {
    const double area = testing::Uniform(rng, 0.0, 2.0);
    const double pa = testing::Uniform(rng, 101.0, 700.0);
    // Ratios over every regime: choked, unchoked, laminar band.
    const double pb = pa * std::exp(testing::Uniform(rng, -2.0, 2.0) *
                                    std::pow(10.0, -testing::Uniform(rng, 0.0, 4.0)));
    const double forward = pn::OrificeMassFlow(pa, pb, area, c);
    EXPECT_EQ(pn::OrificeMassFlow(pb, pa, area, c), -forward);
    EXPECT_EQ(forward > 0.0, pa > pb && area > 0.0) << pa << " " << pb;
  }
}

TEST(PneumaticOrifice, DerivativesAreFiniteEverywhereAndMatchFiniteDifferences) {
  const OrificeProbe probe(1.2);
  const double w = probe.constants_.laminar_width;
  const double r_cr = pn::CriticalPressureRatio(pn::kNominalKappa);
  const double scale = FlowScale(probe.constants_) * probe.area_;
  // Ratios p_b / p_a across every regime, both flow directions, and the joins themselves.
  std::vector<double> ratios = {0.01, 0.2,  0.5,     r_cr,  0.53,   0.7,
                                0.9,  0.97, 1.0 - w, 0.995, 0.9999, 1.0};
  const std::size_t n = ratios.size();
  for (std::size_t i = 0; i < n; ++i) ratios.push_back(1.0 / ratios[i]);
  auto near_join = [&](double r) {
    const double q = r > 1.0 ? 1.0 / r : r;
    return std::fabs(q - r_cr) < 1e-3 || std::fabs(q - (1.0 - w)) < 1e-3 || q == 1.0;
  };
  for (double p_a : {110.0, 400.0}) {
    for (double r : ratios) {
      const double p_b = r * p_a;
      const Eigen::Vector2d g = probe.Gradient(p_a, p_b);
      ASSERT_TRUE(std::isfinite(g[0]) && std::isfinite(g[1])) << "ratio " << r;
      if (near_join(r)) continue;  // one-sided derivatives there: checked by the C1 tests
      const Eigen::Vector2d fd = probe.CentralDifference(p_a, p_b);
      for (int j = 0; j < 2; ++j) {
        EXPECT_NEAR(g[j], fd[j], kFdTolerance * (std::fabs(g[j]) + scale))
            << "ratio " << r << " partial " << j;
      }
    }
  }
}

// ---- chamber ----------------------------------------------------------------------------------

TEST(PneumaticChamber, ClosedChamberCompressedAtKnownRate) {
  const auto chamber = Make("pneumatic.chamber");
  EXPECT_TRUE(chamber->info().stiff);
  const Eigen::VectorXd p = Nominal(*chamber);
  const double n = p[ParameterIndex(*chamber, "polytropic_exponent")];
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 20; ++trial) {
    const double pressure = testing::Uniform(rng, 101.0, 600.0);
    const double volume = testing::Uniform(rng, 1.5e4, 5e4);
    const double volume_rate = testing::Uniform(rng, -2e5, 2e5);
    const Output out = Evaluate(*chamber, Eigen::VectorXd::Constant(1, pressure),
                                Eigen::Vector3d(0.0, volume, volume_rate), p);
    const double expected = -n * pressure * volume_rate / volume;
    EXPECT_NEAR(out.xdot[0], expected, kRearrangedFormulaTolerance * std::fabs(expected));
  }
}

TEST(PneumaticChamber, RigidChamberFilledAtKnownMassFlow) {
  // pdot = n R T mdot / V in SI, converted: V [mm^3] -> m^3, pdot [Pa/s] -> kPa/s.
  const auto chamber = Make("pneumatic.chamber");
  const Eigen::VectorXd p = Nominal(*chamber);
  const double mdot = 2e-3, volume = 3e4;
  const Output out = Evaluate(*chamber, Eigen::VectorXd::Constant(1, 300.0),
                              Eigen::Vector3d(mdot, volume, 0.0), p);
  const double si = 1.4 * pn::kAirGasConstant * 298.0 * mdot / (volume * 1e-9);  // Pa/s
  EXPECT_NEAR(out.xdot[0], si / 1e3, kRearrangedFormulaTolerance * si / 1e3);
}

// ---- slider-crank -----------------------------------------------------------------------------

TEST(PneumaticSliderCrank, VolumesAtKnownAngles) {
  const auto crank = Make("pneumatic.slider_crank");
  const Eigen::VectorXd p = Nominal(*crank);
  const double a1 = 804.0, a2 = 603.0, d1 = 8.0, d2 = 6.0, r = 15.0, l = 40.0, length = 80.0;
  struct Case {
    double q, x, lever;
  };
  // q = 0 and pi: dead centres (x = l + r, l - r; no lever); q = pi/2: x = sqrt(l^2 - r^2), h = -r.
  const Case cases[] = {
      {0.0, l + r, 0.0}, {kPi, l - r, 0.0}, {kPi / 2, std::sqrt(l * l - r * r), -r}};
  for (const Case& c : cases) {
    const double qd = 3.0;
    const Output out = Evaluate(*crank, Eigen::VectorXd(), Eigen::Vector2d(c.q, qd), p);
    EXPECT_NEAR(out.y[0], a1 * c.x + d1, 1e-9) << "q " << c.q;
    EXPECT_NEAR(out.y[1], a2 * (length - c.x) + d2, 1e-9) << "q " << c.q;
    EXPECT_NEAR(out.y[4], c.lever, 1e-12) << "q " << c.q;
    EXPECT_NEAR(out.y[2], a1 * c.lever * qd, 1e-9) << "q " << c.q;
    EXPECT_NEAR(out.y[3], -a2 * c.lever * qd, 1e-9) << "q " << c.q;
  }
}

TEST(PneumaticSliderCrank, RatesAreEquations37And38AndTheDerivativeOfTheVolumes) {
  const auto crank = Make("pneumatic.slider_crank");
  const Eigen::VectorXd p = Nominal(*crank);
  const double a1 = 804.0, a2 = 603.0, r = 15.0, l = 40.0;
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 20; ++trial) {
    const double q = testing::Uniform(rng, -kPi, kPi), qd = testing::Uniform(rng, -10.0, 10.0);
    const Output out = Evaluate(*crank, Eigen::VectorXd(), Eigen::Vector2d(q, qd), p);
    const double s = std::sin(q), c = std::cos(q);
    const double bracket = qd * r * s + qd * r * r * s * c / std::sqrt(l * l - r * r * s * s);
    EXPECT_NEAR(out.y[2], -a1 * bracket,
                kRearrangedFormulaTolerance * (1.0 + a1 * std::fabs(bracket)));
    EXPECT_NEAR(out.y[3], a2 * bracket,
                kRearrangedFormulaTolerance * (1.0 + a2 * std::fabs(bracket)));
    // dV/dt = dV/dq qd by central differences in q (step 1e-6 rad: truncation ~1e-12 relative).
    const double h = 1e-6;
    const Output plus = Evaluate(*crank, Eigen::VectorXd(), Eigen::Vector2d(q + h, qd), p);
    const Output minus = Evaluate(*crank, Eigen::VectorXd(), Eigen::Vector2d(q - h, qd), p);
    for (int i = 0; i < 2; ++i) {
      const double fd = (plus.y[i] - minus.y[i]) / (2.0 * h) * qd;
      EXPECT_NEAR(out.y[2 + i], fd, kFdTolerance * (1.0 + std::fabs(fd))) << "chamber " << i + 1;
    }
  }
}

// ---- arm --------------------------------------------------------------------------------------

struct ArmSetup {
  std::unique_ptr<Block> arm = Make("pneumatic.arm");
  Eigen::VectorXd p = Nominal(*arm);
  int Index(const std::string& name) const { return ParameterIndex(*arm, name); }
};

TEST(PneumaticArm, IsStiffAndUsesTheSeedConstants) {
  ArmSetup s;
  EXPECT_TRUE(s.arm->info().stiff);
  EXPECT_EQ(s.p[s.Index("alpha")], 0.1124);
  EXPECT_EQ(s.p[s.Index("kappa")], 1.4);
  EXPECT_EQ(s.p[s.Index("temperature")], 298.0);
  EXPECT_EQ(s.p[s.Index("bore_area_1")], 804.0);
  EXPECT_EQ(s.p[s.Index("bore_area_2")], 603.0);
  EXPECT_EQ(s.p[s.Index("dead_volume_1")], 8.0);
  EXPECT_EQ(s.p[s.Index("dead_volume_2")], 6.0);
  EXPECT_EQ(s.p[s.Index("rod_length")], 40.0);
  EXPECT_EQ(s.p[s.Index("crank_radius")], 15.0);
}

TEST(PneumaticArm, EqualPressuresGiveZeroTorqueWhenAtmosphericOrWithEqualBores) {
  ArmSetup s;
  const double p_atm = s.p[s.Index("p_exhaust")];
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 10; ++trial) {
    const double q = testing::Uniform(rng, 0.3, 2.8);
    const Eigen::Vector2d u(testing::Uniform(rng, 0.0, 10.0), testing::Uniform(rng, 0.0, 10.0));
    // Atmospheric pressure in both chambers: no force on the piston whatever the bore areas.
    Output out = Evaluate(*s.arm, Eigen::Vector4d(q, 0.0, p_atm, p_atm), u, s.p);
    EXPECT_EQ(out.y[0], 0.0);
    // Equal bore areas (the seed's eq. 3.6 assumption): any equal pressures, zero torque, and at
    // the hanging angle at rest no acceleration.
    Eigen::VectorXd equal = s.p;
    equal[s.Index("bore_area_2")] = equal[s.Index("bore_area_1")];
    const double pressure = testing::Uniform(rng, 150.0, 600.0);
    const double q_hang = equal[s.Index("gravity_angle")];
    out = Evaluate(*s.arm, Eigen::Vector4d(q, 0.0, pressure, pressure), u, equal);
    EXPECT_NEAR(out.y[0], 0.0, kCancelledTorque);
    out = Evaluate(*s.arm, Eigen::Vector4d(q_hang, 0.0, pressure, pressure), u, equal);
    EXPECT_EQ(out.xdot[0], 0.0);
    EXPECT_NEAR(out.xdot[1], 0.0, kCancelledTorque / equal[s.Index("inertia")]);
    // Table 3.3 areas: the rod cross-section A1 - A2 carries (p - p_atm).
    out = Evaluate(*s.arm, Eigen::Vector4d(q, 0.0, pressure, pressure), u, s.p);
    const double r = 15.0, l = 40.0, sq = std::sin(q), cq = std::cos(q);
    const double lever = -r * sq - r * r * sq * cq / std::sqrt(l * l - r * r * sq * sq);
    const double expected = 1e-6 * lever * (804.0 - 603.0) * (pressure - p_atm);
    EXPECT_NEAR(out.y[0], expected, kRearrangedFormulaTolerance * std::fabs(expected));
  }
}

TEST(PneumaticArm, HigherPressureInChamberOneExtendsThePiston) {
  ArmSetup s;
  // For 0 < q < pi the lever arm dx/dq is negative: pushing the piston to larger x turns the
  // crank towards smaller q.
  const Output out =
      Evaluate(*s.arm, Eigen::Vector4d(1.5, 0.0, 500.0, 150.0), Eigen::Vector2d(5.0, 5.0), s.p);
  EXPECT_LT(out.y[0], 0.0);
}

TEST(PneumaticArm, ComposesTheSeparateBlocks) {
  ArmSetup s;
  const auto valve = Make("pneumatic.valve_area");
  const auto ports = Make("pneumatic.ports");
  const auto crank = Make("pneumatic.slider_crank");
  const auto chamber = Make("pneumatic.chamber");
  // Parameters of a part, copied by name from the arm (with an optional prefix).
  auto params_of = [&](const Block& b, const std::string& prefix) {
    Eigen::VectorXd v(b.NumParameters());
    for (int i = 0; i < b.NumParameters(); ++i) {
      const std::string& name = b.info().parameters[i].name;
      const bool valve_param = &b == valve.get();
      v[i] = s.p[s.Index(valve_param ? prefix + name : name)];
    }
    return v;
  };
  std::mt19937 rng(testing::TestSeed());
  for (int trial = 0; trial < 10; ++trial) {
    // Perturb every arm parameter so that a swapped index would show.
    for (int i = 0; i < s.p.size(); ++i) {
      s.p[i] = s.arm->info().parameters[i].nominal * (1.0 + 0.05 * testing::Uniform(rng, -1, 1));
    }
    const Eigen::Vector4d x(testing::Uniform(rng, 0.5, 2.6), testing::Uniform(rng, -5.0, 5.0),
                            testing::Uniform(rng, 110.0, 590.0),
                            testing::Uniform(rng, 110.0, 590.0));
    const Eigen::Vector2d u(testing::Uniform(rng, 0.0, 10.0), testing::Uniform(rng, 0.0, 10.0));
    const Output arm = Evaluate(*s.arm, x, u, s.p);
    const Output k = Evaluate(*crank, Eigen::VectorXd(), x.head<2>(), params_of(*crank, ""));
    for (int c = 0; c < 2; ++c) {
      const Output areas = Evaluate(*valve, Eigen::VectorXd(), Eigen::VectorXd::Constant(1, u[c]),
                                    params_of(*valve, c == 0 ? "valve1_" : "valve2_"));
      const Output flow =
          Evaluate(*ports, Eigen::VectorXd(), Eigen::Vector3d(x[2 + c], areas.y[0], areas.y[1]),
                   params_of(*ports, ""));
      const Output pdot =
          Evaluate(*chamber, Eigen::VectorXd::Constant(1, x[2 + c]),
                   Eigen::Vector3d(flow.y[0], k.y[c], k.y[2 + c]), params_of(*chamber, ""));
      EXPECT_NEAR(arm.xdot[2 + c], pdot.xdot[0], kSameFormulaTolerance * std::fabs(pdot.xdot[0]))
          << "chamber " << c + 1;
    }
    const double torque =
        pn::PneumaticTorque(k.y[4], x[2], x[3], s.p[s.Index("bore_area_1")],
                            s.p[s.Index("bore_area_2")], s.p[s.Index("p_exhaust")]);
    EXPECT_NEAR(arm.y[0], torque, kSameFormulaTolerance * std::fabs(torque));
    EXPECT_EQ(arm.xdot[0], x[1]);
    const double qdd =
        (torque - s.p[s.Index("damping")] * x[1] -
         s.p[s.Index("gravity_torque")] * std::sin(x[0] - s.p[s.Index("gravity_angle")])) /
        s.p[s.Index("inertia")];
    EXPECT_NEAR(arm.xdot[1], qdd, kRearrangedFormulaTolerance * (1.0 + std::fabs(qdd)));
  }
}

// ---- valve areas ------------------------------------------------------------------------------

BlockOptions ValveModel(const std::string& model) {
  BlockOptions o;
  o.words["model"] = model;
  return o;
}

TEST(PneumaticValveArea, SmaxIsEquations315And316) {
  const auto valve = Make("pneumatic.valve_area", ValveModel("smax"));
  const Eigen::VectorXd p = Nominal(*valve);
  const double lc = p[0], lr = p[1], uc = p[2], ur = p[3], b = p[4], w = pn::kDefaultSmaxWidth;
  auto smax = [&](double z) { return (std::sqrt(z * z + w * w) + z) / 2.0; };
  for (double u = 0.0; u <= 10.0; u += 0.25) {
    const Output out = Evaluate(*valve, Eigen::VectorXd(), Eigen::VectorXd::Constant(1, u), p);
    EXPECT_NEAR(out.y[0], lc + smax((u - uc) * b - lc), 1e-15) << "u " << u;
    EXPECT_NEAR(out.y[1], lr + smax((ur - u) * b - lr), 1e-15) << "u " << u;
  }
  // Far from the opening voltages: leakage, or the linear opening, to within w^2 / (4 |z|).
  const Output closed = Evaluate(*valve, Eigen::VectorXd(), Eigen::VectorXd::Constant(1, 0.0), p);
  EXPECT_NEAR(closed.y[0], lc, w * w / (4.0 * uc * b));
  EXPECT_NEAR(closed.y[1], ur * b, w * w / (4.0 * (ur * b - lr)));
}

TEST(PneumaticValveArea, QuadraticIsEquations312And313) {
  const auto valve = Make("pneumatic.valve_area", ValveModel("quadratic"));
  const Eigen::VectorXd p = Nominal(*valve);
  for (double u : {0.0, 2.5, 5.0, 7.3, 10.0}) {
    const Output out = Evaluate(*valve, Eigen::VectorXd(), Eigen::VectorXd::Constant(1, u), p);
    EXPECT_NEAR(out.y[0], p[0] + p[1] * u + p[2] * u * u, 1e-14);
    EXPECT_NEAR(out.y[1], p[3] + p[4] * u + p[5] * u * u, 1e-14);
  }
}

TEST(PneumaticValveArea, TableInterpolatesHoldsAndTakesTheRightSlopeAtBreakpoints) {
  BlockOptions o = ValveModel("table");
  o.numbers["breakpoints"] = {1.0, 2.0, 4.0};
  const auto valve = Make("pneumatic.valve_area", o);
  ASSERT_EQ(valve->NumParameters(), 6);
  Eigen::VectorXd p(6);
  p << 0.5, 1.5, 0.5, 3.0, 2.0, 1.0;  // supply areas, then exhaust areas
  const Function f = AsFunction(*valve);
  const Function jac = f.Jacobian("y", "u");
  auto at = [&](double u) {
    return Evaluate(*valve, Eigen::VectorXd(), Eigen::VectorXd::Constant(1, u), p).y;
  };
  auto slope = [&](double u) {  // dense d y / d u
    const Eigen::VectorXd nz = jac({Eigen::VectorXd(), Eigen::VectorXd::Constant(1, u), p})[0];
    Eigen::Vector2d d = Eigen::Vector2d::Zero();
    const expr::Sparsity& sp = jac.OutputSparsity(0);
    for (int k = 0; k < sp.nnz(); ++k) d[sp.row()[k]] = nz[k];
    return d;
  };
  // Exact at breakpoints, linear between, held outside.
  EXPECT_EQ(at(1.0)[0], 0.5);
  EXPECT_EQ(at(2.0)[0], 1.5);
  EXPECT_EQ(at(4.0)[1], 1.0);
  EXPECT_NEAR(at(1.5)[0], 1.0, 1e-15);
  EXPECT_NEAR(at(3.0)[0], 1.0, 1e-15);
  EXPECT_NEAR(at(3.0)[1], 1.5, 1e-15);
  EXPECT_EQ(at(0.0)[0], 0.5);
  EXPECT_EQ(at(9.0)[1], 1.0);
  // Derivative convention: the slope of the interval to the right of a breakpoint.
  EXPECT_EQ(slope(0.5)[0], 0.0);   // below the table
  EXPECT_EQ(slope(1.0)[0], 1.0);   // first breakpoint: right slope
  EXPECT_EQ(slope(2.0)[0], -0.5);  // interior: right slope (left would be +1)
  EXPECT_EQ(slope(2.0)[1], -0.5);  // exhaust: right slope (left would be -1)
  EXPECT_EQ(slope(4.0)[0], 0.0);   // last breakpoint: held
  EXPECT_EQ(slope(1.7)[0], 1.0);
}

TEST(PneumaticValveArea, EveryModelAgreesWithExpressionsAndFiniteDifferences) {
  // The shared suite runs the registered test options (table); here all three models.
  expr::DerivativeCheckOptions options;  // default step and tolerance, as the shared suite
  std::mt19937 rng(testing::TestSeed());
  for (const char* model : {"smax", "quadratic", "table"}) {
    const auto valve = Make("pneumatic.valve_area", ValveModel(model));
    const Function f = AsFunction(*valve);
    for (int k = 0; k < 5; ++k) {
      // Midway between the default table's breakpoints (0.2 V apart), where the table is smooth.
      const double u0 = 0.1 + 0.2 * std::floor(testing::Uniform(rng, 0.0, 50.0));
      const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, u0);
      Eigen::VectorXd p = Nominal(*valve);
      for (int i = 0; i < p.size(); ++i) p[i] *= 1.0 + 0.1 * testing::Uniform(rng, -1.0, 1.0);
      const Output out = Evaluate(*valve, Eigen::VectorXd(), u, p);
      const auto ref = f({Eigen::VectorXd(), u, p});
      EXPECT_NEAR(out.y[0], ref[1][0], 1e-14) << model;
      EXPECT_NEAR(out.y[1], ref[1][1], 1e-14) << model;
      for (const char* in : {"u", "p"}) {
        const auto check = expr::CheckJacobian(f, "y", in, {Eigen::VectorXd(), u, p}, options);
        EXPECT_TRUE(check.ok) << model << ": " << check.FullReport();
      }
    }
  }
}

TEST(PneumaticArm, EveryValveModelGivesFiniteDerivatives) {
  std::mt19937 rng(testing::TestSeed());
  for (const char* model : {"smax", "quadratic", "table"}) {
    BlockOptions o;
    o.words["valve_model"] = model;
    const auto arm = Make("pneumatic.arm", o);
    const Function f = AsFunction(*arm);
    const Function jac = f.Jacobian("xdot", "x");
    const Eigen::Vector4d x(1.2, 2.0, 300.0, 300.0);  // equal pressures: laminar band
    const Eigen::Vector2d u(testing::Uniform(rng, 0.0, 10.0), testing::Uniform(rng, 0.0, 10.0));
    const Eigen::VectorXd nz = jac({x, u, Nominal(*arm)})[0];
    EXPECT_TRUE(nz.allFinite()) << model;
  }
}

// ---- options ----------------------------------------------------------------------------------

void ExpectInvalid(const std::string& type, const BlockOptions& o, const std::string& fragment) {
  try {
    Make(type, o);
    ADD_FAILURE() << "expected std::invalid_argument containing '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(PneumaticOptions, AreValidated) {
  BlockOptions typo;
  typo.numbers["laminar_widht"] = {1e-3};
  ExpectInvalid("pneumatic.orifice", typo, "did you mean 'laminar_width'?");
  BlockOptions width;
  width.numbers["laminar_width"] = {0.5};
  ExpectInvalid("pneumatic.ports", width, "expected one number in (0, 0.05]");
  BlockOptions gas;
  gas.numbers["gas_constant"] = {-1.0};
  ExpectInvalid("pneumatic.chamber", gas, "gas_constant");
  ExpectInvalid("pneumatic.valve_area", ValveModel("smx"), "did you mean 'smax'?");
  BlockOptions unsorted = ValveModel("table");
  unsorted.numbers["breakpoints"] = {0.0, 5.0, 5.0};
  ExpectInvalid("pneumatic.valve_area", unsorted, "strictly increasing");
  BlockOptions misplaced = ValveModel("quadratic");
  misplaced.numbers["breakpoints"] = {0.0, 5.0};
  ExpectInvalid("pneumatic.valve_area", misplaced, "applies only to model 'table'");
  BlockOptions arm;
  arm.words["model"] = "table";
  ExpectInvalid("pneumatic.arm", arm, "unknown option 'model'");
  ExpectInvalid("pneumatic.slider_crank", typo, "unknown option 'laminar_widht'");
  BlockOptions fine;
  fine.numbers["laminar_width"] = {1e-3};
  EXPECT_NO_THROW(Make("pneumatic.orifice", fine));
}

TEST(PneumaticOptions, DefaultTableIsTheSeedGrid) {
  const auto valve = Make("pneumatic.valve_area", ValveModel("table"));
  EXPECT_EQ(valve->NumParameters(), 100);  // 50 breakpoints 0.2..10 V, supply and exhaust
  const auto arm = Make("pneumatic.arm");
  EXPECT_EQ(arm->NumParameters(), 17 + 2 * 5);  // fixed part + two smax valves
}

}  // namespace
}  // namespace graybox::models
