// libFuzzer harness: the equation parser of equation blocks (models::MakeEquationBlock). The
// input's first line is the derivative of the state h, the second the output y; both may use the
// input u, the parameter a, the constant g and the usual functions. A block that parses is
// evaluated once on doubles (a NaN or Inf there is a value, not a defect). Seeds:
// tests/fuzz/seeds/equations.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "fuzz_common.h"
#include "graybox/models/block.h"
#include "graybox/models/equation_block.h"
#include "graybox/models/model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::size_t newline = text.find('\n');
  graybox::models::BlockOptions o;
  o.words["inputs"] = "u";
  o.words["states"] = "h";
  o.words["outputs"] = "y";
  o.words["parameters"] = "a";
  o.words["constants"] = "g";
  o.numbers["constant.g"] = {9.81};
  o.numbers["nominal.a"] = {0.5};
  o.words["derivative.h"] = text.substr(0, newline);
  o.words["value.y"] = newline == std::string::npos ? "h" : text.substr(newline + 1);
  graybox::fuzz::ExpectCleanRejection([&] {
    const std::shared_ptr<const graybox::models::Block> block =
        graybox::models::MakeEquationBlock(o);
    graybox::models::Model m("fuzz");
    m.AddInput("u", "1");
    m.AddBlock("eq", block, {"u"}, {"y"});
    m.AddOutput("y");
    const graybox::models::StateSpaceModel built = m.Build();
    const Eigen::VectorXd x = Eigen::VectorXd::Constant(built.NumStates(), 0.3);
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(built.NumInputs(), -0.7);
    const Eigen::VectorXd p = built.ParameterValues();
    built.dynamics({x, u, p});
    built.output({x, u, p});
  });
  return 0;
}
