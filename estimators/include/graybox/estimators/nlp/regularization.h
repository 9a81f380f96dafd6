// Regularisation of the free model parameters: a quadratic penalty added to any identification
// NLP built by the formulations (multiple shooting, single shooting, collocation, equation error,
// N-step loss).
//
// For every term t and every free parameter theta_i it selects,
//     r_i = sqrt(2 lambda_t) (theta_i - theta_ref,i),
// is appended to the NLP's residuals, so the objective gains
//     1/2 |r|^2 = lambda_t sum_i (theta_i - theta_ref,i)^2,
// in the parameters' own units (lambda in [objective unit] / [parameter unit]^2). With
// theta_ref = 0 this is weight decay (L2) on, for example, an embedded network's weights
// (seed 000 trains its networks with weight decay); with theta_ref = the initial values it is a
// Gaussian prior centred on them (ridge towards a nominal model). The data term of the
// simulation formulations is 1/2 sum_k |w o (y_hat_k - y_k)|^2, which grows with the number of
// samples; lambda does not, so its effect weakens as the record grows, as with any prior.
//
// The penalty is an ordinary residual group, so Ipopt (objective and exact Hessian) and Ceres
// (least squares) see it alike, and the Gauss-Newton covariance includes it as prior information
// (intervals of strongly regularised parameters shrink accordingly).
//
//   RegularizationOptions reg;
//   reg.terms.push_back({"decay", 1e-4, RegularizationReference::kZero, network_indices});
//   AddRegularization(problem.parameters, reg, &problem.nlp);
#pragma once

#include <string>
#include <vector>

#include "graybox/estimators/nlp/nlp.h"
#include "graybox/estimators/nlp/parameter_map.h"

namespace graybox::estimators {

/// What a regularised parameter is pulled towards.
enum class RegularizationReference {
  kZero,     // weight decay
  kInitial,  // the parameter's value when the problem was built (ParameterMap::values)
};

/// "zero" or "initial".
const char* RegularizationReferenceName(RegularizationReference reference);
/// Inverse of RegularizationReferenceName; std::invalid_argument with a did-you-mean otherwise.
RegularizationReference ParseRegularizationReference(const std::string& name);

struct RegularizationTerm {
  /// For reports and error messages ("decay").
  std::string name;
  /// lambda >= 0 (0 adds nothing).
  double weight = 0.0;
  RegularizationReference reference = RegularizationReference::kZero;
  /// Model parameter indices (into the model's parameter vector); each must be free.
  std::vector<int> parameters;
};

struct RegularizationOptions {
  std::vector<RegularizationTerm> terms;
  /// Throws std::invalid_argument naming the term: a weight negative or not finite, a repeated
  /// parameter index within a term.
  void Validate() const;
};

/// Appends one residual group "regularization.<term>" per term with a positive weight. Throws
/// std::invalid_argument naming the term and the parameter when an index is out of range or the
/// parameter is not free (a fixed parameter has nothing to regularise).
void AddRegularization(const ParameterMap& map, const RegularizationOptions& options, Nlp* nlp);

}  // namespace graybox::estimators
