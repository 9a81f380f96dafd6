// `graybox diagnose` end to end on the real EMPS records: the closed loop without Coulomb friction
// (problems/emps/emps_closed_loop_no_coulomb.toml) is diagnosed with a restricted candidate list,
// and diagnosis.json names coulomb friction as the accepted effect; bad options are bad input
// that writes nothing.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "test_util.h"

namespace graybox::apps_testing {
namespace {

using Json = nlohmann::json;

const std::string kProblem =
    std::string(GRAYBOX_SOURCE_DIR) + "/problems/emps/emps_closed_loop_no_coulomb.toml";
const std::string kEmpsData = std::string(GRAYBOX_SHARED_DATA_DIR) + "/emps/DATA_EMPS.mat";
bool HaveEmps() { return fs::exists(kEmpsData); }

// The test NRMSE of the nominal model (0.0943) and with Coulomb friction (0.0565), as the library
// test tests/diagnosis/emps_diagnosis_test.cc measures them: coulomb closes 40 % of it. The
// bound leaves room for solver tolerances on other machines.
constexpr double kMinGapClosed = 0.3;

TEST(DiagnoseCli, EmpsWithoutCoulombNamesCoulombInDiagnosisJson) {
  if (!HaveEmps()) GTEST_SKIP() << "no EMPS data at " << kEmpsData;
  ScratchDir dir;
  const RunResult r = RunGraybox("diagnose '" + kProblem + "' --out '" + (dir / "out") +
                                     "' --effects coulomb,viscous,asymmetric_friction "
                                     "--refit-top 1 --max-effects 1",
                                 dir / "log.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("round 1: screening"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("verdict: the gap lies in"), std::string::npos) << r.output;
  const Json d = Json::parse(ReadText(dir / "out/diagnosis.json"));
  EXPECT_EQ(d["schema"], 1);
  EXPECT_EQ(d["validation_role"], "test");
  ASSERT_EQ(d["accepted"].size(), 1u) << d["stop_reason"];
  EXPECT_EQ(d["accepted"][0]["effect"], "coulomb");
  EXPECT_GT(d["accepted"][0]["gap_closed"].get<double>(), kMinGapClosed);
  EXPECT_LT(d["remainder"]["validation_nrmse"].get<double>(),
            d["nominal"]["validation_nrmse"].get<double>());
  // viscous and the constant offset are on the axis already: coulomb and the direction-dependent
  // level are the candidates left.
  EXPECT_EQ(d["rounds"][0]["screened"].size(), 2u);
  EXPECT_FALSE(d["run"]["revision"].get<std::string>().empty());
  EXPECT_TRUE(fs::exists(dir / "out/report.html"));
  EXPECT_TRUE(d["reference"]["ok"].get<bool>()) << d["reference"]["failure"];

  // The accepted candidate as problem-file text: appended to the problem file (its
  // [[model.augment]] table at the end, its parameter lines in [model.parameters]) and fitted from
  // the diagnosis' start, it gives the re-fit's Coulomb level again.
  const Json& refit = d["rounds"][0]["refits"][0];
  ASSERT_EQ(refit["effect"], "coulomb");
  const std::string augment = refit["augment_toml"];
  const std::string parameters = refit["parameters_toml"];
  EXPECT_NE(augment.find("type = \"friction.coulomb\""), std::string::npos) << augment;
  EXPECT_NE(augment.find("steepness"), std::string::npos) << augment;
  std::string text = ReadText(kProblem);
  const std::string data_prefix = "\"../../../shared/data/";
  for (std::size_t p = text.find(data_prefix); p != std::string::npos;
       p = text.find(data_prefix, p)) {
    text.replace(p, data_prefix.size(), "\"" + std::string(GRAYBOX_SHARED_DATA_DIR) + "/");
  }
  const std::string table = "[model.parameters]\n";
  ASSERT_NE(text.find(table), std::string::npos);
  text.insert(text.find(table) + table.size(), parameters);
  WriteText(dir / "with_coulomb.toml", text + "\n" + augment);
  const RunResult fit =
      RunGraybox("fit '" + (dir / "with_coulomb.toml") + "' --out '" + (dir / "fit") + "'",
                 dir / "fit_log.txt");
  ASSERT_EQ(fit.exit_code, 0) << fit.output;
  const Json result = Json::parse(ReadText(dir / "fit/result.json"));
  double refit_fc = 0.0;
  for (const Json& p : refit["parameters"]) {
    if (p["name"] == "coulomb.fc") refit_fc = p["value"];
  }
  ASSERT_GT(refit_fc, 0.0);
  // The same problem and start: the same optimum, to the solvers' tolerance.
  constexpr double kRelativeTolerance = 1e-3;
  EXPECT_NEAR(result["parameters"]["coulomb.fc"]["value"].get<double>(), refit_fc,
              kRelativeTolerance * refit_fc);
}

TEST(DiagnoseCli, UnknownEffectIsBadInputAndWritesNothing) {
  ScratchDir dir;
  const RunResult r =
      RunGraybox("diagnose '" + kProblem + "' --out '" + (dir / "out") + "' --effects colomb",
                 dir / "log.txt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("coulomb"), std::string::npos) << r.output;  // did-you-mean
  EXPECT_FALSE(fs::exists(dir / "out"));
}

}  // namespace
}  // namespace graybox::apps_testing
