// The diagnosis on real data (../shared/data/emps): the EMPS closed loop of
// problems/emps/emps_closed_loop.toml built in C++ with one friction term withheld from the
// nominal model, fitted on DATA_EMPS by multiple shooting, then screened and re-fitted; the
// held-out DATA_EMPS_PULSES record is the test split that scores the re-fits. Nothing here is
// tuned to the data: the candidates come from the model's metadata, the options are the defaults.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "graybox/diagnosis/screening.h"
#include "graybox/estimators/fit/fit.h"

namespace graybox::diagnosis {
namespace {

namespace est = graybox::estimators;

const std::string kProblem =
    std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop.toml";

bool HaveEmps() {
  return std::filesystem::exists(std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat");
}

// The closed loop of emps_closed_loop.toml without the friction block `withheld` ("coulomb" or
// "offset"), its parameters set as the file sets them.
est::Problem WithoutFriction(const est::Problem& file, const std::string& withheld) {
  models::BlockOptions prismatic;
  prismatic.words["motion"] = "prismatic";
  models::Model m("emps_without_" + withheld);
  m.AddInput("qr_rate", "m/s", "forward difference of the reference qg", -0.3, 0.3);
  m.AddInput("pulse", "1", "force pulses pulses_N at the controller output", 0.0, 5.0);
  models::BlockOptions integrator;
  integrator.words = {{"input_unit", "m/s"}, {"output_unit", "m"}};
  m.AddBlock("reference", "signal.integrator", integrator, {"qr_rate"}, {});
  m.AddBlock("controller", "control.cascade_p", {}, {"reference.y", "load.q", "load.qd"}, {"nu"});
  models::BlockOptions volts;
  volts.words = {{"input_unit", "1"}, {"output_unit", "V"}};
  m.AddBlock("pulse_gain", "signal.gain", volts, {"pulse"}, {"nu"});
  models::BlockOptions newtons;
  newtons.words = {{"input_unit", "V"}, {"output_unit", "N"}};
  m.AddBlock("drive", "signal.gain", newtons, {"nu"}, {"force"});
  m.AddBlock("load", "mechanics.mass", {}, {"force"}, {});
  m.AddBlock("viscous", "friction.viscous", prismatic, {"load.qd"}, {"-force"});
  if (withheld != "coulomb") {
    models::BlockOptions coulomb = prismatic;
    coulomb.numbers["steepness"] = {1.0e3};
    m.AddBlock("coulomb", "friction.coulomb", coulomb, {"load.qd"}, {"-force"});
  }
  if (withheld != "offset") {
    m.AddBlock("offset", "friction.offset", prismatic, {"load.qd"}, {"-force"});
  }
  m.AddOutput("load.q");
  m.AddOutput("nu");
  for (const models::ModelParameter& p : file.built.parameters) {
    bool present = false;
    for (const models::ModelParameter& q : m.parameters()) present = present || q.name == p.name;
    if (!present) continue;
    models::ModelParameter& q = m.Parameter(p.name);
    q.value = p.value;
    q.free = p.free;
    q.lower = p.lower;
    q.upper = p.upper;
    q.scale = p.scale;
  }
  return est::MakeProblem(m.name(), m, file.estimation);
}

// The pass mark: the shrinkage the accepted effect gives is within 25 % of what fitting
// the true structure (the file's complete model) gives.
constexpr double kShrinkageRelTol = 0.25;

// The test-split NRMSE of the file's complete model fitted on the estimation split.
double TrueStructureNrmse() {
  const est::Problem file = est::LoadProblem(kProblem);
  est::FitOptions fit_options;
  fit_options.compute_covariance = false;
  const est::FitResult full = est::Fit(file, est::LoadData(file), fit_options);
  return full.Evaluation("test_pulses").simulation.overall.nrmse;
}

void ExpectShrinkageOfTheTrueStructure(const RefitResult& best,
                                       double truth = TrueStructureNrmse()) {
  const double estimated = best.validation_nrmse_before - best.validation_nrmse_after;
  const double achievable = best.validation_nrmse_before - truth;
  std::cout << "test NRMSE: nominal " << best.validation_nrmse_before << ", with " << best.effect
            << " " << best.validation_nrmse_after << ", true structure " << truth << "; shrinkage "
            << estimated << " of " << achievable << std::endl;
  ASSERT_GT(achievable, 0.0);
  EXPECT_LT(std::fabs(estimated / achievable - 1.0), kShrinkageRelTol);
}

Diagnosis DiagnoseWithout(const std::string& withheld) {
  const est::Problem file = est::LoadProblem(kProblem);
  const std::vector<est::SplitData> splits = est::LoadData(file);
  const est::Problem nominal_problem = WithoutFriction(file, withheld);
  est::FitOptions fit_options;
  fit_options.compute_covariance = false;
  const est::FitResult nominal = est::Fit(nominal_problem, splits, fit_options);
  EXPECT_TRUE(nominal.IsSolutionUsable()) << nominal.FullReport();
  ScreeningOptions options;
  options.progress = [](const std::string& line) { std::cout << line << std::endl; };
  const Diagnosis d = ScreenAndRefit(nominal_problem, splits, nominal, options);
  std::cout << d.FullReport() << std::endl;
  return d;
}

TEST(EmpsDiagnosis, WithheldCoulombFrictionIsNamedAndShrinksTheErrorAsTheTrueStructure) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data in " << GRAYBOX_SHARED_DATA_DIR;
  const Diagnosis d = DiagnoseWithout("coulomb");
  ASSERT_FALSE(d.screened.empty());
  ASSERT_FALSE(d.refits.empty());
  const std::string top = d.screened.front().candidate.effect;
  EXPECT_TRUE(top == "coulomb" || top == "stribeck") << d.BriefReport();
  const RefitResult& best = d.refits.front();
  ASSERT_TRUE(best.ok) << best.failure;
  EXPECT_TRUE(best.effect == "coulomb" || best.effect == "stribeck") << d.BriefReport();
  EXPECT_LT(best.validation_nrmse_after, best.validation_nrmse_before);
  EXPECT_EQ(d.validation_role, "test");
  ExpectShrinkageOfTheTrueStructure(best);
}

TEST(EmpsDiagnosis, WithheldAsymmetryIsNamedAndShrinksTheErrorAsTheTrueStructure) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data in " << GRAYBOX_SHARED_DATA_DIR;
  const Diagnosis d = DiagnoseWithout("offset");
  ASSERT_FALSE(d.screened.empty());
  // On this closed loop a force on the axis that is constant while it moves (the withheld
  // asymmetry, as a constant or a direction-dependent level) and an offset of the logged command
  // nu are one signature: they score within 3 % of each other and their re-fits reach test NRMSEs
  // within 0.5 %. Any of them names the withheld term.
  auto same_signature = [](const std::string& e) {
    return e == "asymmetric_friction" || e == "sensor_offset";
  };
  EXPECT_TRUE(same_signature(d.screened.front().candidate.effect)) << d.BriefReport();
  ASSERT_FALSE(d.refits.empty());
  // A re-fit may rank above the withheld term only by explaining more than the true structure
  // does: on EMPS a scale of the logged voltage nu reaches test NRMSE 0.046 against the true
  // structure's 0.051 (the full diagnosis accepts both, docs/diagnosis.md).
  const double truth = TrueStructureNrmse();
  const RefitResult* best = nullptr;
  for (const RefitResult& r : d.refits) {
    if (!r.ok) continue;
    if (same_signature(r.effect)) {
      best = &r;
      break;
    }
    EXPECT_LT(r.validation_nrmse_after, truth) << r.effect << " ranks above the withheld term";
  }
  ASSERT_NE(best, nullptr) << d.FullReport();
  bool asymmetry_refitted = false;
  for (const RefitResult& r : d.refits) asymmetry_refitted |= r.effect == "asymmetric_friction";
  EXPECT_TRUE(asymmetry_refitted) << d.FullReport();
  EXPECT_LT(best->validation_nrmse_after, best->validation_nrmse_before);
  ExpectShrinkageOfTheTrueStructure(*best, truth);
}

}  // namespace
}  // namespace graybox::diagnosis
