// ProblemOverride (graybox/estimators/problem/problem_file.h): keys of a problem file set from
// outside it, as a bench suite's variations set them: replaced and added keys, quoted key parts,
// and located errors for a bad key, a bad value and a defect the override causes.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "graybox/estimators/problem/problem_file.h"
#include "test_util.h"

namespace graybox::estimators {
namespace {

using apps_testing::PushedProblem;

ProblemOverride Override(const std::string& key, const std::string& value) {
  ProblemOverride o;
  o.key = key;
  o.value = value;
  o.origin.file = "suite.toml";
  o.origin.line = 7;
  return o;
}

std::string ErrorOf(const std::vector<ProblemOverride>& overrides) {
  try {
    ParseProblem(PushedProblem(), "/tmp/pushed.toml", overrides);
  } catch (const ProblemFileError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a ProblemFileError";
  return "";
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(ProblemOverrides, ReplaceAndAddKeys) {
  const Problem plain = ParseProblem(PushedProblem(), "/tmp/pushed.toml");
  ASSERT_EQ(plain.estimation.method, "multiple_shooting");
  ASSERT_EQ(plain.estimation.multiple_shooting.segment_length, 25);
  const Problem p =
      ParseProblem(PushedProblem(), "/tmp/pushed.toml",
                   {Override("estimation.multiple_shooting.segment_length", "10"),
                    Override("estimation.solver", "\"ceres\""), Override("estimation.seed", "42"),
                    Override("model.parameters.\"load.mass\"", "{ value = 3.5, scale = 2.0 }")});
  EXPECT_EQ(p.estimation.multiple_shooting.segment_length, 10);
  EXPECT_EQ(p.estimation.solver, "ceres");
  EXPECT_EQ(p.estimation.seed, 42u);  // added: the file has no seed
  const int mass = p.built.ParameterIndex("load.mass");
  ASSERT_GE(mass, 0);
  EXPECT_EQ(p.built.parameters[mass].value, 3.5);
  EXPECT_EQ(p.built.parameters[mass].scale, 2.0);
  // A table the file lacks is created on the way.
  const Problem q = ParseProblem(PushedProblem(""), "/tmp/pushed.toml",
                                 {Override("estimation.method", "\"single_shooting\"")});
  EXPECT_EQ(q.estimation.method, "single_shooting");
}

TEST(ProblemOverrides, DefectsAreLocated) {
  // Not TOML: at the override's origin.
  std::string e = ErrorOf({Override("estimation.method", "collocation")});
  EXPECT_TRUE(Contains(e, "suite.toml:7:")) << e;
  EXPECT_TRUE(Contains(e, "expected a TOML value")) << e;
  // A path through a value that is not a table.
  e = ErrorOf({Override("estimation.method.kind", "\"x\"")});
  EXPECT_TRUE(Contains(e, "suite.toml:7:")) << e;
  EXPECT_TRUE(Contains(e, "'estimation.method' is not a table")) << e;
  // Malformed keys.
  for (const char* key : {"", "estimation.", ".method", "model.parameters.\"load.mass"}) {
    e = ErrorOf({Override(key, "1")});
    EXPECT_TRUE(Contains(e, "suite.toml:7:")) << key << ": " << e;
  }
  // A value the problem file's checks refuse: the file's message, with the overrides applied.
  e = ErrorOf({Override("estimation.method", "\"colocation\"")});
  EXPECT_TRUE(Contains(e, "did you mean 'collocation'")) << e;
  EXPECT_TRUE(Contains(e, "(overrides: estimation.method = \"colocation\")")) << e;
  // An unknown key added by an override: the unknown-key message with its suggestion.
  e = ErrorOf({Override("estimation.segment_lenght", "10")});
  EXPECT_TRUE(Contains(e, "unknown key 'segment_lenght'")) << e;
}

}  // namespace
}  // namespace graybox::estimators
