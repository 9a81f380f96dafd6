// ScreenAndRefit on a synthetic sliding mass whose truth has a friction the nominal model lacks,
// of a shape no candidate block has (a Stribeck curve with exponent 1 and a steeper smooth sign
// than the candidates' default), and on a truth equal to the nominal model; EnumerateCandidates'
// axes and attachments from metadata; the chi-square survival function against tables; a Stribeck
// excess beside a Coulomb level on a slow axis, whose hump lies below 1 / the blocks' default
// steepness.
#include "graybox/diagnosis/screening.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/diagnosis/candidates.h"
#include "graybox/estimators/fit/fit.h"
#include "graybox/models/model.h"
#include "slide_truth.h"

namespace graybox::diagnosis {
namespace {

// Re-fit budget [s] that the small synthetic problems here never reach (see its use).
constexpr double kRefitSecondsThatNeverBind = 600.0;

namespace est = graybox::estimators;

constexpr double kPi = 3.14159265358979323846;

unsigned Seed() {
  const char* s = std::getenv("GRAYBOX_TEST_SEED");
  const unsigned seed = s ? static_cast<unsigned>(std::strtoul(s, nullptr, 10)) : 20240611u;
  std::cout << "seed " << seed << " (GRAYBOX_TEST_SEED overrides)\n";
  return seed;
}

// The truth: a 2 kg slide with viscous friction 3 N s/m, and optionally the withheld friction
//   f(v) = (fc + (fs - fc) exp(-|v| / vs)) tanh(v / vd)
// (Stribeck exponent 1, vd = 2 mm/s; the candidate blocks use exponent 2 and tanh(100 v)).
constexpr double kMass = 2.0;       // [kg]
constexpr double kViscous = 3.0;    // [N s/m]
constexpr double kFc = 1.0;         // [N]
constexpr double kFs = 1.8;         // [N]
constexpr double kVs = 0.05;        // [m/s]
constexpr double kVd = 0.002;       // [m/s]
constexpr double kDt = 0.01;        // [s]
constexpr int kSamples = 1000;      // per split (10 s)
constexpr int kSubsteps = 40;       // RK4 steps per sample of the truth (h = 0.25 ms)
constexpr double kNoiseStd = 0.01;  // [m/s], measurement noise on the velocity

double TruthFriction(double v, bool withheld) {
  if (!withheld) return 0.0;
  return (kFc + (kFs - kFc) * std::exp(-std::fabs(v) / kVs)) * std::tanh(v / kVd);
}

// A multisine force [N]; `phase` makes the validation record differ from the estimation one.
double Force(double t, double phase) {
  return 2.5 * std::sin(2.0 * kPi * 0.3 * t + phase) +
         1.5 * std::sin(2.0 * kPi * 0.9 * t + 1.0 + 2.0 * phase) +
         0.8 * std::sin(2.0 * kPi * 1.7 * t + 2.0 + 3.0 * phase);
}

// The truth's measured velocity, RK4 with kSubsteps steps per sample, input held over a sample.
est::SplitData TruthSplit(const std::string& name, est::SplitRole role, double phase, bool withheld,
                          std::mt19937* rng) {
  est::Experiment e;
  e.name = name;
  e.dt = kDt;
  e.u.resize(kSamples, 1);
  e.y.resize(kSamples, 1);
  std::normal_distribution<double> noise(0.0, kNoiseStd);
  double v = 0.0;
  const double h = kDt / kSubsteps;
  for (int k = 0; k < kSamples; ++k) {
    const double u = Force(k * kDt, phase);
    e.u(k, 0) = u;
    e.y(k, 0) = v + noise(*rng);
    auto f = [&](double vv) { return (u - kViscous * vv - TruthFriction(vv, withheld)) / kMass; };
    for (int s = 0; s < kSubsteps; ++s) {
      const double k1 = f(v), k2 = f(v + 0.5 * h * k1), k3 = f(v + 0.5 * h * k2),
                   k4 = f(v + h * k3);
      v += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
  }
  return est::MakeSplit(name, role, e, Eigen::VectorXd::Zero(2));
}

// The nominal model: the slide with viscous friction only; output its velocity.
models::Model NominalModel() {
  models::Model m("slide");
  m.AddInput("force", "N", "drive force", -5.0, 5.0);
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  m.AddBlock("load", "mechanics.mass", prismatic, {"force"}, {});
  m.AddBlock("friction", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  m.SetParameter("load.mass", 1.0);
  m.SetParameter("friction.fv", 1.0);
  m.AddOutput("load.qd");
  return m;
}

est::Problem NominalProblem() {
  est::EstimationSpec spec;
  spec.step.substeps = 4;  // the candidates' smooth sign is steep: 4 RK4 steps per sample
  return est::MakeProblem("slide", NominalModel(), spec);
}

struct Case {
  Diagnosis diagnosis;
  est::FitResult nominal;
  std::vector<std::string> progress;  // the screening's progress lines
};

Case RunCase(bool withheld, bool refit_in_processes = false, int refit_top = 5) {
  std::mt19937 rng(Seed());
  const std::vector<est::SplitData> splits = {
      TruthSplit("estimation", est::SplitRole::kEstimation, 0.0, withheld, &rng),
      TruthSplit("validation", est::SplitRole::kValidation, 0.7, withheld, &rng)};
  const est::Problem problem = NominalProblem();
  Case c;
  c.nominal = est::Fit(problem, splits);
  std::cout << c.nominal.BriefReport() << "\n";
  EXPECT_TRUE(c.nominal.IsSolutionUsable());
  ScreeningOptions options;
  // A budget that binds stops a re-fit at an iteration that depends on the CPU time its iterations
  // take (cache and frequency effects of a loaded machine); one that never binds on these small
  // problems keeps the test deterministic.
  options.refit_max_seconds = kRefitSecondsThatNeverBind;
  options.refit_in_processes = refit_in_processes;
  options.refit_top = refit_top;
  options.num_threads = 2;  // re-fits side by side, so that processes are used where asked
  options.progress = [&c](const std::string& line) {
    std::cout << line << "\n";
    c.progress.push_back(line);
  };
  c.diagnosis = ScreenAndRefit(problem, splits, c.nominal, options);
  std::cout << c.diagnosis.FullReport();
  return c;
}

bool IsCoulombLike(const std::string& effect) {
  return effect == "coulomb" || effect == "stribeck";
}

// 25 times the nominal solve's user CPU time on its thread, at least 10 s; the solve's wall time,
// which a loaded machine lengthens, plays no part.
TEST(AutomaticRefitBudget, TwentyFiveTimesTheNominalSolvesThreadCpuTimeAtLeastTenSeconds) {
  est::FitResult nominal;
  nominal.seconds = {{"solve", 100.0}};
  nominal.solve_thread_user_seconds = 2.0;
  EXPECT_DOUBLE_EQ(AutomaticRefitBudget(nominal), 50.0);
  nominal.solve_thread_user_seconds = 0.1;
  EXPECT_DOUBLE_EQ(AutomaticRefitBudget(nominal), 10.0);
  nominal.solve_thread_user_seconds = 0.0;  // not solved in this process
  EXPECT_DOUBLE_EQ(AutomaticRefitBudget(nominal), 10.0);
}

TEST(ChiSquareSurvival, MatchesTables) {
  // chi^2 tables to 4 significant digits.
  constexpr double kTableTolerance = 1e-4;
  EXPECT_NEAR(ChiSquareSurvival(3.8415, 1), 0.05, kTableTolerance);
  EXPECT_NEAR(ChiSquareSurvival(6.6349, 1), 0.01, kTableTolerance);
  EXPECT_NEAR(ChiSquareSurvival(9.2103, 2), 0.01, kTableTolerance);
  EXPECT_NEAR(ChiSquareSurvival(18.307, 10), 0.05, kTableTolerance);
  EXPECT_NEAR(ChiSquareSurvival(2.0, 2), std::exp(-1.0), 1e-12);  // exact for dof 2
  EXPECT_EQ(ChiSquareSurvival(0.0, 3), 1.0);
  EXPECT_THROW(ChiSquareSurvival(1.0, 0), std::invalid_argument);
}

// Candidate::reduces_to: the Stribeck block contains Coulomb friction through its own level and
// viscous friction through its own fv, each only where the axis lacks that block (else the term is
// held at 0); a power law and LuGre (its sigma2) contain viscous friction on an axis without it,
// LuGre presliding too.
TEST(EnumerateCandidates, NestedFrictionCandidatesNameTheSimplerEffectsTheyContain) {
  for (const bool with_viscous : {false, true}) {
    models::Model m("slide");
    m.AddInput("u", "N", "force", -5.0, 5.0);
    models::BlockOptions prismatic;
    prismatic.words["motion"] = "prismatic";
    m.AddBlock("cart", "mechanics.mass", prismatic, {"u"}, {});
    if (with_viscous) m.AddBlock("damper", "friction.viscous", prismatic, {"cart.qd"}, {"-u"});
    m.AddOutput("cart.q");
    CandidateOptions friction;
    friction.effects = {"stribeck", "power_law_viscous", "presliding"};
    friction.lugre_presliding = true;
    std::map<std::string, std::vector<std::string>> reduces_to;  // by effect and detail
    for (const Candidate& c : EnumerateCandidates(est::MakeProblem("slide", m), friction)) {
      reduces_to[c.effect + " " + c.detail] = c.reduces_to;
    }
    using Names = std::vector<std::string>;
    const Names stribeck = with_viscous ? Names{"coulomb"} : Names{"coulomb", "viscous"};
    const Names power_law = with_viscous ? Names{} : Names{"viscous"};
    const Names lugre = with_viscous ? Names{"presliding"} : Names{"viscous", "presliding"};
    ASSERT_EQ(reduces_to.count("stribeck friction.stribeck"), 1u);
    ASSERT_EQ(reduces_to.count("power_law_viscous friction.power_viscous"), 1u);
    ASSERT_EQ(reduces_to.count("presliding lugre"), 1u);
    ASSERT_EQ(reduces_to.count("presliding dahl"), 1u);
    EXPECT_EQ(reduces_to["stribeck friction.stribeck"], stribeck);
    EXPECT_EQ(reduces_to["power_law_viscous friction.power_viscous"], power_law);
    EXPECT_EQ(reduces_to["presliding lugre"], lugre);
    EXPECT_EQ(reduces_to["presliding dahl"], Names{});
  }
}

TEST(EnumerateCandidates, FindsTheAxisFromMetadata) {
  // Input u drives the force through a gain, so it is a pure input that feeds the axis.
  models::Model m("slide");
  m.AddInput("u", "V", "command", -5.0, 5.0);
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  models::BlockOptions gain;
  gain.words["input_unit"] = "V";
  gain.words["output_unit"] = "N";
  m.AddBlock("amp", "signal.gain", gain, {"u"}, {"f"});
  m.AddBlock("cart", "mechanics.mass", prismatic, {"f"}, {});
  m.AddBlock("damper", "friction.viscous", prismatic, {"cart.qd"}, {"-f"});
  m.AddOutput("cart.q");
  const est::Problem problem = est::MakeProblem("slide", m);

  const std::vector<MechanicalAxis> axes = FindAxes(problem);
  ASSERT_EQ(axes.size(), 1u);
  EXPECT_EQ(axes[0].velocity, "cart.qd");
  EXPECT_EQ(axes[0].force, "f");
  EXPECT_EQ(axes[0].connection, "-f");
  EXPECT_TRUE(axes[0].prismatic);
  EXPECT_EQ(axes[0].present_types, std::vector<std::string>{"friction.viscous"});
  EXPECT_EQ(axes[0].inputs, std::vector<std::string>{"u"});

  CandidateOptions friction_and_delay;
  friction_and_delay.effects = {"coulomb",           "asymmetric_friction", "stribeck",   "viscous",
                                "power_law_viscous", "presliding",          "input_delay"};
  const std::vector<Candidate> candidates = EnumerateCandidates(problem, friction_and_delay);
  std::vector<std::string> effects;
  for (const auto& c : candidates) effects.push_back(c.effect);
  const std::vector<std::string> expected = {
      "coulomb",           "asymmetric_friction", "asymmetric_friction", "stribeck",
      "power_law_viscous", "presliding",          "input_delay"};
  EXPECT_EQ(effects, expected);
  // Every candidate leaves the model's outputs unchanged at its neutral value.
  const models::StateSpaceModel base = m.Build();
  for (const auto& c : candidates) {
    models::Model a = m;
    c.apply(&a);
    const models::StateSpaceModel built = a.Build();
    Eigen::VectorXd x = Eigen::VectorXd::Zero(built.NumStates());
    x[base.StateIndex("cart.q")] = 0.3;
    x[base.StateIndex("cart.qd")] = 0.2;
    Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 1.5);
    for (int i = base.NumStates(); i < built.NumStates(); ++i) x[i] = 0.01;
    const Eigen::VectorXd xdot = built.dynamics({x, u, built.ParameterValues()})[0];
    const Eigen::VectorXd xdot0 =
        base.dynamics({x.head(base.NumStates()), u, base.ParameterValues()})[0];
    // Same expressions evaluated in another order: rounding only.
    constexpr double kNeutralTolerance = 1e-12;
    EXPECT_NEAR((xdot.head(base.NumStates()) - xdot0).norm(), 0.0, kNeutralTolerance) << c.Name();
    EXPECT_FALSE(c.screened.empty()) << c.Name();
    for (const auto& q : c.screened) {
      EXPECT_TRUE(built.parameters[built.ParameterIndex(q)].free) << q;
    }
  }
  EXPECT_THROW(EnumerateCandidates(problem, CandidateOptions{{"colomb"}}), std::invalid_argument);
}

TEST(ScreenAndRefit, WithheldStribeckFrictionIsNamedAndShrinksTheGap) {
  const Case c = RunCase(true);
  const Diagnosis& d = c.diagnosis;
  ASSERT_FALSE(d.screened.empty());
  ASSERT_FALSE(d.refits.empty());
  EXPECT_TRUE(IsCoulombLike(d.screened.front().candidate.effect))
      << d.screened.front().candidate.effect;
  // A friction level of 1 N on a 0.5 m/s slide is far above the noise: overwhelming evidence.
  constexpr double kSignificance = 1e-6;
  EXPECT_LT(d.screened.front().p_value, kSignificance);
  const RefitResult& best = d.refits.front();
  EXPECT_TRUE(best.ok) << best.failure;
  EXPECT_FALSE(best.at_bound);
  EXPECT_TRUE(IsCoulombLike(best.effect)) << best.effect;
  // The best re-fit must remove at least half of the nominal validation error (the shapes
  // differ, so not all of it; the noise floor is kNoiseStd / std(v) ~ 0.03).
  constexpr double kMinGapClosed = 0.5;
  EXPECT_LT(best.validation_nrmse_after, best.validation_nrmse_before);
  EXPECT_GT(best.relative_gain, kMinGapClosed);
  EXPECT_LT(best.bic, d.nominal_bic);
  for (const RefitResult& r : d.refits) {
    if (!r.ok) {
      EXPECT_FALSE(r.failure.empty());
    }
  }
}

// The re-fits of this Ipopt problem in child processes (ScreeningOptions::refit_in_processes,
// two threads) and in threads: the same computation on the same data, so the same ranking,
// statuses, stages and numbers; the fits the parent builds again from the children's solver points
// carry the same parameter values, standard errors and validation simulations.
TEST(ScreenAndRefit, RefitsInProcessesEqualRefitsInThreads) {
  // The best three by score: two re-fits side by side, then the third.
  constexpr int kRefits = 3;
  const Case processes = RunCase(true, true, kRefits);
  const Case threads = RunCase(true, false, kRefits);
  auto in_a_process = [](const Case& c) {
    int n = 0;
    for (const std::string& line : c.progress) n += line.find(" in a process") != line.npos;
    return n;
  };
  EXPECT_EQ(in_a_process(processes), kRefits);
  EXPECT_EQ(in_a_process(threads), 0);
  // Both runs compute the same floating-point operations in the same order.
  constexpr double kSameComputation = 1e-12;
  auto near = [](double a, double b) {
    return (std::isnan(a) && std::isnan(b)) ||
           std::fabs(a - b) <= kSameComputation * std::max(1.0, std::fabs(b));
  };
  const std::vector<RefitResult>& p = processes.diagnosis.refits;
  const std::vector<RefitResult>& t = threads.diagnosis.refits;
  ASSERT_EQ(p.size(), t.size());
  ASSERT_GE(p.size(), 2u);
  for (std::size_t i = 0; i < p.size(); ++i) {
    SCOPED_TRACE(t[i].candidate.Name());
    EXPECT_EQ(p[i].candidate.Name(), t[i].candidate.Name());
    EXPECT_EQ(p[i].ok, t[i].ok);
    EXPECT_EQ(p[i].at_bound, t[i].at_bound);
    EXPECT_EQ(p[i].failure, t[i].failure);
    EXPECT_TRUE(near(p[i].validation_nrmse_after, t[i].validation_nrmse_after))
        << p[i].validation_nrmse_after << " against " << t[i].validation_nrmse_after;
    EXPECT_TRUE(near(p[i].aic, t[i].aic));
    EXPECT_EQ(p[i].candidate.augmentation.options.numbers,
              t[i].candidate.augmentation.options.numbers);
    ASSERT_EQ(p[i].stages.size(), t[i].stages.size());
    // The last stage line holds times; the others say what was done.
    for (std::size_t k = 0; k + 1 < p[i].stages.size(); ++k) {
      EXPECT_EQ(p[i].stages[k], t[i].stages[k]);
    }
    EXPECT_EQ(p[i].fit.solver_result.status, t[i].fit.solver_result.status);
    EXPECT_EQ(p[i].fit.solver_result.iterations, t[i].fit.solver_result.iterations);
    ASSERT_EQ(p[i].fit.values.size(), t[i].fit.values.size());
    for (Eigen::Index k = 0; k < p[i].fit.values.size(); ++k) {
      EXPECT_TRUE(near(p[i].fit.values[k], t[i].fit.values[k]));
    }
    ASSERT_EQ(p[i].parameters.size(), t[i].parameters.size());
    for (std::size_t k = 0; k < p[i].parameters.size(); ++k) {
      EXPECT_EQ(p[i].parameters[k].free, t[i].parameters[k].free);
      EXPECT_TRUE(near(p[i].parameters[k].initial, t[i].parameters[k].initial));
      EXPECT_TRUE(near(p[i].parameters[k].std_error, t[i].parameters[k].std_error))
          << p[i].parameters[k].name;
    }
    ASSERT_EQ(p[i].fit.evaluations.size(), t[i].fit.evaluations.size());
    for (std::size_t k = 0; k < p[i].fit.evaluations.size(); ++k) {
      EXPECT_TRUE(p[i].fit.evaluations[k].simulated.isApprox(t[i].fit.evaluations[k].simulated,
                                                             kSameComputation));
    }
  }
}

TEST(ScreenAndRefit, NoWithheldEffectGivesNoSignificantCandidate) {
  const Case c = RunCase(false);
  // The level below which a candidate would count as found: with five candidates tested, the
  // family-wise false-alarm rate under the null is at most 5 %.
  constexpr double kFalseAlarmLevel = 0.01;
  for (const CandidateScore& s : c.diagnosis.screened) {
    EXPECT_TRUE(s.failure.empty()) << s.candidate.Name() << ": " << s.failure;
    EXPECT_GE(s.p_value, kFalseAlarmLevel) << s.candidate.Name() << " LM " << s.score;
  }
}

// A slow slide (velocities of a few cm/s) with a Coulomb level in the nominal model and, in the
// truth, a Stribeck excess of exponent 1 at vs = 1 cm/s with a hard sign tanh(v / 0.1 mm/s). The
// blocks' default steepness (100 s/m) would flatten a hump this narrow into a ramp that a power
// law fits about as well; the Stribeck candidate's steepness scales with the axis velocity.
TEST(ScreenAndRefit, StribeckExcessBesideACoulombLevelOnASlowAxis) {
  constexpr double kTruthCoulomb = 1.0;       // [N]
  constexpr double kTruthExcess = 0.6;        // [N]
  constexpr double kTruthVs = 0.01;           // [m/s]
  constexpr double kTruthSignWidth = 1.0e-4;  // [m/s]
  testing::SlideTruth truth;
  truth.viscous = 30.0;
  truth.samples = 600;
  truth.substeps = 200;  // the hard sign: slope 1.6e4 N s/m at rest
  truth.noise_std = 1.0e-3;
  truth.friction = [&](double v) {
    return (kTruthCoulomb + kTruthExcess * std::exp(-std::fabs(v) / kTruthVs)) *
           std::tanh(v / kTruthSignWidth);
  };
  std::mt19937 rng(testing::TestSeed(20261127u));
  const std::vector<est::SplitData> splits = {
      testing::SlideSplit(truth, "estimation", est::SplitRole::kEstimation, 0.0, &rng),
      testing::SlideSplit(truth, "validation", est::SplitRole::kValidation, 0.7, &rng)};

  models::Model m("slide");
  m.AddInput("force", "N", "drive force", -5.0, 5.0);
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  models::BlockOptions coulomb = prismatic;
  coulomb.numbers["steepness"] = {1.0e3};
  m.AddBlock("load", "mechanics.mass", prismatic, {"force"}, {});
  m.AddBlock("viscous", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  m.AddBlock("coulomb", "friction.coulomb", coulomb, {"load.qd"}, {"-force"});
  m.SetParameter("load.mass", 1.5);
  m.SetParameter("viscous.fv", 20.0);
  m.SetParameter("coulomb.fc", 0.8);
  m.AddOutput("load.qd");
  est::EstimationSpec spec;
  spec.step.substeps = 10;  // steep signs: RK4 stays inside its stability region
  const est::Problem problem = est::MakeProblem("slide", m, spec);
  const est::FitResult nominal = est::Fit(problem, splits);
  ASSERT_TRUE(nominal.IsSolutionUsable()) << nominal.BriefReport();

  ScreeningOptions options;
  // A budget that binds stops a re-fit at an iteration that depends on the CPU time its iterations
  // take (cache and frequency effects of a loaded machine); one that never binds on these small
  // problems keeps the test deterministic.
  options.refit_max_seconds = kRefitSecondsThatNeverBind;
  options.candidates.effects = {"stribeck", "power_law_viscous"};
  options.refit_top = 2;
  options.progress = [](const std::string& line) { std::cout << line << "\n"; };
  const Diagnosis d = ScreenAndRefit(problem, splits, nominal, options);
  std::cout << d.FullReport();
  ASSERT_FALSE(d.refits.empty());
  const RefitResult& best = d.refits.front();
  EXPECT_EQ(best.effect, "stribeck");
  EXPECT_TRUE(best.ok) << best.failure;
  // The exponent differs (2 against the truth's 1), so much of the error stays (measured: 47 %
  // closed); the level is the truth's within kLevelTolerance (measured 0.43 N against 0.6 N; with
  // the default steepness the re-fit ran to 3.1 N at vs = 3.7 mm/s, a ramp, not the hump).
  constexpr double kMinGapClosed = 0.4;
  constexpr double kLevelTolerance = 0.4;  // relative
  EXPECT_GT(best.relative_gain, kMinGapClosed);
  double fs = 0.0;
  for (const est::FitParameter& p : best.parameters) {
    if (p.name == "stribeck.fs") fs = p.value;
  }
  EXPECT_NEAR(fs, kTruthExcess, kLevelTolerance * kTruthExcess);
}

}  // namespace
}  // namespace graybox::diagnosis
