#include "graybox/estimators/nlp/regularization.h"
#include "graybox/util/did_you_mean.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "graybox/models/block.h"

namespace graybox::estimators {

using expr::Expr;
using expr::Function;

const char* RegularizationReferenceName(RegularizationReference reference) {
  switch (reference) {
    case RegularizationReference::kZero:
      return "zero";
    case RegularizationReference::kInitial:
      return "initial";
  }
  return "unknown";
}

RegularizationReference ParseRegularizationReference(const std::string& name) {
  for (RegularizationReference r :
       {RegularizationReference::kZero, RegularizationReference::kInitial}) {
    if (name == RegularizationReferenceName(r)) return r;
  }
  const std::string hint = util::DidYouMean(name, {"zero", "initial"});
  throw std::invalid_argument("regularization reference: expected 'zero' or 'initial', got '" +
                              name + "'" + (hint.empty() ? "" : "; did you mean '" + hint + "'?"));
}

void RegularizationOptions::Validate() const {
  for (const RegularizationTerm& t : terms) {
    if (!(t.weight >= 0.0) || !std::isfinite(t.weight)) {
      throw std::invalid_argument("regularization term '" + t.name +
                                  "': expected a finite weight >= 0, got " +
                                  std::to_string(t.weight));
    }
    std::vector<int> sorted = t.parameters;
    std::sort(sorted.begin(), sorted.end());
    const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
    if (dup != sorted.end()) {
      throw std::invalid_argument("regularization term '" + t.name + "': parameter index " +
                                  std::to_string(*dup) + " appears twice");
    }
  }
}

void AddRegularization(const ParameterMap& map, const RegularizationOptions& options, Nlp* nlp) {
  options.Validate();
  // One element per regularised parameter: z = (scaled variable), d = (scale, reference,
  // sqrt(2 lambda)), r = sqrt(2 lambda) (scale z - reference).
  const std::vector<Expr> z = Expr::Symbols("w", 1), d = Expr::Symbols("d", 3);
  const Function element("regularization", {{"z", z}, {"d", d}},
                         {{"r", {d[2] * (d[0] * z[0] - d[1])}}});
  for (const RegularizationTerm& t : options.terms) {
    if (t.weight == 0.0 || t.parameters.empty()) continue;
    ElementGroup group{"regularization." + t.name,
                       element,
                       Eigen::MatrixXi(1, static_cast<Eigen::Index>(t.parameters.size())),
                       Eigen::MatrixXd(3, static_cast<Eigen::Index>(t.parameters.size())),
                       Eigen::VectorXd(),
                       Eigen::VectorXd()};
    for (std::size_t k = 0; k < t.parameters.size(); ++k) {
      const int p = t.parameters[k];
      if (p < 0 || p >= static_cast<int>(map.values.size())) {
        throw std::invalid_argument(
            "regularization term '" + t.name + "': expected a parameter index in [0, " +
            std::to_string(map.values.size()) + "), got " + std::to_string(p));
      }
      const auto it = std::find(map.free.begin(), map.free.end(), p);
      if (it == map.free.end()) {
        const std::string name =
            p < static_cast<int>(map.source.size()) ? map.source[p].name : std::to_string(p);
        throw std::invalid_argument("regularization term '" + t.name + "': parameter '" + name +
                                    "' is fixed; expected a free parameter");
      }
      const int i = static_cast<int>(it - map.free.begin());
      const Eigen::Index col = static_cast<Eigen::Index>(k);
      group.index(0, col) = i;  // the free parameters are the first variables
      group.data(0, col) = map.scale[i];
      group.data(1, col) = t.reference == RegularizationReference::kZero ? 0.0 : map.values[p];
      group.data(2, col) = std::sqrt(2.0 * t.weight);
    }
    const int r0 = nlp->NumResiduals();
    const int rows = static_cast<int>(group.index.cols());
    nlp->AddGroup(std::move(group));
    const int channel = nlp->ResidualChannel("regularization." + t.name);
    for (int k = 0; k < rows; ++k) nlp->LabelResidual(r0 + k, {-1, -1, channel});
  }
}

}  // namespace graybox::estimators
