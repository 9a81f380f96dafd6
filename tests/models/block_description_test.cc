// ListBlocks and DescribeBlock (block_description.h): every registered type is listed and
// described (with its example options where it needs some), the described equations are the
// block's own expressions (a viscous term and the Stribeck curve with the given steepness), and
// unknown types and options are errors with a suggestion.
#include "graybox/models/block_description.h"

#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace graybox::models {
namespace {

int CountLines(const std::string& text) {
  int n = 0;
  for (const char c : text) n += c == '\n' ? 1 : 0;
  return n;
}

TEST(BlockDescription, EveryRegisteredTypeIsListedOnItsOwnLine) {
  const std::string list = ListBlocks();
  const auto types = BlockRegistry::Global().Types();
  EXPECT_EQ(CountLines(list), static_cast<int>(types.size()));
  std::istringstream lines(list);
  std::string line;
  for (const std::string& type : types) {
    ASSERT_TRUE(std::getline(lines, line));
    EXPECT_EQ(line.rfind(type + " ", 0), 0u) << line;
    EXPECT_EQ(line.find("not created"), std::string::npos) << line;
  }
}

TEST(BlockDescription, EveryTypeIsDescribedWithEachSignalParameterAndEquation) {
  const BlockRegistry& registry = BlockRegistry::Global();
  for (const std::string& type : registry.Types()) {
    const std::string text = DescribeBlock(type, registry.TestOptions(type));
    const auto block = registry.Create(type, registry.TestOptions(type));
    const BlockInfo& info = block->info();
    for (const ParameterInfo& p : info.parameters) {
      EXPECT_NE(text.find("\n  " + p.name + " [" + p.unit + "] nominal"), std::string::npos)
          << type << ": " << p.name;
    }
    for (const SignalInfo& y : info.outputs) {
      EXPECT_NE(text.find("\n  " + y.name + " = "), std::string::npos) << type << ": " << y.name;
    }
    for (const SignalInfo& x : info.states) {
      EXPECT_NE(text.find("\n  d " + x.name + "/dt = "), std::string::npos)
          << type << ": " << x.name;
    }
  }
}

TEST(BlockDescription, EquationsAreTheBlocksOwnExpressions) {
  const std::string viscous = DescribeBlock("friction.viscous", {});
  EXPECT_NE(viscous.find("\n  tau = (qd*fv)\n"), std::string::npos) << viscous;
  BlockOptions o;
  o.numbers["steepness"] = {300.0};
  o.words["motion"] = "prismatic";
  const std::string stribeck = DescribeBlock("friction.stribeck", o);
  EXPECT_NE(stribeck.find("tanh((qd*300))"), std::string::npos) << stribeck;
  EXPECT_NE(stribeck.find("fs [N]"), std::string::npos) << stribeck;
  EXPECT_NE(stribeck.find("steepness = 300"), std::string::npos) << stribeck;
  // A long expression is summarised by its size.
  BlockDescriptionOptions shortest;
  shortest.max_equation_chars = 5;
  const std::string summarised = DescribeBlock("friction.stribeck", o, shortest);
  EXPECT_NE(summarised.find("nodes; too long to print"), std::string::npos) << summarised;
}

TEST(BlockDescription, ATypeThatNeedsOptionsIsShownWithItsExampleOptions) {
  const std::string text = DescribeBlock("network.mlp", {});
  EXPECT_NE(text.find("it needs options"), std::string::npos) << text;
  EXPECT_NE(text.find("shown with its example options"), std::string::npos) << text;
  EXPECT_NE(text.find("equations"), std::string::npos) << text;
}

TEST(BlockDescription, UnknownTypesAndOptionsAreErrorsWithASuggestion) {
  try {
    DescribeBlock("friction.colomb", {});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'friction.coulomb'"), std::string::npos)
        << e.what();
  }
  BlockOptions typo;
  typo.numbers["stepness"] = {3.0};
  try {
    DescribeBlock("friction.coulomb", typo);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'steepness'"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace graybox::models
