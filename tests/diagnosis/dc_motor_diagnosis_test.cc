// The diagnosis on real data (../shared/data/geared_dc_motor_ayankoso): the linear first-order
// motor model of problems/geared_dc_motor/dc_motor_linear.toml, fitted on the training run, then
// screened and re-fitted with the candidates whose signature on this one-directional record is a
// constant torque (an offset, Coulomb friction, a dead zone of the duty); the repeat run is the
// test split that scores the re-fits. The measured static map is concave (saturating), so the
// constant torque the data ask for drives the shaft: the offset takes it, while Coulomb friction
// and the dead zone, which can only oppose the drive, stay at their bound 0.
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
    std::string(GRAYBOX_SOURCE_DIR) + "/problems/geared_dc_motor/dc_motor_linear.toml";

bool HaveMotorData() {
  return std::filesystem::exists(
      std::string(GRAYBOX_SHARED_DATA_DIR) +
      "/geared_dc_motor_ayankoso/DC_Motor_experimental_data_testing.csv");
}

// Test NRMSE of the linear model, measured once (problems/geared_dc_motor/README.md); the
// tolerance covers solver and platform differences, not a change of the model or the data.
constexpr double kNominalTestNrmse = 0.7694;
constexpr double kNominalRelTol = 0.01;
// The offset's re-fit removed 74 % of the nominal test NRMSE (0.7694 -> 0.1982); the pass mark
// asks for most of it.
constexpr double kMinRelativeGain = 0.6;

const RefitResult* FindRefit(const Diagnosis& d, const std::string& effect) {
  for (const RefitResult& r : d.refits) {
    if (r.effect == effect) return &r;
  }
  return nullptr;
}

TEST(DcMotorDiagnosis, AConstantTorqueIsNamedAndTheTestErrorDrops) {
  if (!HaveMotorData()) GTEST_SKIP() << "no geared DC motor data in " << GRAYBOX_SHARED_DATA_DIR;
  const est::Problem problem = est::LoadProblem(kProblem);
  const std::vector<est::SplitData> splits = est::LoadData(problem);
  est::FitOptions fit_options;
  fit_options.compute_covariance = false;
  const est::FitResult nominal = est::Fit(problem, splits, fit_options);
  ASSERT_TRUE(nominal.IsSolutionUsable()) << nominal.FullReport();

  ScreeningOptions options;
  options.candidates.effects = {"asymmetric_friction", "coulomb", "deadzone"};
  options.refit_top = 4;  // every candidate (two asymmetric_friction variants)
  options.progress = [](const std::string& line) { std::cout << line << std::endl; };
  const Diagnosis d = ScreenAndRefit(problem, splits, nominal, options);
  std::cout << d.FullReport() << std::endl;

  EXPECT_EQ(d.validation_role, "test");
  EXPECT_NEAR(d.nominal_validation_nrmse, kNominalTestNrmse, kNominalRelTol * kNominalTestNrmse);
  ASSERT_EQ(d.refits.size(), 4u);
  const RefitResult& best = d.refits.front();
  ASSERT_TRUE(best.ok) << best.failure;
  EXPECT_FALSE(best.at_bound);
  EXPECT_EQ(best.effect, "asymmetric_friction") << d.BriefReport();
  EXPECT_GE(best.relative_gain, kMinRelativeGain) << d.BriefReport();
  // The constant offset (f_asym) or the direction-dependent level (fd, with its even viscous
  // term held at 0): either way negative, a torque that drives the shaft.
  ASSERT_GE(best.parameters.size(), 1u);
  EXPECT_LT(best.parameters[0].value, 0.0) << "the constant torque drives the shaft";
  for (const std::string effect : {"coulomb", "deadzone"}) {
    const RefitResult* r = FindRefit(d, effect);
    ASSERT_NE(r, nullptr) << effect;
    EXPECT_TRUE(r->at_bound) << effect << " is expected at its bound 0: " << d.FullReport();
  }
}

}  // namespace
}  // namespace graybox::diagnosis
