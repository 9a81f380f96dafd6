// The shared suite over every registered block: metadata complete and consistent, evaluation on
// doubles equal to evaluation through libexpr, derivatives (outputs and state derivatives with
// respect to states, inputs and parameters) equal to central finite differences. A new block is
// covered by registering it.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>

#include "graybox/expr/derivative_check.h"
#include "graybox/expr/function.h"
#include "graybox/models/block.h"
#include "graybox/models/model.h"
#include "graybox/util/did_you_mean.h"
#include "test_util.h"

namespace graybox::models {
namespace {

using expr::Expr;
using expr::Function;

// Same scalar code on doubles and through the tape: differences are rounding only, and the tape
// may fuse or reorder nothing that changes IEEE results, so agreement is to a few ulps.
constexpr double kDoubleVersusExprTolerance = 1e-12;
constexpr int kPointsPerBlock = 3;

class RegisteredBlock : public ::testing::TestWithParam<std::string> {
 protected:
  std::unique_ptr<Block> Make() const {
    const auto& registry = BlockRegistry::Global();
    return registry.Create(GetParam(), registry.TestOptions(GetParam()));
  }
};

struct Point {
  Eigen::VectorXd x, u, p;
};

Point RandomPoint(const Block& b, std::mt19937& rng) {
  Point pt;
  auto sample = [&](const std::vector<SignalInfo>& signals) {
    Eigen::VectorXd v(static_cast<int>(signals.size()));
    for (std::size_t i = 0; i < signals.size(); ++i) {
      v[static_cast<int>(i)] =
          testing::Uniform(rng, signals[i].typical_min, signals[i].typical_max);
    }
    return v;
  };
  pt.x = sample(b.info().states);
  pt.u = sample(b.info().inputs);
  pt.p.resize(b.NumParameters());
  for (int i = 0; i < b.NumParameters(); ++i) {
    const ParameterInfo& par = b.info().parameters[i];
    double v = par.nominal * (1.0 + 0.1 * testing::Uniform(rng, -1.0, 1.0));
    if (par.nominal == 0.0) v = 0.1 * testing::Uniform(rng, -1.0, 1.0);
    pt.p[i] = std::min(par.upper, std::max(par.lower, v));
  }
  return pt;
}

// The block as a Function of (x, u, p) with outputs "xdot" and "y".
Function AsFunction(const Block& b) {
  const std::vector<Expr> x = Expr::Symbols("x", b.NumStates());
  const std::vector<Expr> u = Expr::Symbols("u", b.NumInputs());
  const std::vector<Expr> p = Expr::Symbols("p", b.NumParameters());
  std::vector<Expr> xdot(b.NumStates()), y(b.NumOutputs());
  BlockArgs<Expr> args{x.data(), u.data(), p.data(), xdot.data(), y.data()};
  b.Evaluate(args);
  return Function(b.info().type, {{"x", x}, {"u", u}, {"p", p}}, {{"xdot", xdot}, {"y", y}});
}

TEST_P(RegisteredBlock, MetadataIsCompleteAndConsistent) {
  const auto block = Make();
  const BlockInfo& info = block->info();
  EXPECT_EQ(info.type, GetParam());
  EXPECT_FALSE(info.description.empty());
  EXPECT_FALSE(info.reference.empty());
  EXPECT_GT(block->NumOutputs() + block->NumStates(), 0);
  auto check_signals = [&](const std::vector<SignalInfo>& signals, const char* kind) {
    std::set<std::string> names;
    for (const SignalInfo& s : signals) {
      EXPECT_FALSE(s.name.empty()) << kind;
      EXPECT_TRUE(names.insert(s.name).second) << kind << " '" << s.name << "' repeated";
      EXPECT_FALSE(s.unit.empty()) << kind << " '" << s.name << "' has no unit";
      EXPECT_FALSE(s.description.empty()) << kind << " '" << s.name << "' has no description";
      EXPECT_LT(s.typical_min, s.typical_max) << kind << " '" << s.name << "'";
    }
  };
  check_signals(info.inputs, "input");
  check_signals(info.outputs, "output");
  check_signals(info.states, "state");
  std::set<std::string> names;
  for (const ParameterInfo& par : info.parameters) {
    EXPECT_TRUE(names.insert(par.name).second) << "parameter '" << par.name << "' repeated";
    EXPECT_FALSE(par.unit.empty()) << "parameter '" << par.name << "' has no unit";
    EXPECT_FALSE(par.description.empty()) << "parameter '" << par.name << "'";
    EXPECT_LE(par.lower, par.nominal) << "parameter '" << par.name << "'";
    EXPECT_LE(par.nominal, par.upper) << "parameter '" << par.name << "'";
    if (par.HasNeutral()) {
      EXPECT_LE(par.lower, par.neutral) << "parameter '" << par.name << "'";
      EXPECT_LE(par.neutral, par.upper) << "parameter '" << par.name << "'";
    }
  }
}

TEST_P(RegisteredBlock, DoublesEqualExpressions) {
  const auto block = Make();
  const Function f = AsFunction(*block);
  std::mt19937 rng(testing::TestSeed());
  for (int k = 0; k < kPointsPerBlock; ++k) {
    const Point pt = RandomPoint(*block, rng);
    Eigen::VectorXd xdot(block->NumStates()), y(block->NumOutputs());
    block->Evaluate(
        BlockArgs<double>{pt.x.data(), pt.u.data(), pt.p.data(), xdot.data(), y.data()});
    const auto ref = f({pt.x, pt.u, pt.p});
    for (int i = 0; i < xdot.size(); ++i) {
      EXPECT_NEAR(xdot[i], ref[0][i], kDoubleVersusExprTolerance * (1.0 + std::fabs(ref[0][i])))
          << "xdot '" << block->info().states[i].name << "'";
    }
    for (int i = 0; i < y.size(); ++i) {
      EXPECT_NEAR(y[i], ref[1][i], kDoubleVersusExprTolerance * (1.0 + std::fabs(ref[1][i])))
          << "y '" << block->info().outputs[i].name << "'";
    }
  }
}

TEST_P(RegisteredBlock, DerivativesMatchFiniteDifferences) {
  // Scaled coordinates, so small SI parameters get proportionate steps (see test_util.h).
  testing::ExpectBlockDerivativesMatch(*Make(), testing::TestSeed());
}

TEST_P(RegisteredBlock, FixedByDefaultParametersAreUsableSettings) {
  const auto block = Make();
  // A parameter fixed by default is used at its nominal value: it must be a finite number inside
  // the bounds (checked above), and Model::AddBlock must start it fixed and every other one free.
  for (const ParameterInfo& par : block->info().parameters) {
    if (par.fixed_by_default) {
      EXPECT_TRUE(std::isfinite(par.nominal)) << par.name;
    }
  }
  Model m("one_block");
  std::vector<std::string> inputs, outputs;
  for (const SignalInfo& s : block->info().inputs) inputs.push_back("in_" + s.name);
  for (const SignalInfo& s : block->info().outputs) outputs.push_back("out_" + s.name);
  m.AddBlock("b", std::shared_ptr<const Block>(Make()), inputs, outputs);
  for (const ParameterInfo& par : block->info().parameters) {
    EXPECT_EQ(m.Parameter("b." + par.name).free, !par.fixed_by_default) << par.name;
  }
}

// The units a signal of each role may have (SignalRole in block.h).
bool UnitFitsRole(SignalRole role, const std::string& unit) {
  auto one_of = [&](std::initializer_list<const char*> units) {
    for (const char* u : units) {
      if (unit == u) return true;
    }
    return false;
  };
  switch (role) {
    case SignalRole::kNone:
      return true;
    case SignalRole::kPosition:
      return one_of({"m", "rad"});
    case SignalRole::kVelocity:
      return one_of({"m/s", "rad/s"});
    case SignalRole::kAcceleration:
      return one_of({"m/s^2", "rad/s^2"});
    case SignalRole::kForce:
      return one_of({"N", "N m"});
    case SignalRole::kPressure:
      return one_of({"Pa", "kPa", "bar"});
    case SignalRole::kVoltage:
      return one_of({"V"});
    case SignalRole::kCurrent:
      return one_of({"A"});
  }
  return false;
}

TEST_P(RegisteredBlock, SignalRolesFitTheirUnits) {
  const auto block = Make();
  for (const auto* signals :
       {&block->info().inputs, &block->info().outputs, &block->info().states}) {
    for (const SignalInfo& s : *signals) {
      EXPECT_TRUE(UnitFitsRole(s.role, s.unit))
          << "'" << s.name << "' is a " << SignalRoleName(s.role) << " in '" << s.unit << "'";
    }
  }
}

std::vector<std::string> RegisteredTypes() { return BlockRegistry::Global().Types(); }

INSTANTIATE_TEST_SUITE_P(AllBlocks, RegisteredBlock, ::testing::ValuesIn(RegisteredTypes()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = info.param;
                           for (char& c : name) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return name;
                         });
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(RegisteredBlock);

// Exactly the known settings: the parameters the problem files fixed before fixed_by_default
// existed (the gains and the limit of control.cascade_p) and the ripple's design period, with the
// shared tests' options and with the defaults.
TEST(BlockRegistry, FixedByDefaultAreExactlyTheKnownSettings) {
  const BlockRegistry& registry = BlockRegistry::Global();
  std::set<std::string> fixed;
  for (const std::string& type : registry.Types()) {
    for (const BlockOptions& options : {registry.TestOptions(type), BlockOptions{}}) {
      std::unique_ptr<Block> block;
      try {
        block = registry.Create(type, options);
      } catch (const std::invalid_argument&) {
        continue;  // a block that needs options (its test options are covered)
      }
      for (const ParameterInfo& par : block->info().parameters) {
        if (par.fixed_by_default) fixed.insert(type + "." + par.name);
      }
    }
  }
  EXPECT_EQ(fixed, (std::set<std::string>{"control.cascade_p.kp", "control.cascade_p.kv",
                                          "control.cascade_p.limit", "friction.ripple.period"}));
}

// The physical roles of the mechanical axis signals of the friction, mechanics, load, drive and
// pneumatic blocks (with the shared tests' options). Every signal of these blocks not listed here
// must have no role.
TEST(BlockRegistry, AxisSignalsOfMechanicalBlocksHaveTheirRoles) {
  using R = SignalRole;
  struct Roles {
    std::map<std::string, R> inputs, outputs, states;
  };
  const Roles friction{{{"qd", R::kVelocity}}, {{"tau", R::kForce}}, {}};
  const std::map<std::string, Roles> expected = {
      {"friction.viscous", friction},
      {"friction.coulomb", friction},
      {"friction.offset", friction},
      {"friction.asymmetric", friction},
      {"friction.stribeck", friction},
      {"friction.power_viscous", friction},
      {"friction.dahl", friction},  // z, the bristle deflection, has none
      {"friction.lugre", friction},
      {"friction.kuka", friction},
      {"friction.torque_dependent",
       {{{"qd", R::kVelocity}, {"tau_load", R::kForce}},
        {{"tau", R::kForce}},
        {{"tau_d", R::kForce}}}},
      {"friction.ripple", {{{"q", R::kPosition}}, {{"tau", R::kForce}}, {}}},
      {"mechanics.mass", {{{"force", R::kForce}}, {}, {{"q", R::kPosition}, {"qd", R::kVelocity}}}},
      {"control.cascade_p",
       {{{"q", R::kPosition}, {"qd", R::kVelocity}}, {{"nu", R::kVoltage}}, {}}},
      {"drive.two_mass",
       {{{"tau_m", R::kForce}, {"tau_ext", R::kForce}},
        {{"q_m", R::kPosition},
         {"qd_m", R::kVelocity},
         {"q_l", R::kPosition},
         {"qd_l", R::kVelocity},
         {"tau_s", R::kForce}},
        {{"q_m", R::kPosition},
         {"qd_m", R::kVelocity},
         {"q_l", R::kPosition},
         {"qd_l", R::kVelocity}}}},
      {"drive.gear",
       {{{"tau_m", R::kForce}, {"qd", R::kVelocity}, {"qdd", R::kAcceleration}},
        {{"tau", R::kForce}, {"qd_m", R::kVelocity}},
        {}}},
      {"drive.dc_motor",
       {{{"u", R::kVoltage}, {"tau_load", R::kForce}},
        {{"theta", R::kPosition}, {"omega", R::kVelocity}, {"i", R::kCurrent}},
        {{"theta", R::kPosition}, {"omega", R::kVelocity}, {"i", R::kCurrent}}}},
      {"drive.backlash", {}},  // a deflection is not an axis position
      // e and ed are a deflection and its rate: no role, so the diagnosis finds no new axis.
      {"mechanics.elastic_coupling", {{{"F", R::kForce}}, {{"F_c", R::kForce}}, {}}},
      {"pneumatic.orifice", {{{"p_up", R::kPressure}, {"p_down", R::kPressure}}, {}, {}}},
      {"pneumatic.chamber", {{}, {}, {{"p", R::kPressure}}}},
      {"pneumatic.ports", {{{"p", R::kPressure}}, {}, {}}},
      {"pneumatic.valve_area", {{{"u", R::kVoltage}}, {}, {}}},
      {"pneumatic.slider_crank", {{{"q", R::kPosition}, {"qd", R::kVelocity}}, {}, {}}},
      {"pneumatic.piston_torque",
       {{{"p1", R::kPressure}, {"p2", R::kPressure}}, {{"torque", R::kForce}}, {}}},
      {"pneumatic.arm",
       {{{"u1", R::kVoltage}, {"u2", R::kVoltage}},
        {{"torque", R::kForce}},
        {{"q", R::kPosition}, {"qd", R::kVelocity}, {"p1", R::kPressure}, {"p2", R::kPressure}}}},
  };
  const BlockRegistry& registry = BlockRegistry::Global();
  for (const auto& [type, roles] : expected) {
    SCOPED_TRACE(type);
    const auto block = registry.Create(type, registry.TestOptions(type));
    auto check = [&](const std::vector<SignalInfo>& signals, const std::map<std::string, R>& want,
                     const char* kind) {
      std::size_t found = 0;
      for (const SignalInfo& s : signals) {
        auto it = want.find(s.name);
        found += it != want.end();
        const R role = it == want.end() ? R::kNone : it->second;
        EXPECT_EQ(s.role, role) << kind << " '" << s.name << "' is a " << SignalRoleName(s.role)
                                << ", expected a " << SignalRoleName(role);
      }
      EXPECT_EQ(found, want.size()) << kind << ": a listed signal is missing";
    };
    check(block->info().inputs, roles.inputs, "input");
    check(block->info().outputs, roles.outputs, "output");
    check(block->info().states, roles.states, "state");
  }
}

TEST(BlockRegistry, UnknownTypeSuggestsTheClosest) {
  const auto types = BlockRegistry::Global().Types();
  if (types.empty()) GTEST_SKIP() << "no block registered yet";
  std::string typo = types.front();
  typo.back() = typo.back() == 'x' ? 'y' : 'x';
  try {
    BlockRegistry::Global().Create(typo);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean '" + types.front() + "'"), std::string::npos)
        << e.what();
  }
}

TEST(BlockRegistry, DidYouMeanPicksTheClosestWord) {
  EXPECT_EQ(util::DidYouMean("stribek", {"stribeck", "coulomb", "viscous"}), "stribeck");
  EXPECT_EQ(util::DidYouMean("zzzzzz", {"stribeck", "coulomb"}), "");
}

}  // namespace
}  // namespace graybox::models
