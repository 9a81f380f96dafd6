// The withheld-effect benchmark on a fast selection of cases (the CI part of
// `graybox bench withheld`): a Coulomb friction of atan shape withheld from a closed-loop drive
// is named and its shrinkage matches the oracle's; a periodic disturbance (outside the library)
// is left unexplained; the records and bench.json carry the documented fields.
#include "graybox/bench/withheld_bench.h"

#include <cmath>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace graybox::bench {
namespace {

// The pass mark on the shrinkage: within 25 % of what the true structure gives.
constexpr double kShrinkageTolerance = 0.25;

WithheldBench RunSelection() {
  WithheldBenchOptions o;
  o.name_filters = {"drive_cl/coulomb_atan/s1", "drive_cl/periodic_disturbance"};
  o.progress = [](const std::string& line) { std::cout << line << "\n"; };
  const WithheldBench b = RunWithheldBench(o);
  std::cout << b.ConfusionTable() << b.Summary();
  return b;
}

TEST(WithheldBench, CoulombIsNamedAndTheDisturbanceIsLeftUnexplained) {
  const WithheldBench b = RunSelection();
  ASSERT_EQ(b.records.size(), 2u);
  const WithheldRecord& coulomb = b.records[0];
  EXPECT_EQ(coulomb.name, "drive_cl/coulomb_atan/s1");
  EXPECT_TRUE(coulomb.failure.empty()) << coulomb.failure;
  EXPECT_EQ(coulomb.top, "coulomb") << coulomb.verdict;
  EXPECT_TRUE(coulomb.pass);
  EXPECT_LE(coulomb.shrinkage_error, kShrinkageTolerance)
      << "shrinkage " << coulomb.shrinkage << " of " << coulomb.achievable_shrinkage;
  const WithheldRecord& disturbance = b.records[1];
  EXPECT_FALSE(disturbance.in_library);
  EXPECT_EQ(disturbance.top, "none") << disturbance.verdict;
  EXPECT_TRUE(disturbance.pass);
  EXPECT_NE(disturbance.verdict.find("not explained by the candidate library"), std::string::npos)
      << disturbance.verdict;
  EXPECT_DOUBLE_EQ(b.top_ranked_rate, 1.0);
  EXPECT_DOUBLE_EQ(b.unexplained_rate, 1.0);

  const nlohmann::json j = nlohmann::json::parse(WithheldBenchJson(b, {{"seed", "1"}}));
  ASSERT_EQ(j.at("records").size(), 2u);
  for (const char* key : {"case", "withheld", "in_library", "top", "accepted", "top_alternatives",
                          "named_or_equivalent", "shrinkage_error"}) {
    EXPECT_TRUE(j["records"][0].contains(key)) << key;
  }
  EXPECT_EQ(j["records"][0]["withheld"], "coulomb");
  EXPECT_EQ(j["records"][1]["in_library"], false);
  EXPECT_EQ(j["summary"]["num_outside"], 1);
}

TEST(WithheldBench, AFilterMatchingNothingIsAnError) {
  WithheldBenchOptions o;
  o.name_filters = {"no_such_case"};
  EXPECT_THROW(RunWithheldBench(o), std::invalid_argument);
}

}  // namespace
}  // namespace graybox::bench
